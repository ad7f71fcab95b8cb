#!/usr/bin/env python3
"""odoerr_calibrate.py: `odoerr calibrate LOG --out DIR [--map MAP]`, a real log to a
calibration the user can trust (docs/calibrate.md).

Usage (through `odoerr calibrate`, which adds --odoerr):
    odoerr calibrate LOG --out DIR [--map MAP] [--max-scans N] [--range-sigma S]
                     [--param-sigma P] [--k0 K] [--no-report]

The steps, each an odoerr command or importer (printed as it runs, its output in DIR):
1. the format: an odolog (`odolog 1` first), or a CARMEN log (upper-case message types);
   anything else is refused. A CARMEN log is imported with `--scans --auto`: the time
   base, missing odometry and the laser's no-return code are chosen from the log.
2. the map: --map (.odomap, or a ROS map_server YAML, imported with --faces); else, for a
   CARMEN log, an occupancy grid from its corrected poses and scans, then its line segments
   (what a user's SLAM run would give); else the odolog's own walls.
   The reference the check uses: the log's reference poses ('truth' records, a CARMEN
   log's corrected poses); a log without them is first tracked over its whole length
   against the map (range sigma 0.10 m, relocalisation on), and that track, at the scans
   where it fits the map, stands in for them (DIR/log_reference.odolog). A log with
   neither reference poses nor a map is refused; so is one whose track is lost.
3. the settings, from the data (each value and its reason in calibration.json):
   a first pass of the estimator over the first half gives K_w (the start of K for the
   next passes, within 1e-5-1e-2 m) and the laser-to-map residuals (the residual sigma:
   1.4826 x their median absolute value, those within 1 m); 1, 1.5, 2 and 3 times that
   (within 0.03-0.30 m) are each tracked over the first half and the range sigma whose
   track fits the map best is kept (choose.py); beams are fused most consistent first;
   the drive constants' prior is 5 %.
4. tracking: the whole log against the map with lost-track detection and relocalisation
   (`odoerr replay --relocalise`), scored at the log's reference poses where it has them.
5. calibration: the log cut in two halves of path; the first half calibrates (and its two
   quarters each calibrate, a cross-check); the second half checks: odometry alone with the
   nominal and the calibrated constants, the 5 m relative pose error (`odoerr evaluate`),
   and the error growth that the calibrated K_w predicts against the one observed.
6. the trust rule: the calibration is trusted when the tracking of the first half was
   never lost at its end nor more than 0.5 m RMS off the log's reference poses (where it
   has them), the checked half's 5 m RPE falls in translation or rotation and
   rises in neither by more than 5 %, the predicted growth is within 1.5x of the observed,
   and most of the log's intervals carry raw odometry. The quarters' agreement is reported
   (a note when they are more than 3 sigma apart), not a clause: the filter's sigmas on
   real logs are optimistic.
   Otherwise it is NOT trusted, the reason is said, and the nominal constants stand.
7. the diagnosis and its report page (`odoerr report`) on the first half with the map.

Writes DIR/calibration.json (the contract in docs/real-data.md) and prints a summary.
Exit status 0 when a verdict was reached (trusted or not), 1 when a step failed, 2 on an
input it cannot read or work from (no laser scans; no reference poses and no map; no
reference poses and a track that is lost).
"""
import argparse
import gzip
import json
import math
import os
import re
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
IMPORT_DIR = os.path.join(HERE, "..", "import")
PY = sys.executable
sys.path.insert(0, IMPORT_DIR)
import import_common  # noqa: E402  (the odolog helpers the importers share)
import choose  # noqa: E402  (the settings chosen from the data)

K0_RANGE = (1e-5, 1e-2)       # m, the start of K_w chosen from the first pass stays within
PARAM_SIGMA = 0.05            # the drive constants' prior (relative)
GROWTH_MAX = 1.5              # the predicted growth must be within this factor of the observed
RPE_WORSE_MAX = 1.05          # the checked half's RPE may not rise by more than 5 %
QUARTER_SIGMAS = 3.0          # the quarters' constants more than 3 sigma apart: a note
RAW_ODOMETRY_MIN = 0.5        # at least half of the intervals must carry raw odometry
TRACK_OFF_M = 0.5             # a track farther off the log's reference poses (RMS) is not used
CARMEN_TYPE = re.compile(r"^[A-Z][A-Z0-9_]*$")


class StepError(Exception):
    pass


def log_lines(path, limit=200):
    with open(path, "rb") as f:
        head = f.read(2)
    opener = gzip.open if head == b"\x1f\x8b" else open
    out = []
    with opener(path, "rt", errors="replace") as f:
        for line in f:
            out.append(line)
            if len(out) >= limit:
                break
    return out


def detect_format(path):
    """('odolog' | 'carmen', why); raises ValueError naming the first line when neither."""
    for no, line in enumerate(log_lines(path), 1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("odolog"):
            return "odolog", f"line {no} is the odolog header '{s[:20]}'"
        if s.startswith("#"):
            continue
        word = s.split()[0]
        if CARMEN_TYPE.match(word):
            return "carmen", f"line {no} starts with the CARMEN message type {word}"
        raise ValueError(f"{path}:{no}: neither an odolog (first line 'odolog 1') nor a CARMEN log "
                         f"(lines that start with an upper-case message type): '{s[:40]}'")
    raise ValueError(f"{path}: no line to read")


class Runner:
    def __init__(self, odoerr, out):
        self.odoerr = odoerr
        self.out = out
        self.steps = []

    def path(self, name):
        return os.path.join(self.out, name)

    def run(self, what, cmd):
        shown = " ".join(os.path.relpath(c, self.out) if os.path.isabs(c) and c.startswith(self.out) else c
                         for c in cmd)
        print(f"+ {shown}", flush=True)
        t0 = time.time()
        r = subprocess.run(cmd, capture_output=True, text=True)
        dt = time.time() - t0
        self.steps.append({"step": what, "seconds": round(dt, 1), "status": r.returncode})
        if r.returncode != 0:
            raise StepError(f"{what} failed (exit {r.returncode}): {r.stderr.strip()[-800:]}")
        return r

    def replay(self, what, log, mp, out, settings, relocalise=True, k0=None, stop_when_lost=False):
        cmd = [self.odoerr, "replay", log, "--out", self.path(out), "--order-beams",
               "--range-sigma", f"{settings['range_sigma_m']['value']:.4g}",
               "--param-sigma", f"{settings['param_sigma']['value']:g}"]
        if mp:
            cmd += ["--map", mp]
        k = k0 if k0 is not None else settings.get("k0_m", {}).get("value")
        if k is not None:
            cmd += ["--k0", f"{k:.4g}"]
        if relocalise:
            cmd.append("--relocalise")
            if stop_when_lost:
                cmd.append("--stop-when-lost")
        self.run(what, cmd)
        with open(os.path.join(self.path(out), "replay.json")) as f:
            return json.load(f)


def constants_of(rep):
    f = rep["final"]
    return ({k: f[k]["estimate"] for k in ("delta_R", "delta_L", "delta_d")},
            {k: f[k]["sigma"] for k in ("delta_R", "delta_L", "delta_d")}, f["K_w"]["estimate"])


def meta_value(log, key):
    with open(log) as f:
        for line in f:
            if line.startswith("meta " + key + " "):
                return line.split(" ", 2)[2].strip()
            if line.startswith(("enc ", "scan ")):
                break
    return None


class InputRefused(Exception):
    """An input calibrate cannot work from: exit 2 with the message."""


def record_counts(log):
    """{record type: count} of an odolog."""
    counts = {}
    with open(log) as f:
        for line in f:
            k = line.split(" ", 1)[0].strip()
            counts[k] = counts.get(k, 0) + 1
    return counts


def trust(result, quarters, raw_share):
    """(trusted, reason): the rule of the module's docstring, first failing clause named."""
    tr1 = result["tracking_first_half"]
    if tr1.get("lost"):
        return False, "the track of the first half was lost and not recovered: its calibration is not used"
    off, what = tr1.get("pose_rmse_at_truth_m"), "the log's reference poses"
    if off is None and tr1.get("rmse_to_reference_track_m") is not None:
        off, what = tr1["rmse_to_reference_track_m"], "the reference track (the log has no reference poses)"
    if off is not None and off > TRACK_OFF_M:
        return False, (f"the track of the first half is {off:.2f} m RMS off {what} (more than "
                       f"{TRACK_OFF_M} m): a relocalisation went wrong or the track drifted; its calibration is "
                       f"not used")
    if raw_share is not None and raw_share < RAW_ODOMETRY_MIN:
        return False, (f"only {100 * raw_share:.0f} % of the log's scan intervals carry raw odometry (the rest "
                       f"repeat the corrected pose): the odometry cannot be calibrated from it")
    rpe = result["rpe_5m_second_half"]
    nom, cal = rpe.get("nominal"), rpe.get("calibrated")
    if not nom or not cal:
        return False, "the second half has no 5 m segment to check the calibration on"
    rt, rr = cal["trans_m"] / nom["trans_m"], cal["rot_rad"] / nom["rot_rad"]
    if rt > RPE_WORSE_MAX or rr > RPE_WORSE_MAX:
        return False, (f"on the checked half the calibrated odometry is worse than nominal: 5 m RPE x{rt:.2f} "
                       f"in translation, x{rr:.2f} in rotation")
    if rt >= 1 and rr >= 1:
        return False, "on the checked half the calibration lowers neither the translation nor the rotation error"
    g = result["growth"].get("ratio_observed_to_predicted")
    if g is None:
        return False, "the growth of the error could not be predicted on the checked half"
    if not (1 / GROWTH_MAX <= g <= GROWTH_MAX):
        return False, (f"the error growth K_w predicts is {g:.2f}x off the one observed on the checked half "
                       f"(at most {GROWTH_MAX}x)")
    note = ""
    if quarters and quarters["disagreement_sigma"] > QUARTER_SIGMAS:
        note = (f"; note: the first half's quarters calibrate {quarters['disagreement_sigma']:.1f} sigma apart "
                f"({quarters['worst']}), the filter's sigmas are optimistic on this log")
    return True, (f"the checked half's 5 m RPE falls to x{rt:.2f} in translation and x{rr:.2f} in rotation; the "
                  f"predicted growth is within {GROWTH_MAX}x (x{g:.2f})" + note)


REFERENCE_STATES = ("tracked", "corrected", "recovered")  # tracking.csv states a reference pose is taken at


def tracked_reference(a, r, log, mp, settings):
    """A log without reference poses: the robot tracked over the whole log against the map
    (the first pass's defaults, relocalisation on) stands in for them. Its poses at the
    scans where the track fits the map (tracking.csv states REFERENCE_STATES) become the
    log's 'truth' records in DIR/log_reference.odolog; a track lost and not recovered
    is no reference, and the log is refused. Returns (the new log, the reference's entry
    in settings)."""
    if mp is None and record_counts(log).get("wall", 0) == 0:
        raise InputRefused(f"{a.log}: no reference poses and no map (no --map, no 'wall' records): calibrate needs "
                           f"the map to track the robot, and the track to check the calibration against")
    pre = dict(settings, range_sigma_m={"value": a.range_sigma or 0.10})
    rep = r.replay("reference track", log, mp, "reference", pre, relocalise=True, k0=a.k0 or 3e-4)
    t = rep.get("tracking", {})
    if t.get("lost"):
        raise InputRefused(f"{a.log}: no reference poses, and the track that would stand in for them was lost and "
                           f"not recovered (reference/tracking.csv): the calibration cannot be checked")
    kept, dropped = {}, 0
    for row in choose.tracking_rows(r.path("reference")):
        if row["state"] in REFERENCE_STATES:
            kept[round(float(row["t"]), 4)] = (row["x"], row["y"], row["theta"])
        else:
            dropped += 1
    out = r.path("log_reference.odolog")
    n = 0
    with open(log) as src, open(out, "w") as dst:
        for line in src:
            if line.startswith("truth "):
                continue
            dst.write(line)
            if line.startswith("scan "):
                ts = line.split(" ", 2)[1]
                pose = kept.get(round(float(ts), 4))
                if pose is not None:
                    dst.write(f"truth {ts} {pose[0]} {pose[1]} {pose[2]}\n")
                    n += 1
    if n < 3:
        raise InputRefused(f"{a.log}: no reference poses, and the track fits the map at only {n} scans: the "
                           f"calibration cannot be checked")
    return out, {"kind": "track", "poses": n, "scans_left_out": dropped,
                 "why": (f"the log has no reference poses: the robot tracked over the whole log against the map "
                         f"(range sigma {pre['range_sigma_m']['value']:g} m, relocalisation on; reference/) stands in "
                         f"for them, at the {n} scans where its fit is good ({dropped} poor or lost left out). "
                         f"The check then sees the odometry's error against the track, whose own error (a few cm "
                         f"on the buildings where it could be measured) it cannot see; the pose RMSE at reference "
                         f"poses is not computed")}


def tracking_block(rep, reference=None):
    t = rep.get("tracking", {})
    tracked = reference is not None and reference["kind"] == "track"
    out = {"pose_rmse_at_truth_m": None if tracked else rep.get("pose_rmse_at_truth_records_m"),
           "heading_rmse_at_truth_rad": None if tracked else rep.get("heading_rmse_at_truth_records_rad"),
           "truth_records": None if tracked else rep.get("truth_records_scored"),
           "lost": bool(t.get("lost", False)), "lost_episodes": t.get("lost_episodes", 0),
           "recovered": t.get("recovered", 0), "fit_median": t.get("fit_median"),
           "scans_poor": t.get("scans_poor"), "scans_checked": t.get("scans_checked"),
           "episodes": t.get("episodes", [])}
    if tracked:  # against the reference track: how far this track is from it
        out["rmse_to_reference_track_m"] = rep.get("pose_rmse_at_truth_records_m")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(prog="odoerr calibrate", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--odoerr", required=True, help=argparse.SUPPRESS)
    ap.add_argument("log", metavar="LOG")
    ap.add_argument("--out", required=True, metavar="DIR")
    ap.add_argument("--map", default=None, help="the map (.odomap or ROS map_server .yaml) instead of one built from the log")
    ap.add_argument("--max-scans", type=int, default=None, help="only the first N scans of a CARMEN log")
    ap.add_argument("--range-sigma", type=float, default=None, help="override the range sigma chosen from the data (m)")
    ap.add_argument("--param-sigma", type=float, default=None, help="override the constants' prior (relative)")
    ap.add_argument("--k0", type=float, default=None, help="override K_w's start chosen from the data (m)")
    ap.add_argument("--no-report", action="store_true", help="leave out the diagnosis and its report page")
    a = ap.parse_args(argv)
    t_start = time.time()
    if not os.path.isfile(a.log):
        print(f"odoerr calibrate: {a.log}: no such file", file=sys.stderr)
        return 2
    try:
        fmt, fmt_why = detect_format(a.log)
    except ValueError as e:
        print(f"odoerr calibrate: {e}", file=sys.stderr)
        return 2
    os.makedirs(a.out, exist_ok=True)
    out = os.path.abspath(a.out)
    r = Runner(a.odoerr, out)
    settings = {"format": {"value": fmt, "why": fmt_why}}
    try:
        result = calibrate(a, r, fmt, settings)
    except InputRefused as e:
        print(f"odoerr calibrate: {e}", file=sys.stderr)
        return 2
    except StepError as e:
        print(f"odoerr calibrate: {e}", file=sys.stderr)
        json.dump({"error": str(e), "settings": settings, "steps": r.steps}, open(r.path("calibration.json"), "w"),
                  indent=1)
        return 1
    result["steps"] = r.steps
    result["seconds"] = round(time.time() - t_start, 1)
    with open(r.path("calibration.json"), "w") as f:
        json.dump(result, f, indent=1)
    summary(result, r.path("calibration.json"))
    return 0


def calibrate(a, r, fmt, settings):
    # 1. the log as an odolog
    if fmt == "carmen":
        log = r.path("log.odolog")
        cmd = [PY, os.path.join(IMPORT_DIR, "carmen_to_odolog.py"), a.log, "--out", log, "--scans", "--auto",
               "--choices", r.path("import_choices.json")]
        if a.max_scans:
            cmd += ["--max-scans", str(a.max_scans)]
        r.run("import", cmd)
        settings["import"] = json.load(open(r.path("import_choices.json")))
    else:
        log = os.path.abspath(a.log)
    # 2. the map
    if a.map:
        if a.map.endswith((".yaml", ".yml")):
            mp = r.path("map.odomap")
            r.run("map import", [r.odoerr, "map", "import", a.map, "--out", mp, "--faces"])
            settings["map"] = {"value": a.map, "why": "given (--map), a ROS map_server map: its line segments"}
        else:
            mp = os.path.abspath(a.map)
            settings["map"] = {"value": a.map, "why": "given (--map)"}
    elif fmt == "carmen":
        grid = [r.odoerr, "map", "grid-from-carmen", a.log, "--out", r.path("map")]
        if a.max_scans:
            grid += ["--max-scans", str(a.max_scans)]
        nr = settings["import"]["no_return"]
        if nr["chosen"]:
            grid += ["--no-return", f"{nr['value']:g}"]
        r.run("map grid", grid)
        mp = r.path("map.odomap")
        r.run("map import", [r.odoerr, "map", "import", r.path("map.yaml"), "--out", mp, "--faces"])
        settings["map"] = {"value": "map.odomap", "why": "no --map: an occupancy grid from the log's corrected poses "
                                                         "and scans (as a SLAM run gives), then its line segments"}
    else:
        mp = None
        settings["map"] = {"value": "the log's walls", "why": "no --map: the odolog's own wall records"}
    # 3. the halves, and the settings from a first pass over the first half
    kinds = record_counts(log)
    if kinds.get("scan", 0) == 0 or "laser" not in kinds:
        raise InputRefused(f"{a.log}: no laser scans: calibrate tracks the robot against the map with its laser "
                           f"(odolog 'laser' and 'scan' records)")
    settings["order_beams"] = {"value": True, "why": "a map from a SLAM grid misses objects and people: the beams "
                                                     "most consistent with the map are fused first, so one wrong "
                                                     "beam does not pull the pose"}
    settings["param_sigma"] = {"value": a.param_sigma or PARAM_SIGMA,
                               "why": "given (--param-sigma)" if a.param_sigma else
                               "the nominal constants are declared, not measured: a 5 % prior on each scale"}
    if kinds.get("truth", 0) >= 2:
        reference = {"kind": "log", "poses": kinds["truth"],
                     "why": "the log's reference poses ('truth' records; a CARMEN log's corrected poses)"}
    else:
        log, reference = tracked_reference(a, r, log, mp, settings)
    settings["reference"] = reference
    r.run("split", [PY, os.path.join(IMPORT_DIR, "odolog_split.py"), log, "--first", r.path("first.odolog"),
                    "--second", r.path("second.odolog")])
    settings["range_sigma_m"] = {"value": a.range_sigma or 0.10, "why": "first pass"}
    probe = r.replay("first pass", r.path("first.odolog"), mp, "pass1", settings, relocalise=True,
                     k0=a.k0 or 3e-4)
    k_probe = probe["final"]["K_w"]["estimate"]
    if a.k0:
        settings["k0_m"] = {"value": a.k0, "why": "given (--k0)"}
    else:
        k = min(max(k_probe, K0_RANGE[0]), K0_RANGE[1])
        settings["k0_m"] = {"value": k, "why": f"K_w at the end of the first pass ({k_probe:.3g} m; started at 3e-4), "
                                               f"within {K0_RANGE[0]:g}-{K0_RANGE[1]:g} m"}
    sig, n = choose.residual_sigma(os.path.join(r.path("pass1"), "innovations.csv"))
    tracked1 = not probe.get("tracking", {}).get("lost", False)
    if a.range_sigma:
        settings["range_sigma_m"] = {"value": a.range_sigma, "why": "given (--range-sigma)"}
    elif sig is None and tracked1:
        raise StepError(f"the first pass predicted only {n} beams against the map: no range sigma can be measured "
                        f"(is the map the log's building?)")
    else:
        settings["range_sigma_m"] = choose_range_sigma(r, mp, settings, sig or 0.0, n, tracked1 and sig is not None)
    settings["gate_nis"] = {"value": 25, "why": "the default: 5 sigma, a beam's innovation past it is not fused"}
    # 4. tracking over the whole log
    full = r.replay("tracking", log, mp, "track", settings)
    # 5. calibration on the first half, cross-check on its quarters, check on the second
    first = r.replay("calibration", r.path("first.odolog"), mp, "first", settings)
    c, s, kw = constants_of(first)
    quarters = None
    r.run("split quarters", [PY, os.path.join(IMPORT_DIR, "odolog_split.py"), r.path("first.odolog"),
                             "--first", r.path("q1.odolog"), "--second", r.path("q2.odolog")])
    q = [r.replay(f"quarter {i}", r.path(f"q{i}.odolog"), mp, f"q{i}", settings) for i in (1, 2)]
    if not any(x.get("tracking", {}).get("lost") for x in q):
        (c1, s1, _), (c2, s2, _) = constants_of(q[0]), constants_of(q[1])
        dis = {k: abs(c1[k] - c2[k]) / math.hypot(s1[k], s2[k]) for k in c1}
        worst = max(dis, key=dis.get)
        quarters = {"first_quarter": c1, "second_quarter": c2, "sigma_first": s1, "sigma_second": s2,
                    "disagreement_sigma": dis[worst], "worst": worst}
    walls = r.path("first_walls.odolog")
    if mp:
        import_common.with_map_walls(r.path("first.odolog"), mp, walls)
    else:
        walls = r.path("first.odolog")
    ev_json = r.path("evaluate.json")
    r.run("check", [r.odoerr, "evaluate", "--calibrate", walls, "--test", r.path("second.odolog"), "--json", ev_json,
                    "--constants", ",".join(f"{c[k]:.6f}" for k in ("delta_R", "delta_L", "delta_d")),
                    "--constants-k-w", f"{kw:.6g}"])
    ev = json.load(open(ev_json))
    rpe5 = ev["rpe"]["5m"]
    rpe = {"nominal": pick(rpe5.get("nominal")), "calibrated": pick(rpe5.get("constants"))}
    growth = ev.get("growth_constants", {})
    fills = meta_value(log, "odometry_gaps")
    raw_share = None
    if fills:
        m = re.match(r"(\d+) intervals", fills)
        scans = int(full.get("scans_fused", 0))
        if m and scans > 1:
            raw_share = 1 - int(m.group(1)) / (scans - 1)
    result = {"log": a.log, "format": fmt,
              "tracking": tracking_block(full, reference), "tracking_first_half": tracking_block(first, reference),
              "calibration": {"constants": c, "sigma": s, "K_w": kw, "quarters": quarters,
                              "nominal": {"delta_R": 1.0, "delta_L": 1.0, "delta_d": 1.0}},
              "rpe_5m_second_half": rpe, "growth": growth,
              "encoder_rejections": full.get("encoder_rejections"),
              "raw_odometry_share": raw_share, "settings": settings}
    ok, why = trust(result, quarters, raw_share)
    result["calibration"]["trusted"] = ok
    result["calibration"]["reason"] = why
    result["calibration"]["use"] = c if ok else result["calibration"]["nominal"]
    # 7. the diagnosis and its page
    if not a.no_report:
        cmd = [r.odoerr, "report", walls, "--out", r.path("report"), "--order-beams",
               "--range-sigma", f"{settings['range_sigma_m']['value']:.4g}",
               "--param-sigma", f"{settings['param_sigma']['value']:g}", "--k0", f"{settings['k0_m']['value']:.4g}"]
        r.run("diagnose and report", cmd)
        d = json.load(open(os.path.join(r.path("report"), "diagnose.json")))
        mm = d.get("map_misfit") if isinstance(d.get("map_misfit"), dict) else {}
        result["diagnose"] = {
            "verdict": d.get("verdict"),
            "named": [{"effect": e["effect"], "estimate": e.get("estimate"), "sigma": e.get("sigma"),
                       "parameters": e.get("parameters")} for e in d.get("ranking", []) if e.get("significant")],
            "map_regions": [{**{k: g.get(k) for k in ("x", "y", "extent_m", "sign", "beams", "scans")},
                             "kind": (g.get("history") or {}).get("kind")} for g in mm.get("regions", [])],
            "report": "report/report.html"}
    return result


def choose_range_sigma(r, mp, settings, sig, n, first_pass_tracked):
    """The range sigma: candidates tracked over the first half until their first loss, the
    best fitting track's kept (choose.best); its value and why, with every candidate."""
    tried = []
    for i, v in enumerate(choose.candidates(sig, first_pass_tracked)):
        trial = dict(settings, range_sigma_m={"value": v})
        rep = r.replay(f"range sigma {v:.3f}", r.path("first.odolog"), mp, f"sigma{i}", trial, stop_when_lost=True)
        tried.append((v, choose.track_quality(r.path(f"sigma{i}"), rep)))
    kept = choose.best(tried)
    if kept is None:
        raise StepError("no candidate range sigma gave a track with a scan fit (tracking.csv empty)")
    listing = "; ".join(f"{v:.3f} m: mean fit {q['fit_mean']:.3f}" + (", lost" if q["lost"] else "") +
                        (f", {q['lost_episodes']} loss(es)" if q["lost_episodes"] else "")
                        for v, q in tried if q["fit_mean"] is not None)
    source = (f"{', '.join(f'{m:g}' for m in choose.SIGMA_LADDER)} x the laser-to-map residual sigma "
              f"({sig:.3f} m: 1.4826 x the median absolute residual within {choose.RESIDUAL_BAND:g} m of {n} beams "
              f"in a first pass over the first half), within {choose.SIGMA_RANGE[0]}-{choose.SIGMA_RANGE[1]} m"
              if first_pass_tracked else
              f"{', '.join(f'{v:g}' for v in choose.SIGMA_SPAN)} m (the first pass lost the robot: its residuals "
              f"measure the loss, not the laser)")
    return {"value": kept[0],
            "why": f"of {source}, each tracked over the first half until its first loss, the one whose track "
                   f"fits the map best (never lost; the highest mean scan fit, within {choose.FIT_TIE} of it the "
                   f"smaller sigma; every one lost: the one that kept the track longest): {listing}",
            "residual_sigma_m": sig,
            "candidates": [{"value": v, **q} for v, q in tried]}


def pick(r):
    if not r or r.get("trans_m") is None:
        return None
    return {"trans_m": r["trans_m"], "rot_rad": r["rot_rad"], "segments": r.get("segments")}


def summary(res, where):
    t = res["tracking"]
    cal = res["calibration"]
    rmse = t["pose_rmse_at_truth_m"]
    off = rmse is not None and rmse > TRACK_OFF_M
    print(f"tracking: {'LOST (not recovered)' if t['lost'] else 'OFF the reference poses' if off else 'tracked'}; {t['lost_episodes']} lost, "
          f"{t['recovered']} recovered; median scan fit {t['fit_median']:.2f}" if t["fit_median"] is not None
          else "tracking: no scan was checked")
    if rmse is not None:
        print(f"  pose RMSE at the {t['truth_records']} reference poses: {rmse:.3f} m, "
              f"heading {t['heading_rmse_at_truth_rad']:.4f} rad")
    ref = res["settings"].get("reference", {})
    if ref.get("kind") == "track":
        print(f"  no reference poses in the log: the track is the reference ({ref['poses']} scans; the pose error "
              f"cannot be measured, the check sees the odometry against the track)")
    rej = res.get("encoder_rejections") or {}
    if rej.get("count"):
        r0 = rej["first"][0]
        print(f"  {rej['count']} encoder increment(s) rejected as impossible for the drive, left out (the first at "
              f"line {r0['line']}, t={r0['t']:.2f} s, channel {r0['channel']}: {r0['ticks']:.0f} ticks, at most "
              f"{r0['limit_ticks']:.0f})")
    cc = cal["constants"]
    print("calibration (first half): " + ", ".join(f"{k} {cc[k]:.5f} +- {cal['sigma'][k]:.2g}" for k in cc) +
          f", K_w {cal['K_w']:.3g} m")
    rpe = res["rpe_5m_second_half"]
    if rpe["nominal"] and rpe["calibrated"]:
        n, c = rpe["nominal"], rpe["calibrated"]
        print(f"second half, odometry alone, 5 m RPE: nominal {n['trans_m']:.3f} m / {n['rot_rad']:.3f} rad, "
              f"calibrated {c['trans_m']:.3f} m / {c['rot_rad']:.3f} rad")
    print(("TRUSTED: " if cal["trusted"] else "NOT TRUSTED (the nominal constants stand): ") + cal["reason"])
    if "diagnose" in res:
        dg = res["diagnose"]
        named = ", ".join(e["effect"] for e in dg["named"]) or "no effect named"
        kinds = {}
        for g in dg["map_regions"]:
            kinds[g.get("kind") or "?"] = kinds.get(g.get("kind") or "?", 0) + 1
        kt = f" ({', '.join(f'{n} {k}' for k, n in kinds.items())})" if kinds else ""
        print(f"diagnosis (first half): {dg['verdict']}; {named}; {len(dg['map_regions'])} map region(s) where the "
              f"map disagrees{kt}; the page: {os.path.join(os.path.dirname(where), 'report', 'report.html')}")
    print(f"wrote {where} ({res['seconds']:.0f} s)")


if __name__ == "__main__":
    sys.exit(main())
