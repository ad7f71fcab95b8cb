"""The self-check's shared part (check_odosim.py is its command): the tally of checks, a
minimal strict odolog v1 reader written independently of odosim.py's writer, and a ray cast
from a pose against wall segments."""

import math

import numpy as np

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
