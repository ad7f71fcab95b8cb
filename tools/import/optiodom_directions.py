#!/usr/bin/env python3
"""What separates the clockwise from the counter-clockwise OptiOdom runs (docs/real-data.md,
"What separates the two directions"). For every circle and square run, from the raw ticks
(nominal constants) and the motion capture:
- kS: the motion capture's path length over the nominal odometry's (1 s samples);
- kT: the motion capture's total turn over the nominal odometry's ((sR - sL) / b).
Then, per group (recording day x path type x direction), the medians, and for the circles
the heading error per metre of travel e = (kT - 1) / R split into its part common to both
directions (a wheel-diameter ratio: the same sign whichever way the robot turns) and its
part that follows the turn (an effective wheelbase: a = 1 - R * odd part).

Usage: optiodom_directions.py [DATA_DIR]   (default: optiodom-diff in the data folder,
$ODOERR_DATA, else ../shared/data from the repository root; every run is needed, so the
sample in tests/data is not used)
"""
import glob
import os
import statistics
import sys

import import_common

TICK = 3.141592653589793 * 0.084 / (43.7 * 64)
B = 0.2


def load(path):
    rows = []
    for line in open(path, encoding="utf-8-sig"):
        f = line.strip().split(",")
        if len(f) >= 6:
            rows.append([float(v) for v in f[:6]])
    return rows


def runStats(path):
    rows = load(path)
    sR = sum(r[4] for r in rows) * TICK
    sL = sum(r[5] for r in rows) * TICK
    sub = rows[::20]
    L = sum(((b[1] - a[1]) ** 2 + (b[2] - a[2]) ** 2) ** 0.5 for a, b in zip(sub, sub[1:]))
    turn = rows[-1][3] - rows[0][3]
    moving = [r for r in rows if r[4] or r[5]]
    v = statistics.median((r[4] + r[5]) / 2 * TICK / 0.05 for r in moving)
    w = statistics.median((r[4] - r[5]) * TICK / B / 0.05 for r in moving)
    return {"dir": "cw" if turn < 0 else "ccw", "R": v / w if w else float("inf"), "v": v,
            "kS": L / ((sR + sL) / 2), "kT": turn / ((sR - sL) / B)}


def main():
    data = sys.argv[1] if len(sys.argv) > 1 else os.path.join(import_common.data_dir(), "optiodom-diff")
    if not os.path.isdir(data):
        print(import_common.skip_message("the direction analysis", data))
        return 77
    groups = {}
    print("| run | dir | R (m) | v (m/s) | kS | kT |\n|---|---|---|---|---|---|")
    for typ in ("circular", "square"):
        for c in sorted(glob.glob(os.path.join(data, typ, "*", "*_run-*.csv"))):
            s = runStats(c)
            name = os.path.basename(c)[:-4]
            print("| %s %s | %s | %+.3f | %.3f | %.4f | %.4f |" % (typ, name, s["dir"], s["R"], s["v"], s["kS"], s["kT"]))
            groups.setdefault((typ, name[:6], s["dir"]), []).append(s)
    med = lambda g, k: statistics.median(s[k] for s in g)
    print("\n| path | day (ddmmyy) | dir | runs | R (m) | v (m/s) | kS | kT | heading error (mrad/m) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for (typ, day, d), g in sorted(groups.items()):
        R = med(g, "R")
        e = (med(g, "kT") - 1) / R * 1e3 if typ == "circular" else float("nan")
        print("| %s | %s | %s | %d | %+.3f | %.3f | %.4f | %.4f | %+.1f |" % (
            typ, day, d, len(g), R, med(g, "v"), med(g, "kS"), med(g, "kT"), e))
    print("\n| circles of day | heading error common to both directions (mrad/m) | part that follows the turn: "
          "kT of a wheelbase-only error |\n|---|---|---|")
    for day in sorted({k[1] for k in groups if k[0] == "circular"}):
        cw, ccw = groups.get(("circular", day, "cw")), groups.get(("circular", day, "ccw"))
        if not cw or not ccw:
            continue
        Rc, Ra = med(cw, "R"), med(ccw, "R")
        ecw, eccw = (med(cw, "kT") - 1) / Rc, (med(ccw, "kT") - 1) / Ra
        R = (abs(Rc) + abs(Ra)) / 2
        print("| %s | %+.1f | %.4f |" % (day, 1e3 * (ecw + eccw) / 2, 1 + R * (eccw - ecw) / 2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
