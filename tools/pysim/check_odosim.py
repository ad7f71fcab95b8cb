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
  * the CLI refuses an unknown effect and a wrong value count with exit status 2.
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


def main():
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

        bad = os.path.join(tmp, "bad.odolog")
        for args in (["--effect", "no_such_effect=1"], ["--effect", "laser_mount_xy=0.1"]):
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
