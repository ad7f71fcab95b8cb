#!/usr/bin/python3
"""Write a realistic fixture of what `odoerr diagnose` puts in its output directory.

    make_fixture.py OUTDIR [--beams N] [--drive diff|sync] [--seed S]
                           [--no-truth] [--no-heldout] [--no-alarms] [--no-discovery] [--alarms N]

Files written (the contract that tools/report/make_report.py reads):
  diagnose.json, scans.csv, beams.csv, trajectory.csv,
  heldout_before.csv and heldout_after.csv (unless --no-heldout),
  discovery_motion.csv and discovery_beam.csv (unless --no-discovery; fixture_discovery.py),
  map_grid.csv and diagnose.json's map_misfit (unless --no-discovery; fixture_map.py).

The drive is a figure-eight with one reversal through a 10 m x 8 m room with a few inner
walls. Two effects are planted so that the plots have something to show: wall 5 sits 4 cm
further along its normal than the map says (wall_offset), and the tyres slide sideways in
turns (turn_slip, a cross-track correction growing with v*w). Everything else is noise.
Only numpy is used; the numbers are made up but consistent with each other.

CUSUM alarms: three single ones by default; with --alarms N (N >= 7) N of them in seven bursts
at consecutive scans (0.1 s and 5 cm apart), as a drive whose NIS stays high for a while raises
them: the report draws seven clusters and labels five. The other files do not change with it.
"""
import argparse
import json
import math
import os
import sys

import numpy as np
import scipy.stats

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fixture_discovery import add_discovery, add_tests_extras  # noqa: E402
from fixture_map import add_map_misfit  # noqa: E402

EFFECTS = [
    ("turn_slip", 1, "Tyres slide sideways under centripetal acceleration v*w."),
    ("rotation_slip", 1, "Wheels scrub and lose heading when turning fast."),
    ("speed_scale", 1, "Tyre compression or longitudinal slip grows with speed."),
    ("wheel_eccentricity", 2, "An out-of-round wheel: the travel scale varies once per wheel turn."),
    ("backlash", 1, "Gear play: the first millimetres after a reversal are lost."),
    ("region_scale", 9, "A floor region (carpet, ramp) has its own travel scale."),
    ("radius_drift", 1, "A wheel radius changes slowly with distance (wear, tyre pressure)."),
    ("turn_noise", 1, "Non-systematic heading noise growing with rotation."),
    ("range_bias", 1, "The laser reports every range with a constant offset."),
    ("range_scale", 1, "The laser's range scale is off (clock or calibration)."),
    ("laser_mount_xy", 2, "The laser is mounted off the position the model assumes."),
    ("laser_mount_yaw", 1, "The laser is rotated against the yaw the model assumes."),
    ("scan_latency", 1, "Scans are stamped later than they were taken."),
    ("wall_offset", 12, "The map is wrong: a wall is not where the map says."),
]

# Room 10 x 8 m, plus inner walls (x1, y1, x2, y2).
WALLS = [
    [0.0, 0.0, 10.0, 0.0], [10.0, 0.0, 10.0, 8.0], [10.0, 8.0, 0.0, 8.0], [0.0, 8.0, 0.0, 0.0],
    [3.0, 0.0, 3.0, 1.2], [6.5, 8.0, 6.5, 6.9], [4.2, 3.6, 5.8, 3.6], [4.2, 4.4, 5.8, 4.4],
    [8.6, 2.0, 8.6, 3.5], [1.2, 6.0, 2.2, 6.0], [0.0, 3.5, 0.6, 3.5], [7.5, 0.0, 7.5, 0.7],
]
OFFSET_WALL = 5          # index of the wall that is really 4 cm off
OFFSET_M = 0.04
SIGMA_R = 0.012          # beam range sigma (m)
BEAMS_PER_SCAN = 91      # -90..90 deg every 2 deg
RANGE_MAX = 8.0
SCAN_EVERY_M = 0.05
SPEED = 0.5              # m/s nominal


def chi2_band(dof):
    """The central 95 % band of a chi-square with dof degrees of freedom (as odoerr writes it)."""
    dof = np.maximum(np.asarray(dof, float), 1.0)
    return scipy.stats.chi2.ppf(0.025, dof), scipy.stats.chi2.ppf(0.975, dof)


def figure_eight(n_laps):
    """Dense truth path: (s, x, y, theta, v_sign) sampled every 1 cm of travel."""
    u = np.linspace(0.0, 2.0 * math.pi * n_laps, 200000)
    x = 5.0 + 3.6 * np.sin(u)
    y = 4.0 + 2.6 * np.sin(u) * np.cos(u) * 1.6
    ds = np.hypot(np.diff(x), np.diff(y))
    s = np.concatenate([[0.0], np.cumsum(ds)])
    s_new = np.arange(0.0, s[-1], 0.01)
    x = np.interp(s_new, s, x)
    y = np.interp(s_new, s, y)
    return s_new, x, y


def with_reversal(x, y, at_frac=0.55, back_m=1.5):
    """Insert a reversal: at at_frac of the path drive back_m backwards, then forwards again."""
    n = len(x)
    i0 = int(at_frac * n)
    k = int(back_m / 0.01)
    idx = np.concatenate([np.arange(0, i0), np.arange(i0, i0 - k, -1), np.arange(i0 - k, n)])
    direction = np.concatenate([np.ones(i0), -np.ones(k), np.ones(n - i0 + k)])
    return idx, direction


def raycast(ox, oy, angles, walls):
    """Ranges and wall indices of rays from (ox, oy) at the given world angles."""
    w = np.asarray(walls, float)
    dx, dy = np.cos(angles)[:, None], np.sin(angles)[:, None]
    ex, ey = (w[:, 2] - w[:, 0])[None, :], (w[:, 3] - w[:, 1])[None, :]
    qx, qy = (w[:, 0] - ox)[None, :], (w[:, 1] - oy)[None, :]
    den = dx * ey - dy * ex
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qx * ey - qy * ex) / den
        u = (qx * dy - qy * dx) / den
    ok = (np.abs(den) > 1e-12) & (t > 1e-6) & (u >= 0.0) & (u <= 1.0)
    t = np.where(ok, t, np.inf)
    j = np.argmin(t, axis=1)
    r = t[np.arange(len(angles)), j]
    return r, j


def bin_stats(values, edges, beam_scan, nis, norm_innov, scan_corr, scan_values=None):
    """Per-bin summaries in the contract's shape. values: per beam; scan_values: per scan."""
    along, cross, heading = scan_corr
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = (values >= lo) & (values < hi)
        count = int(m.sum())
        entry = {"lo": round(float(lo), 6), "hi": round(float(hi), 6), "count": count}
        if count:
            scans_in = np.unique(beam_scan[m])
            entry.update({
                "nis_mean": round(float(nis[m].mean()), 4),
                "mean_norm_innovation": round(float(norm_innov[m].mean()), 4),
                "along_mean_m": round(float(along[scans_in].mean()), 6),
                "cross_mean_m": round(float(cross[scans_in].mean()), 6),
                "heading_mean_rad": round(float(heading[scans_in].mean()), 7),
            })
        else:
            entry.update({"nis_mean": None, "mean_norm_innovation": None, "along_mean_m": None,
                          "cross_mean_m": None, "heading_mean_rad": None})
        out.append(entry)
    return out


def fmt(v, nd=6):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    return f"{v:.{nd}f}".rstrip("0").rstrip(".") if nd else str(v)


def write_csv(path, header, cols, nds):
    n = len(cols[0])
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        parts = []
        for c, nd in zip(cols, nds):
            if nd is None:
                parts.append([str(v) for v in c])
            else:
                parts.append([("" if not np.isfinite(v) else f"{v:.{nd}f}") for v in c])
        f.write("\n".join(",".join(row) for row in zip(*parts)))
        if n:
            f.write("\n")


def alarm_bursts(n):
    """(fraction of the drive, direction, alarms at consecutive scans) for n alarms: the three
    single alarms of old for n = 3, else seven bursts whose sizes add up to n (n >= 7)."""
    if n == 3:
        return [(0.31, "up", 1), (0.57, "down", 1), (0.74, "up", 1)]
    if n < 7:
        raise SystemExit("make_fixture: --alarms takes 3 or at least 7")
    at = [(0.08, "up"), (0.22, "up"), (0.31, "up"), (0.45, "up"), (0.57, "down"), (0.74, "up"), (0.88, "up")]
    w = np.array([2, 5, 3, 12, 7, 6, 1], float)
    m = np.maximum(1, np.floor(n * w / w.sum())).astype(int)
    m[3] += n - m.sum()
    return [(f, d, int(k)) for (f, d), k in zip(at, m)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("outdir")
    ap.add_argument("--beams", type=int, default=100000, help="about this many beams.csv rows")
    ap.add_argument("--drive", choices=["diff", "sync"], default="diff")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-truth", action="store_true")
    ap.add_argument("--no-heldout", action="store_true")
    ap.add_argument("--no-alarms", action="store_true")
    ap.add_argument("--alarms", type=int, default=3,
                    help="CUSUM alarms: 3 single ones (default), or N >= 7 in seven bursts")
    ap.add_argument("--no-discovery", action="store_true",
                    help="a diagnose.json of an older odoerr: no unexplained / change_points / auto, no "
                         "discovery CSVs, no nested tests, no map_misfit")
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    os.makedirs(a.outdir, exist_ok=True)

    # ---- truth path ---------------------------------------------------------------------
    n_scans_target = max(20, int(math.ceil(a.beams / (BEAMS_PER_SCAN * 0.93))))
    length_m = n_scans_target * SCAN_EVERY_M
    lap_len = 26.0
    s0, x0, y0 = figure_eight(max(1, int(math.ceil(length_m / lap_len)) + 1))
    idx, direction = with_reversal(x0, y0)
    idx = idx[: int(length_m / 0.01)]
    direction = direction[: len(idx)]
    tx, ty = x0[idx], y0[idx]
    # Heading: tangent of the forward path, whichever way the robot is moving along it.
    gx, gy = np.gradient(x0), np.gradient(y0)
    tth = np.arctan2(gy, gx)[idx]
    n = len(tx)
    dist = np.arange(n) * 0.01
    speed = SPEED * (1.0 + 0.3 * np.sin(dist / 3.1)) * np.where(direction < 0, 0.5, 1.0)
    t = np.concatenate([[0.0], np.cumsum(0.01 / speed[:-1])])
    dth = np.diff(np.unwrap(tth), prepend=tth[0])
    omega = dth / np.concatenate([[0.01 / speed[0]], np.diff(t)])
    v = speed * direction

    # Estimate = truth + a slowly varying error that the scans keep correcting.
    drift_x = np.cumsum(rng.normal(0, 0.0004, n))
    drift_y = np.cumsum(rng.normal(0, 0.0004, n))
    ex = tx + 0.01 * np.sin(dist / 4.0) + 0.3 * (drift_x - np.convolve(drift_x, np.ones(301) / 301, "same"))
    ey = ty + 0.01 * np.cos(dist / 5.0) + 0.3 * (drift_y - np.convolve(drift_y, np.ones(301) / 301, "same"))
    eth = tth + 0.004 * np.sin(dist / 2.3) + 0.0015 * omega

    # ---- scans --------------------------------------------------------------------------
    step = int(round(SCAN_EVERY_M / 0.01))
    si = np.arange(step, n, step)[:n_scans_target]
    ns = len(si)
    rel = np.deg2rad(np.linspace(-90.0, 90.0, BEAMS_PER_SCAN))
    walls_true = [list(w) for w in WALLS]
    wx1, wy1, wx2, wy2 = WALLS[OFFSET_WALL]
    L = math.hypot(wx2 - wx1, wy2 - wy1)
    nx, ny = -(wy2 - wy1) / L, (wx2 - wx1) / L
    walls_true[OFFSET_WALL] = [wx1 + OFFSET_M * nx, wy1 + OFFSET_M * ny,
                               wx2 + OFFSET_M * nx, wy2 + OFFSET_M * ny]
    b_scan, b_beam, b_hx, b_hy, b_inn, b_nis, b_status = [], [], [], [], [], [], []
    for k, i in enumerate(si):
        ang = eth[i] + rel
        r_pred, _ = raycast(ex[i], ey[i], ang, WALLS)
        r_true, _ = raycast(tx[i], ty[i], tth[i] + rel, walls_true)
        keep = np.isfinite(r_pred) & (r_pred < RANGE_MAX) & np.isfinite(r_true)
        keep &= rng.random(len(rel)) > 0.03               # a few no-returns
        meas = r_true + rng.normal(0.0, SIGMA_R, len(rel))
        outlier = rng.random(len(rel)) < 0.015             # people, chair legs
        meas = np.where(outlier, meas - rng.uniform(0.2, 2.0, len(rel)), meas)
        inn = meas - r_pred
        s2 = SIGMA_R ** 2 + (0.004 + 0.002 * r_pred) ** 2
        nis = inn ** 2 / s2
        status = np.where(nis > 25.0, "gated", "used")
        kk = np.nonzero(keep)[0]
        b_scan.append(np.full(len(kk), k))
        b_beam.append(kk)
        b_hx.append(ex[i] + r_pred[kk] * np.cos(ang[kk]))
        b_hy.append(ey[i] + r_pred[kk] * np.sin(ang[kk]))
        b_inn.append(inn[kk])
        b_nis.append(nis[kk])
        b_status.append(status[kk])
    b_scan = np.concatenate(b_scan)
    b_beam = np.concatenate(b_beam)
    b_hx, b_hy = np.concatenate(b_hx), np.concatenate(b_hy)
    b_inn, b_nis = np.concatenate(b_inn), np.concatenate(b_nis)
    b_status = np.concatenate(b_status)
    b_t = t[si][b_scan]
    used = b_status == "used"
    norm_innov = np.sign(b_inn) * np.sqrt(b_nis)

    dof = np.bincount(b_scan[used], minlength=ns)
    nis_sum = np.bincount(b_scan[used], weights=b_nis[used], minlength=ns)
    band_lo, band_hi = chi2_band(dof)
    # Pose corrections the scans made (robot frame): turn_slip shows as cross ~ v*w.
    vs, ws = v[si], omega[si]
    along = rng.normal(0.0, 0.0015, ns) + 0.0005 * np.sign(vs)
    cross = rng.normal(0.0, 0.0012, ns) + 0.012 * vs * ws
    heading = rng.normal(0.0, 0.0009, ns) + 0.002 * ws
    scan_corr = (along, cross, heading)

    write_csv(os.path.join(a.outdir, "scans.csv"),
              ["t", "dist_m", "x", "y", "theta", "dof", "nis_sum", "band_lo", "band_hi",
               "along_m", "cross_m", "heading_rad"],
              [t[si], dist[si], ex[si], ey[si], eth[si], dof, nis_sum, band_lo, band_hi,
               along, cross, heading],
              [3, 3, 4, 4, 5, None, 3, 3, 3, 5, 5, 6])
    write_csv(os.path.join(a.outdir, "beams.csv"),
              ["t", "beam", "hit_x", "hit_y", "innovation_m", "nis", "status"],
              [b_t, b_beam, b_hx, b_hy, b_inn, b_nis, b_status],
              [3, None, 3, 3, 4, 3, None])
    tr = slice(0, n, 2)
    if a.no_truth:
        truth = [np.full(len(t[tr]), np.nan)] * 3
    else:
        truth = [tx[tr], ty[tr], tth[tr]]
    write_csv(os.path.join(a.outdir, "trajectory.csv"),
              ["t", "x", "y", "theta", "truth_x", "truth_y", "truth_theta"],
              [t[tr], ex[tr], ey[tr], eth[tr]] + truth, [3, 4, 4, 5, 4, 4, 5])

    # ---- bins ---------------------------------------------------------------------------
    bw = omega[si][b_scan]
    bv = np.abs(v[si][b_scan])
    bvw = (v * omega)[si][b_scan]
    bh = np.mod(eth[si][b_scan] + math.pi, 2 * math.pi) - math.pi
    rev_i = np.nonzero(np.diff(np.sign(v)) != 0)[0]
    s_rev = np.full(n, 1e8)          # never reversed yet: in the last bin
    if len(rev_i):
        r0 = rev_i[0] + 1
        s_rev[r0:] = dist[r0:] - dist[r0]
        if len(rev_i) > 1:
            r1 = rev_i[1] + 1
            s_rev[r1:] = dist[r1:] - dist[r1]
    bsr = s_rev[si][b_scan]
    xmin, ymin = min(min(w[0], w[2]) for w in WALLS), min(min(w[1], w[3]) for w in WALLS)
    xmax, ymax = max(max(w[0], w[2]) for w in WALLS), max(max(w[1], w[3]) for w in WALLS)
    col = np.clip(((ex[si] - xmin) / (xmax - xmin) * 3).astype(int), 0, 2)
    row = np.clip(((ey[si] - ymin) / (ymax - ymin) * 3).astype(int), 0, 2)
    bcell = (3 * row + col)[b_scan].astype(float)
    keep = used
    args = (b_scan[keep], b_nis[keep], norm_innov[keep], scan_corr)
    bins = {
        "turn_rate": bin_stats(bw[keep], np.linspace(-1.2, 1.2, 9), *args),
        "speed": bin_stats(bv[keep], np.array([0.0, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]), *args),
        "v_omega": bin_stats(bvw[keep], np.linspace(-0.6, 0.6, 9), *args),
        "heading": bin_stats(bh[keep], np.linspace(-math.pi, math.pi, 9), *args),
        "since_reversal": bin_stats(bsr[keep], np.array([0.0, 0.05, 0.2, 1.0, 5.0, 1e9]), *args),
        "wheel_angle": ([] if a.drive == "diff" else
                        bin_stats(np.mod(eth[si][b_scan][keep], 2 * math.pi),
                                  np.linspace(0, 2 * math.pi, 7), *args)),
        "map_cell": bin_stats(bcell[keep], np.arange(0, 10) - 0.0, *args),
    }

    # ---- tests, ranking, heldout, excitation --------------------------------------------
    nis_norm = nis_sum / np.maximum(dof, 1)
    outside = ((nis_sum < band_lo) | (nis_sum > band_hi))[dof > 0]
    nis_mean = float(nis_norm[dof > 0].mean())
    total_dof = int(dof.sum())
    mlo, mhi = chi2_band(total_dof)
    win = 20
    wmeans = np.convolve(nis_sum, np.ones(win), "valid") / np.maximum(np.convolve(dof, np.ones(win), "valid"), 1)
    wlo, whi = chi2_band(win * BEAMS_PER_SCAN * 0.9)
    wlo, whi = wlo / (win * BEAMS_PER_SCAN * 0.9), whi / (win * BEAMS_PER_SCAN * 0.9)
    tests = {
        "nis_mean": round(nis_mean, 4),
        "nis_band": [round(float(mlo / total_dof), 4), round(float(mhi / total_dof), 4)],
        "scans_outside_band_frac": round(float(outside.mean()), 4),
        "windowed_nis_outside_frac": round(float(((wmeans < wlo) | (wmeans > whi)).mean()), 4),
        "ljung_box": {"lags": 20, "q": 61.3, "p_value": 4.1e-6},
        "nees_pose": None if a.no_truth else 2.87,
        "nees_params": None if a.no_truth else 1.42,
        "beams_used": int(used.sum()),
        "beams_gated": int((b_status == "gated").sum()),
    }
    ranking = []
    stats = {"wall_offset": (412.7, 713.1, 1e-30), "turn_slip": (58.2, 102.3, 2.2e-16),
             "range_bias": (21.4, 29.1, 4.4e-8), "laser_mount_yaw": (3.1, -3.9, 0.012),
             "rotation_slip": (2.4, -5.2, 0.028)}
    for name, k, desc in EFFECTS:
        dl, gain, p = stats.get(name, (float(rng.uniform(0.0, 1.6)), 0.0, 0.0))
        if name not in stats:
            gain = round(2 * dl - k * math.log(total_dof), 2)
            p = round(float(min(1.0, math.exp(-dl) * 1.3)), 4)
        sig = p < 0.001 and gain > 0
        if name == "wall_offset":
            est = [0.0] * k
            est[OFFSET_WALL] = 0.0391
            est = [round(e + float(rng.normal(0, 0.002)), 4) for e in est]
            sg = [0.0021] * k
        elif name == "turn_slip":
            est, sg = [0.0118], [0.0011]
        else:
            sg = [round(float(rng.uniform(0.001, 0.05)), 4) for _ in range(k)]
            est = [round(float(rng.normal(0.0, s)), 4) for s in sg]
        confused = {"turn_slip": ["rotation_slip"], "rotation_slip": ["turn_slip", "turn_noise"],
                    "range_bias": ["wall_offset", "laser_mount_xy"],
                    "wall_offset": ["range_bias"], "speed_scale": ["radius_drift"],
                    "radius_drift": ["speed_scale", "region_scale"],
                    "laser_mount_xy": ["range_bias"]}.get(name, [])
        detectable = name not in ("backlash", "wheel_eccentricity")
        ranking.append({"effect": name, "significant": bool(sig), "delta_loglik": round(dl, 3),
                        "bic_gain": round(gain, 2), "p_value": p, "informed_params": k,
                        "estimate": est, "sigma": sg, "detectable": detectable,
                        "confused_with": confused, "description": desc})
    ranking.sort(key=lambda r: -r["bic_gain"])

    heldout = None
    if not a.no_heldout:
        tmax = float(t[si][-1])
        blocks = [[round(tmax * f, 2), round(tmax * (f + 0.08), 2)] for f in (0.2, 0.5, 0.8)]
        hb = [], [], []
        ha = [], [], []
        for t0, t1 in blocks:
            m = (t[si] >= t0) & (t[si] <= t1)
            tt = t[si][m]
            nb = rng.chisquare(BEAMS_PER_SCAN * 0.9, len(tt)) / (BEAMS_PER_SCAN * 0.9) * 1.6
            na = rng.chisquare(BEAMS_PER_SCAN * 0.9, len(tt)) / (BEAMS_PER_SCAN * 0.9) * 1.04
            eb = 0.02 + 0.04 * np.linspace(0, 1, len(tt)) + np.abs(rng.normal(0, 0.005, len(tt)))
            ea = 0.01 + 0.006 * np.linspace(0, 1, len(tt)) + np.abs(rng.normal(0, 0.003, len(tt)))
            for dst, vals in ((hb, (tt, nb, eb)), (ha, (tt, na, ea))):
                for lst, vv in zip(dst, vals):
                    lst.append(vv)
        hb = [np.concatenate(x) for x in hb]
        ha = [np.concatenate(x) for x in ha]
        if a.no_truth:
            hb[2][:] = np.nan
            ha[2][:] = np.nan
        write_csv(os.path.join(a.outdir, "heldout_before.csv"), ["t", "nis", "pose_err_m"], hb,
                  [3, 4, 4])
        write_csv(os.path.join(a.outdir, "heldout_after.csv"), ["t", "nis", "pose_err_m"], ha,
                  [3, 4, 4])

        def summary(h, inn):
            return {"nis_mean": round(float(h[1].mean()), 4), "nll_mean": round(float(-1.3 + 0.1 * h[1].mean()), 4),
                    "innovation_rms_m": inn,
                    "pose_rmse_m": None if a.no_truth else round(float(np.sqrt((h[2] ** 2).mean())), 4),
                    "heading_rmse_rad": None if a.no_truth else round(float(0.004 + 0.01 * h[1].mean() / 3), 5)}
        def paired(better, z):
            return {"blocks": len(blocks), "blocks_better": better, "change_mean": -0.01, "change_z": z}
        heldout = {"with": ["wall_offset", "turn_slip"], "folds": 3, "blocks": blocks,
                   "before": summary(hb, 0.0187), "after": summary(ha, 0.0131),
                   "paired": {"nis": paired(3, -4.1), "nll": paired(3, -3.2),
                              "pose_err_m": None if a.no_truth else paired(2, -2.5)}}

    params = ([("delta_R", 0.0004, 0.05, True), ("delta_L", 0.0004, 0.05, True),
               ("delta_d", 0.0031, 0.05, True), ("K_w", 0.00002, 0.001, True)]
              if a.drive == "diff" else
              [("delta_rho", 0.0005, 0.05, True), ("E_theta", 0.0011, 0.02, True),
               ("K_rho", 0.00003, 0.001, True), ("K_theta", 0.00004, 0.001, True)])
    params += [("turn_slip.k", 0.0011, 0.05, True), ("rotation_slip.k", 0.004, 0.05, True),
               ("backlash.b", 0.0049, 0.005, False), ("wheel_eccentricity.a", 0.011, 0.01, False),
               ("wheel_eccentricity.b", 0.012, 0.01, False), ("scan_latency.tau", 0.003, 0.05, True),
               ("wall_offset.o_5", 0.0021, 0.1, True), ("wall_offset.o_11", 0.09, 0.1, False)]
    excitation = {
        "parameters": [{"name": nm, "sigma_achievable": sa, "prior_sigma": ps, "determined": d}
                       for nm, sa, ps, d in params],
        "warnings": [
            "The drive reversed only once, so backlash is barely better known than its prior.",
            "Wheel eccentricity needs constant-speed straight runs of several wheel turns; "
            "this log has few.",
            "Wall 11 is seen by fewer than 40 beams, all at grazing incidence; its offset is not determined.",
        ],
    }
    alarms = []
    if not a.no_alarms:
        for f, d, m in alarm_bursts(a.alarms):
            k0 = int(f * (ns - 1))
            for k in range(k0, min(k0 + m, ns)):
                j = si[k]
                alarms.append({"t": round(float(t[j]), 3), "x": round(float(ex[j]), 3),
                               "y": round(float(ey[j]), 3), "direction": d})

    verdict = "inconsistent" if not (tests["nis_band"][0] <= nis_mean <= tests["nis_band"][1]) \
        or tests["ljung_box"]["p_value"] < 0.01 else "consistent"
    doc = {"log": "/data/logs/warehouse-run-07.odolog", "drive": a.drive, "verdict": verdict,
           "tests": tests, "ranking": ranking, "heldout": heldout, "excitation": excitation,
           "bins": bins, "cusum": {"alarms": alarms}, "map": {"walls": WALLS}}
    if not a.no_discovery:
        add_tests_extras(tests, rng, 36)
        add_discovery(doc, a.outdir, rng, float(t[si][-1]), float(dist[si][-1]))
        add_map_misfit(doc, a.outdir, WALLS, b_hx, b_hy, norm_innov, b_scan, ex[si], ey[si], rng)
        doc["detection_power"] = {
            "power": 0.8, "rule": "the ranking's", "n_innovations": len(b_t),
            "families": [
                {"family": "turn_slip", "kind": "motion", "excited": True, "informed_params": 1, "threshold": 11.6,
                 "noncentrality": 19.5, "parameters": [{"name": "k_s2_per_m", "reference_size": 0.04,
                                                        "min_detectable": 0.00321, "sigma": 0.000727,
                                                        "over_reference_size": 0.0803}]},
                {"family": "backlash", "kind": "motion", "excited": False,
                 "why": "not excited by this drive: reverse the direction of travel many times",
                 "informed_params": 0, "threshold": None, "noncentrality": None,
                 "parameters": [{"name": "b_m", "reference_size": 0.005, "min_detectable": None,
                                 "why": "not excited by this drive: reverse the direction of travel many times"}]},
                {"family": "turn_noise", "kind": "noise", "excited": False,
                 "why": "a noise effect is tested on its likelihood profile, which gives no sigma to scale",
                 "informed_params": 1, "threshold": None, "noncentrality": None,
                 "parameters": [{"name": "q", "reference_size": 0.001, "min_detectable": None,
                                 "why": "a noise effect is tested on its likelihood profile"}]}],
            "features": {
                "power": 0.8, "rule": "discovery's: a term's cluster-robust z beyond 4.5 and a 1 % fall",
                "motion": {"rows": 412, "terms": [
                    {"term": "abs_ds@world_x", "frame": "world", "unit": "m/m", "min_detectable": 0.00184,
                     "sigma": 0.000345},
                    {"term": "dt@along", "frame": "robot", "unit": "m/s", "min_detectable": None,
                     "why": "not excited by this drive (the term's column is zero or follows the drive parameters')"}]},
                "beam": {"rows": 12000, "terms": [
                    {"term": "inv_cos_inc@range", "frame": "beam", "unit": "m", "min_detectable": 0.00071,
                     "sigma": 0.00013}]}}}
    with open(os.path.join(a.outdir, "diagnose.json"), "w") as f:
        json.dump(doc, f, indent=1)
    print(f"make_fixture: {a.outdir}: {ns} scans, {len(b_t)} beams, drive {a.drive}, "
          f"verdict {verdict}", file=sys.stderr)


if __name__ == "__main__":
    main()
