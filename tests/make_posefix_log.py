#!/usr/bin/env python3
"""A pose-fix log from a simulated one (tests of `odoerr evaluate --fix-sigma`): the laser,
its scans and the walls are dropped, and a `pose` fix is written every PERIOD seconds from
the truth, with Gaussian noise of the TRUE sigmas and the DECLARED sigmas in the record.

Usage: make_posefix_log.py IN.odolog OUT.odolog --true XY,TH --declared XY,TH [--period S] [--seed N]
"""
import argparse
import math
import random
import sys


def pair(s):
    a, b = (float(v) for v in s.split(","))
    return a, b


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("inp")
    ap.add_argument("out")
    ap.add_argument("--true", type=pair, required=True)
    ap.add_argument("--declared", type=pair, required=True)
    ap.add_argument("--period", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    rng = random.Random(a.seed)
    out, t0, next_t = [], None, None
    for line in open(a.inp):
        f = line.split()
        if not f or f[0] in ("laser", "scan", "wall"):
            continue
        out.append(line.rstrip("\n"))
        if f[0] == "truth":
            t = float(f[1])
            if t0 is None:
                t0, next_t = t, t + a.period
            elif t >= next_t - 1e-9:
                next_t += a.period
                x = float(f[2]) + rng.gauss(0, a.true[0])
                y = float(f[3]) + rng.gauss(0, a.true[0])
                th = float(f[4]) + rng.gauss(0, a.true[1])
                out.append("pose %.6f %.6f %.6f %.7f %g %g %g" % (t, x, y, th, a.declared[0], a.declared[0],
                                                                  a.declared[1]))
    if t0 is None:
        sys.exit("%s: no truth record" % a.inp)
    open(a.out, "w").write("\n".join(out) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
