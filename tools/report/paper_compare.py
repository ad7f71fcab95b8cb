#!/usr/bin/env python3
"""Side by side: the paper's Observable Filter and another K estimator on the same drive.

Usage: paper_compare.py PAPER_DIR OTHER_DIR [--at METRES]

Each directory is an `odoerr paper --out` directory (summary.json). Prints, for each
parameter and each start (K 100x below / above the truth), the mean over the truth, the
accuracy (100 std / mean, %), sigma's ratio to the spread, and the Cramer-Rao bounds (%):
`bound` with the systematic parameters known, `joint` with them unknown (K_w's differs on
the circle, docs/nonsystematic.md), at the last checkpoint (or --at).
Exits 1 with a message naming the file when a summary is missing, unreadable or does
not match the other (drive, runs, path).
"""
import argparse
import json
import os
import sys


def load(d):
    path = os.path.join(d, "summary.json")
    try:
        with open(path) as f:
            return json.load(f), path
    except (OSError, ValueError) as e:
        sys.exit(f"paper_compare: {path}: {e}")


def checkpoint(summary, path, init, at):
    for case in summary.get("cases", []):
        if case.get("init") != init:
            continue
        cps = case.get("checkpoints", [])
        if not cps:
            sys.exit(f"paper_compare: {path}: start '{init}' has no checkpoints")
        if at is None:
            return cps[-1]
        for cp in cps:
            if abs(cp["distance_m"] - at) < 1e-9:
                return cp
        sys.exit(f"paper_compare: {path}: no checkpoint at {at} m")
    sys.exit(f"paper_compare: {path}: no start '{init}'")


def cell(p):
    if p is None:
        return "-"
    ratio = p.get("sigma_ratio")
    r = f"{ratio:.2f}" if isinstance(ratio, (int, float)) else "-"
    return f"{p['mean'] / p['true']:.3f}x {p['accuracy_pct']:5.1f} % s{r}"


def pct(v):
    return f"{v:.2f} %" if isinstance(v, (int, float)) else "-"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paper_dir")
    ap.add_argument("other_dir")
    ap.add_argument("--at", type=float, default=None, help="checkpoint (m); default: the last")
    a = ap.parse_args()
    base, base_path = load(a.paper_dir)
    other, other_path = load(a.other_dir)
    for key in ("drive", "runs", "path"):
        if base.get(key) != other.get(key):
            sys.exit(f"paper_compare: {base_path} and {other_path} differ in {key}: "
                     f"{base.get(key)} / {other.get(key)}")
    names = (base.get("of", "paper"), other.get("of", "?"))
    print(f"{base['drive']} drive, {base['path']}, {base['runs']} runs: '{names[0]}' against "
          f"'{names[1]}' (mean / truth, accuracy = 100 std / mean, s = sigma / spread)")
    for init, label in (("small", "K from 100x below"), ("large", "K from 100x above")):
        cp_a = checkpoint(base, base_path, init, a.at)
        cp_b = checkpoint(other, other_path, init, a.at)
        print(f"  {label}, at {cp_a['distance_m']:g} m:")
        print(f"    {'':10} {names[0]:>24} {names[1]:>24} {'bound':>8} {'joint':>8}")
        for name, p in cp_a["params"].items():
            q = cp_b["params"].get(name)
            print(f"    {name:10} {cell(p):>24} {cell(q):>24} {pct(p.get('bound_pct')):>8} "
                  f"{pct(p.get('bound_pct_joint')):>8}")
        pa, pb = cp_a.get("pose_rms", {}), cp_b.get("pose_rms", {})
        if pa and pb:
            print(f"    {'pose RMS':10} {pa['position_m'] * 100:21.2f} cm {pb['position_m'] * 100:21.2f} cm")


if __name__ == "__main__":
    main()
