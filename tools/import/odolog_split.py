#!/usr/bin/env python3
"""odolog_split.py: cut an odolog in two at a truth record, so that one part can calibrate
and the other test (odoerr evaluate; docs/real-data.md, the Intel lab end to end).

Usage: odolog_split.py LOG --first OUT1 --second OUT2 [--fraction 0.5]

The cut is the first truth record at or past FRACTION of the log's truth path length
that has an enc record at the same time (the Intel importer writes one at every scan).
Both parts keep the header records (meta, drive, param, laser, wall). The first part
ends at the cut; the second starts there, with `init` at the truth pose of the cut (the
original init's sigmas) and enc counts rebased to 0 0, as docs/odolog.md asks. A log
without such a cut point is refused with a message.
"""
import argparse
import math
import sys

HEADER = ("odolog", "meta", "drive", "param", "laser", "wall")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("log")
    ap.add_argument("--first", required=True)
    ap.add_argument("--second", required=True)
    ap.add_argument("--fraction", type=float, default=0.5)
    a = ap.parse_args()
    if not 0.0 < a.fraction < 1.0:
        sys.exit("odolog_split: --fraction must lie in (0, 1)")
    header, data, init = [], [], None
    with open(a.log) as f:
        for n, line in enumerate(f, 1):
            p = line.split()
            if not p or p[0].startswith("#"):
                continue
            if p[0] in HEADER:
                header.append(line.rstrip("\n"))
            elif p[0] == "init":
                init = p
            else:
                try:
                    data.append((float(p[1]), p, n))
                except (IndexError, ValueError):
                    sys.exit(f"odolog_split: {a.log}:{n}: a data record without a time")
    if init is None:
        sys.exit(f"odolog_split: {a.log}: no 'init' record")
    truth = [(t, p) for t, p, _ in data if p[0] == "truth"]
    enc_times = {t for t, p, _ in data if p[0] == "enc"}
    if len(truth) < 3:
        sys.exit(f"odolog_split: {a.log}: fewer than 3 truth records; nothing to cut at")
    path = [0.0]
    for (_, p0), (_, p1) in zip(truth, truth[1:]):
        path.append(path[-1] + math.hypot(float(p1[2]) - float(p0[2]), float(p1[3]) - float(p0[3])))
    cut = None
    for (t, p), s in zip(truth, path):
        if s >= a.fraction * path[-1] and t in enc_times:
            cut = (t, p)
            break
    if cut is None:
        sys.exit(f"odolog_split: {a.log}: no truth record past {a.fraction} of the path has an enc record at its time")
    t_cut, p_cut = cut
    base = next(p for t, p, _ in data if p[0] == "enc" and t == t_cut)
    ba, bb = int(base[2]), int(base[3])
    with open(a.first, "w") as f1, open(a.second, "w") as f2:
        for h in header:
            f1.write(h + "\n")
            f2.write(h + "\n")
        f1.write(f"meta split first part of {a.log}, up to t={t_cut}\n")
        f2.write(f"meta split second part of {a.log}, from t={t_cut}\n")
        f1.write(" ".join(init) + "\n")
        f2.write(f"init {p_cut[2]} {p_cut[3]} {p_cut[4]} {init[4]} {init[5]} {init[6]}\n")
        for t, p, _ in data:
            if t <= t_cut:
                f1.write(" ".join(p) + "\n")
            if t >= t_cut:
                if p[0] == "enc":
                    f2.write(f"enc {p[1]} {int(p[2]) - ba} {int(p[3]) - bb}\n")
                elif not (t == t_cut and p[0] != "enc" and p[0] != "truth"):
                    f2.write(" ".join(p) + "\n")
    print(f"odolog_split: cut at t={t_cut} ({a.fraction:.2f} of {path[-1]:.1f} m of truth path): {a.first}, {a.second}")


if __name__ == "__main__":
    main()
