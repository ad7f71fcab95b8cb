#!/usr/bin/python3
"""Self-check of odosim.py: generate drives, re-read them with a minimal odolog v1 parser
written here, and verify them.

    python3 tools/pysim/check_odosim.py

Checks
  * every generated file follows odolog v1: `odolog 1` first, header records before data,
    the drive's params present and unique, scans with N ranges, integer encoder counts,
    times non-decreasing and enc < scan < truth at equal times;
  * clean drives (diff and sync, 1 minute): > 99 % of the beams agree with a ray cast from
    the truth pose within 5 sigma; the robot stays > 1 m from every wall; at least two
    direction reversals and turns of both signs;
  * an effect drive (range_bias=0.1, turn_slip=0.03): its meta truth_effect records, and the
    range residuals are centred on the injected bias;
  * the CLI refuses an unknown effect and a wrong value count with exit status 2, and a
    per-wheel effect on the sync drive;
  * per-wheel and out-of-catalogue forms (in-process, on open-loop drives without the
    1 Hz steering correction, so the encoder counts are the same with and without the
    effect; motion checks on noise-free drives, where the truth gives each cycle's wheel
    travels exactly): each form's formula is recovered from the truth by code written
    here, e.g. wheel_backlash loses exactly b per own-wheel reversal (end to end and on a
    scripted sequence where one wheel reverses alone), ooc_world_drift displaces the truth
    by (cx, cy) |travel| in the world frame, ooc_abrupt_scale starts at t_c, the incidence
    bias is zero at normal incidence and c (1/cos 40 deg - 1) at 40 degrees; a measurement form
    leaves the encoders, truth and range noise of the same seed unchanged.
  * map errors (--map-error, on a 1-minute drive against the clean drive of the same seed):
    the objects (a cabinet against a wall and a pillar in the open) are absent from the
    wall records, the beams that differ from the clean drive are exactly those whose ray
    cast (this file's) meets an object first, each shorter by the ray cast's difference;
    the phantom is the last wall record and no measured range ends on it; the shifted
    wall record is the real wall moved exactly d along its left normal, the other records
    unchanged; encoders and truth are those of the clean drive; the CLI refuses an
    object on the path, bad values and counts, an unknown kind with exit status 2, and
    --list-map-errors lists the three kinds.
Exits 1 with a message naming each failed check.
"""

import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
# The simulator's modules (odosim.py is the command, these its rooms).
import effect_table as sim_effects  # noqa: E402
import laser as sim_laser  # noqa: E402
import motion as sim_motion  # noqa: E402
import world as sim_world  # noqa: E402
ODOSIM = os.path.join(HERE, "odosim.py")
HEADER = {"drive", "param", "laser", "wall", "init", "meta"}
DATA_RANK = {"enc": 0, "scan": 1, "pose": 2, "truth": 3}
PARAMS = {"diff": {"wheel_radius_m", "ticks_per_rev", "wheelbase_m"},
          "sync": {"ticks_per_m", "ticks_per_rad"}}

failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        failures.append(what)
    return ok


class LogError(Exception):
    pass


def read_log(fname):
    """Minimal strict odolog v1 reader. Returns a dict of the parts."""
    log = {"params": {}, "walls": [], "meta": [], "enc": [], "scan": [], "truth": [],
           "drive": None, "laser": None, "init": None}
    seen_version = seen_data = False
    last = (-math.inf, -1)
    with open(fname, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            tok = line.split("#", 1)[0].split()
            if not tok:
                continue
            kind = tok[0]

            def fail(rule):
                raise LogError(f"{fname}:{n}: {rule}")

            if not seen_version:
                if tok != ["odolog", "1"]:
                    fail("the first record must be 'odolog 1'")
                seen_version = True
                continue
            if kind in HEADER:
                if seen_data:
                    fail(f"header record '{kind}' after a data record")
                if kind == "drive":
                    if len(tok) != 2 or tok[1] not in PARAMS or log["drive"]:
                        fail("one 'drive diff|sync' record")
                    log["drive"] = tok[1]
                elif kind == "param":
                    if len(tok) != 3 or tok[1] in log["params"]:
                        fail("'param NAME VALUE', each NAME once")
                    log["params"][tok[1]] = float(tok[2])
                elif kind == "laser":
                    if len(tok) != 9:
                        fail("laser takes 8 fields")
                    log["laser"] = [int(tok[1])] + [float(v) for v in tok[2:]]
                elif kind == "wall":
                    if len(tok) != 5:
                        fail("wall takes 4 fields")
                    log["walls"].append([float(v) for v in tok[1:]])
                elif kind == "init":
                    if len(tok) != 7:
                        fail("init takes 6 fields")
                    log["init"] = [float(v) for v in tok[1:]]
                else:
                    log["meta"].append(tok[1:])
                continue
            if kind not in DATA_RANK:
                continue                      # unknown records are skipped
            seen_data = True
            try:
                t = float(tok[1])
            except (IndexError, ValueError):
                fail("data record without a time")
            if not math.isfinite(t):
                fail("time must be finite")
            key = (t, DATA_RANK[kind])
            if key < last:
                fail("times must be non-decreasing (enc, scan, truth at equal times)")
            last = key
            if kind == "enc":
                if len(tok) != 4:
                    fail("enc takes T A B")
                try:
                    log["enc"].append((t, int(tok[2]), int(tok[3])))
                except ValueError:
                    fail("encoder counts must be integers")
            elif kind == "scan":
                if log["laser"] is None or len(tok) != 2 + log["laser"][0]:
                    fail("scan needs a laser record and N ranges")
                log["scan"].append([t] + [float(v) for v in tok[2:]])
            elif kind == "truth":
                if len(tok) != 5 or "nan" in tok:
                    fail("truth takes T X Y THETA, no nan")
                log["truth"].append([float(v) for v in tok[1:]])
    if not seen_version:
        raise LogError(f"{fname}: empty file")
    if log["drive"] is None or log["laser"] is None or log["init"] is None:
        raise LogError(f"{fname}: drive, laser and init records are required")
    if set(log["params"]) != PARAMS[log["drive"]]:
        raise LogError(f"{fname}: params {sorted(log['params'])} do not match the drive")
    for k in ("enc", "scan", "truth"):
        log[k] = np.array(log[k], dtype=float)
    log["walls"] = np.array(log["walls"])
    return log


def ray_ranges(x, y, th, laser, walls):
    """Expected ranges of one scan from pose (x, y, th); nan where no wall is hit."""
    n, amin, ainc, rmax, _sigma, mx, my, myaw = laser
    ox = x + math.cos(th) * mx - math.sin(th) * my
    oy = y + math.sin(th) * mx + math.cos(th) * my
    phi = th + myaw + amin + ainc * np.arange(n)
    out = np.full(n, np.nan)
    for x1, y1, x2, y2 in walls:
        # solve o + r (cos phi, sin phi) = p1 + u (p2 - p1) by Cramer's rule
        ex, ey = x2 - x1, y2 - y1
        c, s = np.cos(phi), np.sin(phi)
        det = -c * ey + s * ex
        with np.errstate(divide="ignore", invalid="ignore"):
            r = (-(x1 - ox) * ey + (y1 - oy) * ex) / det
            u = (c * (y1 - oy) - s * (x1 - ox)) / det
        good = (np.abs(det) > 1e-12) & (r > 0) & (u >= 0) & (u <= 1) & (r <= rmax)
        better = good & ~(out <= r)          # nan compares False: first hit taken
        out[better] = r[better]
    return out


def residuals(log):
    """Measured minus ray-cast range for every beam with both values (flattened)."""
    truth = {round(row[0], 6): row[1:] for row in log["truth"]}
    res = []
    for row in log["scan"]:
        x, y, th = truth[round(row[0], 6)]
        res.append(row[1:] - ray_ranges(x, y, th, log["laser"], log["walls"]))
    res = np.concatenate(res)
    return res[np.isfinite(res)], res.size


def min_wall_distance(log):
    p = log["truth"][:, 1:3]
    best = math.inf
    for x1, y1, x2, y2 in log["walls"]:
        a, e = np.array([x1, y1]), np.array([x2 - x1, y2 - y1])
        u = np.clip(((p - a) @ e) / (e @ e), 0.0, 1.0)
        best = min(best, float(np.hypot(*(p - a - u[:, None] * e).T).min()))
    return best


def motion_stats(log):
    """(reversals, max and min 1 s turn rate) from the truth."""
    tr = log["truth"]
    d = np.diff(tr[:, 1:3], axis=0)
    th = tr[:-1, 3]
    dt = np.diff(tr[:, 0])
    v = (d[:, 0] * np.cos(th) + d[:, 1] * np.sin(th)) / dt
    v = np.convolve(v, np.ones(10) / 10, mode="valid")       # 0.1 s average
    reversals, sign = 0, 0
    for vi in v:
        if abs(vi) > 0.05:                                    # hysteresis
            s = 1 if vi > 0 else -1
            reversals += sign != 0 and s != sign
            sign = s
    heading = np.unwrap(tr[:, 3])
    n = int(round(1.0 / np.median(dt)))
    w = (heading[n:] - heading[:-n]) / (tr[n:, 0] - tr[:-n, 0])
    return reversals, float(w.max()), float(w.min())


def generate(path, *args):
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, ODOSIM, "--out", path, *args],
                       capture_output=True, text=True)
    dt = time.perf_counter() - t0
    check(p.returncode == 0, f"odosim {' '.join(args)} ran ({dt:.2f} s)"
          + ("" if p.returncode == 0 else ": " + p.stderr.strip()))
    return p.returncode == 0


def check_clean(path, label):
    try:
        log = read_log(path)
    except LogError as e:
        check(False, f"{label}: valid odolog v1 ({e})")
        return
    check(True, f"{label}: valid odolog v1 header, times non-decreasing, record order")
    check(len(log["enc"]) == 6001 and len(log["truth"]) == 6001 and len(log["scan"]) == 600,
          f"{label}: 100 Hz enc/truth and 10 Hz scans "
          f"({len(log['enc'])}, {len(log['truth'])}, {len(log['scan'])})")
    check(np.allclose(log["init"][:3], log["truth"][0, 1:]),
          f"{label}: init is the true start pose")
    res, total = residuals(log)
    sigma = log["laser"][4]
    frac = np.mean(np.abs(res) < 5 * sigma) * len(res) / total
    check(frac > 0.99, f"{label}: {100 * frac:.2f} % of beams within 5 sigma of the ray cast "
          f"(residual mean {1000 * res.mean():+.2f} mm, std {1000 * res.std():.1f} mm)")
    clear = min_wall_distance(log)
    check(clear > 1.0, f"{label}: minimum wall clearance {clear:.2f} m > 1 m")
    rev, wmax, wmin = motion_stats(log)
    check(rev >= 2, f"{label}: {rev} direction reversals (>= 2)")
    check(wmax > 0.2 and wmin < -0.2,
          f"{label}: turns both ways (1 s turn rate {wmin:+.2f} .. {wmax:+.2f} rad/s)")


# ---------------------------------------------------------------------------
# Per-wheel and out-of-catalogue forms (in-process)
# ---------------------------------------------------------------------------

class ZeroRng:
    """Stands in for the noise generator: every draw is 0 (a noise-free drive)."""

    @staticmethod
    def standard_normal(shape):
        return np.zeros(shape)


def open_loop(effects, seed=7, minutes=1.0, noise=False, drive="diff"):
    """(enc, truth, record) of an open-loop drive (no steering correction)."""
    n = int(round(minutes * 60.0 / sim_world.DT))
    rngs = [np.random.default_rng([seed, i]) for i in range(4)]
    rec = {}
    enc, truth = sim_motion.simulate_motion(drive, n, effects, sim_motion.Path(), rngs[0],
                                            rngs[1] if noise else ZeroRng(), rngs[2],
                                            steer_feedback=False, record=rec)
    return enc, truth, rec


def increments(truth):
    """Per cycle (rho, dtheta, side) from the truth: the mid-point rule inverted."""
    d = np.diff(truth, axis=0)
    mid = truth[:-1, 2] + 0.5 * d[:, 2]
    c, s = np.cos(mid), np.sin(mid)
    return c * d[:, 0] + s * d[:, 1], d[:, 2], -s * d[:, 0] + c * d[:, 1]


def wheels(truth):
    """Per cycle true wheel travels (R, L) of a diff drive (side must be 0)."""
    rho, dth, _ = increments(truth)
    half = 0.5 * sim_world.WHEELBASE * sim_world.DIFF_TRUTH["delta_d"]
    return rho + dth * half, rho - dth * half


def own_reversals(x):
    """Indices of the cycles where the sign of x flips against its last non-zero sign."""
    out, last = [], 0
    for i, v in enumerate(x):
        sg = int(v > 0) - int(v < 0)
        if sg and last and sg != last:
            out.append(i)
        if sg:
            last = sg
    return out


def span_losses(x_clean, x_eff, revs):
    """Travel lost from each reversal to the next (or to the end)."""
    bounds = list(revs) + [len(x_clean)]
    d = x_eff - x_clean
    # the lost travel has the sign of the travel: count it as a positive loss
    return [float(-(np.sign(x_clean[a:b]) * d[a:b]).sum()) for a, b in zip(bounds, bounds[1:])]


def check_wheel_forms():
    b_R, b_L = 0.01, 0.006
    # scripted: the right wheel reverses alone (3 mm, 7 mm and 3 cm steps, one straddling
    # the end of the span); the left wheel keeps its direction and loses nothing
    right = [0.003] * 20 + [-0.007] * 12 + [0.03] * 4 + [-0.003] * 30
    left = [0.004] * len(right)
    losses_R, losses_L = [], []
    for b, seq, out in ((b_R, right, losses_R), (b_L, left, losses_L)):
        sl = sim_motion.SpanLoss(b)
        lost = [x - x * sl.factor(x) for x in seq]
        revs = own_reversals(seq)
        out.extend(span_losses(np.array(seq), np.array(seq) - np.array(lost), revs))
    check(len(losses_R) == 3 and max(abs(v - b_R) for v in losses_R) < 1e-12
          and losses_L == [],
          f"wheel_backlash scripted: right wheel loses {[round(v, 6) for v in losses_R]} "
          f"at its 3 own reversals (b_R {b_R}), the left wheel, not reversing, "
          f"{len(losses_L)} losses")

    enc0, tr0, rec0 = open_loop({})
    R0, L0 = wheels(tr0)
    check(np.allclose(R0, rec0["wheel_R"], atol=1e-12) and np.allclose(L0, rec0["wheel_L"], atol=1e-12),
          "noise-free open-loop drive: wheel travels recovered from the truth")
    enc, tr, _ = open_loop({"wheel_backlash": [b_R, b_L]})
    R, L = wheels(tr)
    same_enc = np.array_equal(enc, enc0)
    # reversals and signs from the drive model's own travel (exact zeros when standing)
    WR, WL = rec0["wheel_R"], rec0["wheel_L"]
    lR = span_losses(WR, WR + (R - R0), own_reversals(WR))
    lL = span_losses(WL, WL + (L - L0), own_reversals(WL))
    ok = (same_enc and len(lR) >= 2 and len(lL) >= 2
          and max(abs(v - b_R) for v in lR) < 1e-9 and max(abs(v - b_L) for v in lL) < 1e-9)
    first = own_reversals(WR)[0]
    untouched = np.allclose(R[:first], R0[:first], atol=1e-15)
    check(ok and untouched,
          f"wheel_backlash {b_R},{b_L} end to end: {len(lR)} right / {len(lL)} left own "
          f"reversals, loss per reversal R {min(lR):.6f}..{max(lR):.6f}, L "
          f"{min(lL):.6f}..{max(lL):.6f} m, nothing lost before the first")

    kR, kL = 0.05, 0.02
    enc, tr, _ = open_loop({"wheel_speed_scale": [kR, kL]})
    R, L = wheels(tr)
    m = np.abs(R0) > 1e-6
    eR = np.abs(R[m] / R0[m] - (1 + kR * np.abs(R0[m]) / sim_world.DT)).max()
    m = np.abs(L0) > 1e-6
    eL = np.abs(L[m] / L0[m] - (1 + kL * np.abs(L0[m]) / sim_world.DT)).max()
    check(np.array_equal(enc, enc0) and eR < 1e-9 and eL < 1e-9,
          f"wheel_speed_scale {kR},{kL}: each wheel's travel scaled by 1 + k_X |v_X| "
          f"(max error {max(eR, eL):.1e})")

    t_c, k_ab = 20.0, -0.02
    enc, tr, _ = open_loop({"ooc_abrupt_scale": [t_c, k_ab]})
    R, L = wheels(tr)
    kc = int(round(t_c / sim_world.DT))
    m = np.abs(R0) > 1e-6
    ratio = np.where(m, R / np.where(m, R0, 1.0), np.nan)
    before_ok = np.array_equal(tr[:kc + 1], tr0[:kc + 1])
    after_ok = np.nanmax(np.abs(ratio[kc:] - (1 + k_ab))) < 1e-9
    first_changed = int(np.argmax(np.any(tr != tr0, axis=1))) - 1    # cycle index
    check(before_ok and after_ok and np.allclose(L, L0, atol=1e-12) and first_changed == kc,
          f"ooc_abrupt_scale {t_c},{k_ab}: truth identical up to t_c, the right wheel "
          f"scaled by 1 + kR from the cycle at t = {first_changed * sim_world.DT:.2f} s on, "
          f"the left untouched")

    k_dr = 0.1
    enc, tr, _ = open_loop({"ooc_one_wheel_drag": [k_dr]})
    R, L = wheels(tr)
    m = np.abs(L0) > 1e-6
    eL = np.abs(L[m] / L0[m] - (1 - k_dr * (L0[m] / sim_world.DT) ** 2)).max()
    check(np.array_equal(enc, enc0) and eL < 1e-9 and np.allclose(R, R0, atol=1e-12),
          f"ooc_one_wheel_drag {k_dr}: L scaled by 1 - k v_L^2 (max error {eL:.1e}), "
          f"R untouched")


def check_robot_forms():
    enc0, tr0, rec0 = open_loop({})
    rho0, dth0, side0 = increments(tr0)
    travel = rec0["travel"]

    cx, cy = 0.012, -0.008
    enc, tr, _ = open_loop({"ooc_world_drift": [cx, cy]})
    s_abs = np.concatenate([[0.0], np.cumsum(np.abs(travel))])
    ex = np.abs((tr[:, 0] - tr0[:, 0]) - cx * s_abs).max()
    ey = np.abs((tr[:, 1] - tr0[:, 1]) - cy * s_abs).max()
    check(np.array_equal(enc, enc0) and np.array_equal(tr[:, 2], tr0[:, 2])
          and ex < 1e-9 and ey < 1e-9,
          f"ooc_world_drift {cx},{cy}: truth displaced by (cx, cy) |travel| in the world "
          f"frame ({tr[-1, 0] - tr0[-1, 0]:+.4f}, {tr[-1, 1] - tr0[-1, 1]:+.4f} m after "
          f"{s_abs[-1]:.1f} m; error {max(ex, ey):.1e}), heading unchanged")

    k, th0 = 0.03, 0.5
    enc, tr, _ = open_loop({"ooc_heading_scale": [k, th0]})
    rho, dth, side = increments(tr)
    m = np.abs(rho0) > 1e-6
    want = 1 + k * np.cos(tr0[:-1, 2] - th0)
    err = np.abs(rho[m] / rho0[m] - want[m]).max()
    check(np.array_equal(tr[:, 2], tr0[:, 2]) and err < 1e-9,
          f"ooc_heading_scale {k},{th0}: rho scaled by 1 + k cos(theta - theta0) "
          f"(factor {want.min():.3f}..{want.max():.3f}, error {err:.1e})")

    kc = 0.2
    enc, tr, _ = open_loop({"ooc_turn_slip_cubic": [kc]})
    rho, dth, side = increments(tr)
    a = (rho0 / sim_world.DT) * (dth0 / sim_world.DT)
    want = kc * a ** 3 * rho0
    err = np.abs(side - want).max()
    check(np.array_equal(tr[:, 2], tr0[:, 2]) and np.abs(side0).max() < 1e-12 and err < 1e-12
          and np.abs(want).max() > 1e-5,
          f"ooc_turn_slip_cubic {kc}: side = k (v w)^3 rho per cycle (largest "
          f"{1e3 * np.abs(want).max():.3f} mm, error {err:.1e})")

    # with the drive's noise: an effect changes neither the encoders nor the noise draws
    encn, trn, _ = open_loop({}, noise=True)
    encw, trw, _ = open_loop({"ooc_world_drift": [cx, cy]}, noise=True)
    check(np.array_equal(encn, encw) and np.array_equal(trn[:, 2], trw[:, 2]),
          "same seed, same noise: open-loop noisy drives with and without world drift "
          "have the same encoders and heading")


def check_beam_forms():
    # one scan from a fixed pose facing the wall x = 10 at normal incidence
    x, y, th = 3.0, 4.0, 0.0      # beam 0 deg hits x = 10 square on, beam 40 deg at 40 deg
    truth = np.tile([x, y, th], (sim_world.SCAN_EVERY + 1, 1))
    ref_k, ref = sim_laser.simulate_scans(truth, sim_world.SCAN_EVERY, {}, np.random.default_rng(1))
    alpha = sim_world.ANGLE_MIN + sim_world.ANGLE_INC * np.arange(sim_world.N_BEAMS)
    laser = [sim_world.N_BEAMS, sim_world.ANGLE_MIN, sim_world.ANGLE_INC, sim_world.RANGE_MAX,
             sim_world.RANGE_SIGMA, *sim_world.MOUNT]
    c = 0.015
    _, r = sim_laser.simulate_scans(truth, sim_world.SCAN_EVERY, {"ooc_incidence_bias": [c]},
                                    np.random.default_rng(1))
    d = (r - ref)[0]
    i0 = int(np.argmin(np.abs(alpha)))                    # straight ahead: normal
    i40 = int(np.argmin(np.abs(alpha - math.radians(40))))  # hits x = 10 at 40 deg
    ox = x + sim_world.MOUNT[0]
    # incidence of each beam computed here: the wall hit by the ray cast of this file
    walls = np.array(sim_world.WALLS)
    want = np.zeros(sim_world.N_BEAMS)
    for i in range(sim_world.N_BEAMS):
        best, cosv = math.inf, None
        ca, sa = math.cos(alpha[i]), math.sin(alpha[i])
        for x1, y1, x2, y2 in walls:
            ex, ey = x2 - x1, y2 - y1
            det = -ca * ey + sa * ex
            if abs(det) < 1e-12:
                continue
            rr = (-(x1 - ox) * ey + (y1 - y) * ex) / det
            u = (ca * (y1 - y) - sa * (x1 - ox)) / det
            if rr > 0 and 0 <= u <= 1 and rr < best:
                best = rr
                cosv = abs(ca * ey - sa * ex) / math.hypot(ex, ey)
        want[i] = c * (1.0 / max(cosv, math.cos(math.radians(80))) - 1.0)
    err = np.nanmax(np.abs(d - want))
    w40 = c * (1.0 / math.cos(math.radians(40)) - 1.0)
    check(abs(d[i0]) < 1e-12 and abs(d[i40] - w40) < 1e-9 and err < 1e-9,
          f"ooc_incidence_bias {c}: zero at normal incidence ({d[i0]:.1e}), "
          f"c (1/cos 40 - 1) = {1e3 * d[i40]:.3f} mm at 40 deg, c (1/cos - 1) on every beam "
          f"(error {err:.1e})")

    s = 0.002
    _, r = sim_laser.simulate_scans(truth, sim_world.SCAN_EVERY, {"ooc_beam_angle_scale": [s]},
                                    np.random.default_rng(1))
    noise = ref[0] - ray_ranges(x, y, th, laser, walls)          # the same draws
    lz = list(laser)
    want = np.array([ray_ranges(x, y, th, lz[:1] + [a * (1 + s)] + [0.0] + lz[3:], walls)[0]
                     for a in alpha]) + noise
    err = np.nanmax(np.abs(r[0] - want))
    check(abs(r[0][i0] - ref[0][i0]) < 1e-12 and err < 1e-9,
          f"ooc_beam_angle_scale {s}: beam alpha cast at alpha (1 + s): straight ahead "
          f"unchanged, every beam matches a ray cast at the scaled angle (error {err:.1e})")

    enc0, tr0, _ = open_loop({}, noise=True)
    n = len(tr0) - 1
    k0, r0 = sim_laser.simulate_scans(tr0, n, {}, np.random.default_rng(3))
    ct = 1e-4
    k1, r1 = sim_laser.simulate_scans(tr0, n, {"ooc_range_time_drift": [ct]},
                                      np.random.default_rng(3))
    d = r1 - r0
    err = np.nanmax(np.abs(d - ct * (k0 * sim_world.DT)[:, None]))
    check(err < 1e-9 and abs(np.nanmax(d) - ct * k0[-1] * sim_world.DT) < 1e-9,
          f"ooc_range_time_drift {ct}: ranges + c t (scan at {k0[-1] * sim_world.DT:.0f} s: "
          f"+{1e3 * np.nanmax(d):.2f} mm; error {err:.1e})")


# ---------------------------------------------------------------------------
# Map errors (--map-error)
# ---------------------------------------------------------------------------

MAP_OBJECTS = [[5.0, 0.2, 0.6, 0.4], [4.3, 3.2, 0.3, 0.3]]    # cabinet, pillar
MAP_PHANTOM = [1.5, 3.0, 1.5, 4.5]
MAP_SHIFT = [0, 0.1]


def box_segments(x, y, w, h):
    x0, x1, y0, y1 = x - w / 2, x + w / 2, y - h / 2, y + h / 2
    return [[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]]


def map_error_args():
    out = []
    for o in MAP_OBJECTS:
        out += ["--map-error", "object=" + ",".join(repr(v) for v in o)]
    out += ["--map-error", "phantom=" + ",".join(repr(v) for v in MAP_PHANTOM),
            "--map-error", "shift=%d,%r" % tuple(MAP_SHIFT)]
    return out


def check_map_errors(log, log0):
    """log: the drive with MAP_OBJECTS, MAP_PHANTOM and MAP_SHIFT; log0: the clean drive
    of the same seed."""
    nominal = np.array(sim_world.WALLS, dtype=float)
    walls = log["walls"]
    metas = [m for m in log["meta"] if m[0] == "truth_map_error"]
    want_meta = ([["truth_map_error", "object"] + [repr(v) for v in o] for o in MAP_OBJECTS]
                 + [["truth_map_error", "phantom"] + [repr(v) for v in MAP_PHANTOM]]
                 + [["truth_map_error", "shift", "0", "0.1"]])
    check(metas == want_meta, f"map errors: meta truth_map_error records {metas}")
    same = (np.array_equal(log["enc"], log0["enc"])
            and np.array_equal(log["truth"], log0["truth"]))
    check(same, "map errors: same seed, same encoders and truth as the clean drive")

    # --- objects: in the world, not in the map -------------------------------------
    obj_segs = [sg for o in MAP_OBJECTS for sg in box_segments(*o)]
    in_records = [sg for sg in obj_segs
                  if any(np.allclose(sg, w) or np.allclose(sg[2:] + sg[:2], w) for w in walls)]
    check(len(walls) == len(nominal) + 1 and not in_records,
          f"map errors: {len(walls)} wall records (the {len(nominal)} real ones and the "
          f"phantom), no edge of the objects among them")
    # the world the laser sees: the real walls (not shifted, no phantom) and the objects
    world = np.concatenate([nominal, np.array(obj_segs)])
    truth = {round(row[0], 6): row[1:] for row in log["truth"]}
    r_meas, r_clean = log["scan"][:, 1:], log0["scan"][:, 1:]
    hit_obj = np.zeros(r_meas.shape, bool)
    want_d = np.zeros(r_meas.shape)
    r_phantom = np.full(r_meas.shape, np.nan)
    for k, row in enumerate(log["scan"]):
        x, y, th = truth[round(row[0], 6)]
        r_wall = ray_ranges(x, y, th, log["laser"], nominal)
        r_world = ray_ranges(x, y, th, log["laser"], world)
        r_obj = ray_ranges(x, y, th, log["laser"], np.array(obj_segs))
        hit_obj[k] = np.isfinite(r_obj) & (r_obj <= r_world + 1e-9)
        want_d[k] = r_world - r_wall
        r_phantom[k] = ray_ranges(x, y, th, log["laser"], [MAP_PHANTOM])
    differ = ~((r_meas == r_clean) | (np.isnan(r_meas) & np.isnan(r_clean)))
    n_hit = int(hit_obj.sum())
    err = float(np.nanmax(np.abs((r_meas - r_clean - want_d)[hit_obj]))) if n_hit else math.inf
    shorter = bool(np.all((r_meas - r_clean)[hit_obj] < 0.0))
    scans_hit = int(hit_obj.any(axis=1).sum())
    check(n_hit > 50 and np.array_equal(differ, hit_obj) and shorter and err < 2e-6,
          f"map errors: the objects shorten exactly the {n_hit} beams (in {scans_hit} scans) "
          f"whose ray meets an object first, by the ray cast's difference (median "
          f"{np.median((r_meas - r_clean)[hit_obj]):+.2f} m, error {err:.1e}); every other "
          f"beam is the clean drive's")

    # --- phantom: in the map, not in the world ---------------------------------------
    on_phantom = np.abs(r_meas - r_phantom) < 5 * log["laser"][4]
    n_cross = int(np.isfinite(r_phantom).sum())
    check(np.allclose(walls[-1], MAP_PHANTOM, atol=0, rtol=0) and n_cross > 50
          and not on_phantom.any(),
          f"map errors: the phantom is the last wall record {walls[-1].tolist()}; "
          f"{n_cross} beams cross it, none of the measured ranges ends on it (5 sigma)")

    # --- shift: wall i written d along its left normal -------------------------------
    i, d = MAP_SHIFT
    x1, y1, x2, y2 = nominal[i]
    length = math.hypot(x2 - x1, y2 - y1)
    nx, ny = -(y2 - y1) / length, (x2 - x1) / length
    want = np.array([x1 + d * nx, y1 + d * ny, x2 + d * nx, y2 + d * ny])
    moved = walls[i] - nominal[i]
    others = np.array_equal(np.delete(walls[:len(nominal)], i, axis=0),
                            np.delete(nominal, i, axis=0))
    check(np.abs(walls[i] - want).max() < 1e-12 and others,
          f"map errors: shift {i},{d}: wall record {i}'s end points moved by "
          f"({moved[0]:+.3f}, {moved[1]:+.3f}) and ({moved[2]:+.3f}, {moved[3]:+.3f}) "
          f"= d x its left normal "
          f"({nx:+.0f}, {ny:+.0f}); the other real walls' records unchanged")


def main():
    t0 = time.perf_counter()
    check_wheel_forms()
    check_robot_forms()
    check_beam_forms()
    print(f"(in-process form checks: {time.perf_counter() - t0:.2f} s)")

    with tempfile.TemporaryDirectory() as tmp:
        clean = os.path.join(tmp, "clean.odolog")
        if generate(clean, "--minutes", "1", "--seed", "3"):
            check_clean(clean, "clean diff")
        sync = os.path.join(tmp, "sync.odolog")
        if generate(sync, "--minutes", "1", "--seed", "4", "--drive", "sync"):
            check_clean(sync, "clean sync")

        eff = os.path.join(tmp, "effect.odolog")
        if generate(eff, "--minutes", "1", "--seed", "3", "--effect", "range_bias=0.1",
                    "--effect", "turn_slip=0.03"):
            try:
                log = read_log(eff)
                check(True, "effect diff: valid odolog v1")
                metas = [m for m in log["meta"] if m[0] == "truth_effect"]
                check(["truth_effect", "range_bias", "0.1"] in metas
                      and ["truth_effect", "turn_slip", "0.03"] in metas,
                      f"effect diff: meta truth_effect records {metas}")
                res, _ = residuals(log)
                med = float(np.median(res))
                check(abs(med - 0.1) < 0.01,
                      f"effect diff: range residual median {med:.4f} m ~ injected 0.1 m")
            except LogError as e:
                check(False, f"effect diff: valid odolog v1 ({e})")

        ooc = os.path.join(tmp, "ooc.odolog")
        clean4 = os.path.join(tmp, "clean4.odolog")
        if (generate(ooc, "--minutes", "1", "--seed", "4", "--effect",
                     "ooc_incidence_bias=0.015", "--effect", "ooc_range_time_drift=1e-4")
                and generate(clean4, "--minutes", "1", "--seed", "4")):
            try:
                log, log0 = read_log(ooc), read_log(clean4)
                metas = [m for m in log["meta"] if m[0] == "truth_effect"]
                check(["truth_effect", "ooc_incidence_bias", "0.015"] in metas
                      and ["truth_effect", "ooc_range_time_drift", "0.0001"] in metas,
                      f"ooc diff: valid odolog v1, meta truth_effect records {metas}")
                same = (np.array_equal(log["enc"], log0["enc"])
                        and np.array_equal(log["truth"], log0["truth"]))
                d = log["scan"][:, 1:] - log0["scan"][:, 1:]
                drift = d - 1e-4 * log["scan"][:, :1]
                check(same and np.nanmin(drift) > -1e-5,
                      "ooc diff: same seed, same encoders and truth as the clean drive; "
                      f"ranges differ by c t plus a non-negative incidence bias "
                      f"(median {1e3 * np.nanmedian(drift):.2f} mm)")
            except LogError as e:
                check(False, f"ooc diff: valid odolog v1 ({e})")
        mapped = os.path.join(tmp, "map.odolog")
        if generate(mapped, "--minutes", "1", "--seed", "3", *map_error_args()):
            try:
                check_map_errors(read_log(mapped), read_log(clean))
            except (LogError, OSError) as e:
                check(False, f"map errors: valid odolog v1 ({e})")
        p = subprocess.run([sys.executable, ODOSIM, "--list-map-errors"], capture_output=True,
                           text=True)
        listed = {line.split()[0] for line in p.stdout.splitlines() if line.strip()}
        check(p.returncode == 0 and {"object", "phantom", "shift"} <= listed,
              "--list-map-errors lists object, phantom, shift")
        p = subprocess.run([sys.executable, ODOSIM, "--list-effects"], capture_output=True,
                           text=True)
        listed = {line.split()[0] for line in p.stdout.splitlines() if line.strip()}
        want = set(sim_effects.TEST_SIZES)
        check(p.returncode == 0 and len(want) >= 10 and want <= listed,
              f"--list-effects lists the {len(want)} per-wheel and out-of-catalogue forms")

        bad = os.path.join(tmp, "bad.odolog")
        for args in (["--effect", "no_such_effect=1"], ["--effect", "laser_mount_xy=0.1"],
                     ["--drive", "sync", "--effect", "wheel_backlash=0.01,0.01"],
                     ["--drive", "sync", "--effect", "ooc_one_wheel_drag=0.05"],
                     ["--effect", "ooc_world_drift=0.01"],
                     ["--map-error", "object=4.3,5.2,0.3,0.3"],      # on the path
                     ["--map-error", "object=7,2,0,0.5"],
                     ["--map-error", "object=7,2,0.5"],
                     ["--map-error", "phantom=2,2,2,2"],
                     ["--map-error", "shift=12,0.1"],
                     ["--map-error", "shift=0.5,0.1"],
                     ["--map-error", "shift=0,nan"],
                     ["--map-error", "shift=0,0.1", "--map-error", "shift=0,0.2"],
                     ["--map-error", "door=1,2"]):
            p = subprocess.run([sys.executable, ODOSIM, "--out", bad, *args],
                               capture_output=True, text=True)
            check(p.returncode == 2 and "error" in p.stderr,
                  f"CLI refuses {' '.join(args)} with exit 2 (got {p.returncode})")

    if failures:
        print(f"\ncheck_odosim: {len(failures)} check(s) FAILED:", file=sys.stderr)
        for f in failures:
            print("  - " + f, file=sys.stderr)
        return 1
    print("\ncheck_odosim: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
