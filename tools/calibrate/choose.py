"""The settings `odoerr calibrate` chooses from the data (docs/calibrate.md, "Settings"):
the range sigma from the laser-to-map residuals of a first pass, then checked by tracking:
a few multiples of it are tracked over the first half and the one whose track fits the
map best is kept. The fit is the track's own agreement with the map (each scan's mean over
its end points of exp(-d^2 / 2 (0.1 m)^2), d the distance to the nearest wall, from
`odoerr replay --relocalise`'s tracking.csv), never the log's reference poses: those only
score the result afterwards.
"""
import csv
import math
import os
import statistics

SIGMA_RANGE = (0.03, 0.30)    # m, every range sigma tried stays within
RESIDUAL_BAND = 1.0           # m, the residuals the range sigma is measured on
SIGMA_LADDER = (1.0, 1.5, 2.0, 3.0)  # the candidates: multiples of the residual sigma
# When the first pass itself lost the robot its residuals measure the loss, not the laser:
# the candidates then span the whole range, each 1.5 x the one before.
SIGMA_SPAN = (0.03, 0.045, 0.068, 0.10, 0.15, 0.225, 0.30)
FIT_TIE = 0.01                # mean fits closer than this are a tie: the smaller sigma wins
SAME_SIGMA = 0.10             # candidates closer than 10 % are one


def residual_sigma(innovations_csv):
    """1.4826 x the median absolute innovation of the beams a pass predicted (used or gated)
    within RESIDUAL_BAND of the map (a beam farther off hit something the map lacks, or the
    track was off: it says nothing of the range noise), and how many."""
    vals = []
    with open(innovations_csv, newline="") as f:
        for row in csv.DictReader(f):  # replay's innovations.csv: t,beam,status,...,innovation,...
            if row.get("status") not in ("used", "gated"):
                continue
            try:
                v = abs(float(row["innovation"]))
            except (KeyError, TypeError, ValueError):  # a beam without a prediction: nothing to measure
                continue
            if v < RESIDUAL_BAND:
                vals.append(v)
    if len(vals) < 100:
        return None, len(vals)
    return 1.4826 * statistics.median(vals), len(vals)


def clip(v):
    return min(max(v, SIGMA_RANGE[0]), SIGMA_RANGE[1])


def candidates(sig, first_pass_tracked=True):
    """The range sigmas to try: SIGMA_LADDER x sig, clipped; when the first pass lost the
    robot, SIGMA_SPAN instead; near-duplicates dropped."""
    out = []
    for v in ([clip(m * sig) for m in SIGMA_LADDER] if first_pass_tracked else SIGMA_SPAN):
        if all(abs(v - u) > SAME_SIGMA * u for u in out):
            out.append(v)
    return out


def tracking_rows(replay_dir):
    """The rows of a --relocalise replay's tracking.csv (t, x, y, theta, fit, state), as dicts."""
    with open(os.path.join(replay_dir, "tracking.csv"), newline="") as f:
        return list(csv.DictReader(f))


def track_quality(replay_dir, rep):
    """What a --relocalise replay says of its own track: lost at the end, the loss episodes,
    and the mean fit of its scans (a lost stretch's scans fit poorly and pull it down)."""
    fits = []
    for row in tracking_rows(replay_dir):
        try:
            v = float(row["fit"])
        except (KeyError, TypeError, ValueError):
            continue
        if math.isfinite(v):
            fits.append(v)
    t = rep.get("tracking", {})
    return {"lost": bool(t.get("lost", False)), "lost_episodes": int(t.get("lost_episodes", 0)),
            "fit_mean": statistics.fmean(fits) if fits else None, "scans": len(fits)}


def best(tried):
    """tried: [(sigma, quality)], each tracked until its first loss (replay --stop-when-lost).
    The candidate kept: of those never lost, the highest mean fit, and within FIT_TIE of it
    the smallest sigma; when every one was lost, the one that kept the track over the most
    scans. None when no candidate has a fit."""
    pool = [c for c in tried if c[1]["fit_mean"] is not None]
    alive = [c for c in pool if not c[1]["lost"]]
    if not alive:
        return max(pool, key=lambda c: (c[1]["scans"], c[1]["fit_mean"]), default=None)
    top = max(q["fit_mean"] for _, q in alive)
    return min((c for c in alive if c[1]["fit_mean"] >= top - FIT_TIE), key=lambda c: c[0])
