#!/usr/bin/env python3
"""Side by side: the paper's Observable Filter and another K estimator on the same drive.

Usage: paper_compare.py PAPER_DIR OTHER_DIR [--at METRES]

Each directory is an `odoerr paper --out` directory (summary.json). Prints, for each
parameter and each start (K 100x below / above the truth), the mean over the truth, the
accuracy (100 std / mean, %), sigma's ratio to the spread, and the Cramer-Rao bounds (%):
`bound` (summary.json's bound_pct: K's with the systematic parameters unknown, as the AKF
estimates them) and `known` (bound_pct_known: K's with them known; K_w's differs on the
circle, docs/nonsystematic.md), at the last checkpoint (or --at).

--paired adds, run by run on the same drives (runs_<drive>.csv, paired by start and seed),
the end error of each systematic parameter (RMS about the truth) and of the pose (position
and heading RMS): the ratio OTHER / PAPER with its 95 % paired bootstrap interval
(scipy.stats.bootstrap, BCa, fixed seed). --no-worse (implies --paired) exits 1 when an
interval lies wholly above 1: the other estimator is then significantly worse than the
paper's OF on that quantity (issue 15's acceptance: "the systematic parameters and the pose
error are no worse than with the paper's OF").

Exits 2 with a message naming the file when a summary or a runs CSV is missing, unreadable
or does not match the other (drive, runs, path, the runs' seeds).
"""
import argparse
import csv
import json
import os
import sys

import numpy as np


def fail(msg):
    print(f"paper_compare: {msg}", file=sys.stderr)
    sys.exit(2)


def load(d):
    path = os.path.join(d, "summary.json")
    try:
        with open(path) as f:
            return json.load(f), path
    except (OSError, ValueError) as e:
        fail(f"{path}: {e}")


def checkpoint(summary, path, init, at):
    for case in summary.get("cases", []):
        if case.get("init") != init:
            continue
        cps = case.get("checkpoints", [])
        if not cps:
            fail(f"{path}: start '{init}' has no checkpoints")
        if at is None:
            return cps[-1]
        for cp in cps:
            if abs(cp["distance_m"] - at) < 1e-9:
                return cp
        fail(f"{path}: no checkpoint at {at} m")
    fail(f"{path}: no start '{init}'")


def cell(p):
    if p is None:
        return "-"
    ratio = p.get("sigma_ratio")
    r = f"{ratio:.2f}" if isinstance(ratio, (int, float)) else "-"
    return f"{p['mean'] / p['true']:.3f}x {p['accuracy_pct']:5.1f} % s{r}"


def pct(v):
    return f"{v:.2f} %" if isinstance(v, (int, float)) else "-"


def load_runs(d, summary):
    """runs_<drive>.csv as {init: {seed: {column: value}}}; a malformed row names its line."""
    fn = os.path.join(d, f"runs_{summary['drive']}.csv")
    out = {}
    try:
        with open(fn, newline="") as f:
            for line, row in enumerate(csv.DictReader(f), start=2):
                try:
                    vals = {k: float(v) for k, v in row.items() if k not in ("init", "run", "seed")}
                    seed = int(row["seed"])
                except (TypeError, ValueError, KeyError) as e:
                    fail(f"{fn}:{line}: malformed row ({e})")
                out.setdefault(row["init"], {})[seed] = vals
    except OSError as e:
        fail(f"{fn}: {e}")
    return out, fn


def rms_ratio(err_a, err_b, axis=-1):
    """RMS of err_b over RMS of err_a (the bootstrap's statistic, vectorised along axis)."""
    return np.sqrt(np.mean(err_b ** 2, axis=axis) / np.mean(err_a ** 2, axis=axis))


def paired(base, base_dir, base_path, other, other_dir):
    """Per start, the other's end error over the paper's with a 95 % paired bootstrap
    interval, for each systematic parameter (about the truth) and the pose. Returns the
    quantities whose interval lies wholly above 1."""
    from scipy import stats  # only here: the side-by-side table needs no scipy
    runs_a, fn_a = load_runs(base_dir, base)
    runs_b, fn_b = load_runs(other_dir, other)
    worse = []
    print("  paired, run by run (same seeds): end error's RMS, other / paper, [95 % paired bootstrap]")
    for init in ("small", "large"):
        ra, rb = runs_a.get(init, {}), runs_b.get(init, {})
        if not ra or sorted(ra) != sorted(rb):
            fail(f"{fn_a} and {fn_b}: start '{init}' has other seeds ({len(ra)} / {len(rb)} runs)")
        if len(ra) < 10:
            fail(f"{fn_a}: start '{init}' has {len(ra)} runs; a paired comparison needs at least 10")
        seeds = sorted(ra)
        start = "from below" if init == "small" else "from above"
        cp = checkpoint(base, base_path, init, None)
        rows = [(n, p["true"]) for n, p in cp["params"].items() if not n.startswith("K_")]
        rows += [("pos_err_m", 0.0), ("heading_err_rad", 0.0)]
        cells = []
        for name, truth in rows:
            try:
                ea = np.array([ra[s][name] - truth for s in seeds])
                eb = np.array([rb[s][name] - truth for s in seeds])
            except KeyError:
                fail(f"{fn_a} or {fn_b}: no column '{name}'")
            q = float(rms_ratio(ea, eb))
            if np.all(ea == eb):  # the same numbers: no interval to draw
                lo = hi = q
            else:
                ci = stats.bootstrap((ea, eb), rms_ratio, paired=True, vectorized=True, n_resamples=4000,
                                     method="BCa", random_state=np.random.default_rng(1)).confidence_interval
                lo, hi = float(ci.low), float(ci.high)
            label = {"pos_err_m": "position", "heading_err_rad": "heading"}.get(name, name)
            flag = " WORSE" if lo > 1 else ""
            cells.append(f"{label} {q:.3f} [{lo:.3f}, {hi:.3f}]{flag}")
            if lo > 1:
                worse.append(f"{start}: {label} {q:.3f}x [{lo:.3f}, {hi:.3f}]")
        print(f"    {start}: " + "; ".join(cells))
    return worse


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paper_dir")
    ap.add_argument("other_dir")
    ap.add_argument("--at", type=float, default=None, help="checkpoint (m); default: the last")
    ap.add_argument("--paired", action="store_true", help="run-by-run ratios of the end errors, with intervals")
    ap.add_argument("--no-worse", action="store_true",
                    help="with --paired: exit 1 when the other is significantly worse on a systematic parameter or the pose")
    a = ap.parse_args()
    base, base_path = load(a.paper_dir)
    other, other_path = load(a.other_dir)
    for key in ("drive", "runs", "path"):
        if base.get(key) != other.get(key):
            fail(f"{base_path} and {other_path} differ in {key}: {base.get(key)} / {other.get(key)}")
    names = (base.get("of", "paper"), other.get("of", "?"))
    print(f"{base['drive']} drive, {base['path']}, {base['runs']} runs: '{names[0]}' against "
          f"'{names[1]}' (mean / truth, accuracy = 100 std / mean, s = sigma / spread)")
    for init, label in (("small", "K from 100x below"), ("large", "K from 100x above")):
        cp_a = checkpoint(base, base_path, init, a.at)
        cp_b = checkpoint(other, other_path, init, a.at)
        print(f"  {label}, at {cp_a['distance_m']:g} m:")
        print(f"    {'':10} {names[0]:>24} {names[1]:>24} {'bound':>8} {'known':>8}")
        for name, p in cp_a["params"].items():
            q = cp_b["params"].get(name)
            print(f"    {name:10} {cell(p):>24} {cell(q):>24} {pct(p.get('bound_pct')):>8} "
                  f"{pct(p.get('bound_pct_known')):>8}")
        pa, pb = cp_a.get("pose_rms", {}), cp_b.get("pose_rms", {})
        if pa and pb:
            print(f"    {'pose RMS':10} {pa['position_m'] * 100:21.2f} cm {pb['position_m'] * 100:21.2f} cm")
    if a.paired or a.no_worse:
        worse = paired(base, a.paper_dir, base_path, other, a.other_dir)
        if a.no_worse:
            if worse:
                print(f"significantly worse than '{names[0]}': " + "; ".join(worse))
                return 1
            print(f"no worse than '{names[0]}': no interval lies wholly above 1")
    return 0


if __name__ == "__main__":
    sys.exit(main())
