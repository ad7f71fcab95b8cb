#!/usr/bin/env python3
"""Tests of tools/report/paper_compare.py --paired / --no-worse on synthetic paper directories.

  test_paper_compare.py PAPER_COMPARE WORKDIR

Two `odoerr paper --out` directories are written by hand (summary.json and runs_sync.csv)
with known end errors: the other estimator's errors the paper's times a factor, plus a
little independent noise. Checked: 1.3x is flagged worse (exit 1) and its ratio printed;
0.8x and the same errors pass (exit 0); a seed missing, a malformed row, a column missing
and too few runs are
refused (exit 2) with the file named.
"""
import json
import os
import re
import subprocess
import sys

import numpy as np

TRUTH = {"delta_rho": 1.1, "E_theta": 0.0174533, "K_rho": 1e-3, "K_theta": 3e-4}


def write(d, errs, runs, of, drop_seed=None, bad_row=False, drop_col=None):
    os.makedirs(d, exist_ok=True)
    params = {n: {"mean": t, "true": t, "accuracy_pct": 1.0, "sigma_ratio": 1.0, "bound_pct": 1.0,
                  "bound_pct_known": 1.0} for n, t in TRUTH.items()}
    cp = {"distance_m": 30.0, "params": params, "pose_rms": {"position_m": 0.004, "orientation_rad": 0.001}}
    s = {"drive": "sync", "runs": runs, "of": of, "path": "circle",
         "cases": [{"init": "small", "checkpoints": [cp]}, {"init": "large", "checkpoints": [cp]}]}
    with open(os.path.join(d, "summary.json"), "w") as f:
        json.dump(s, f)
    cols = [c for c in list(TRUTH) + ["pos_err_m", "heading_err_rad"] if c != drop_col]
    with open(os.path.join(d, "runs_sync.csv"), "w") as f:
        f.write("init,run,seed," + ",".join(cols) + "\n")
        for init in ("small", "large"):
            for r in range(runs):
                if r + 1 == drop_seed:
                    continue
                vals = [TRUTH.get(c, 0.0) + errs[c][r] for c in cols]
                f.write(f"{init},{r},{r + 1}," + ",".join(f"{v:.9g}" for v in vals) + "\n")
        if bad_row:
            f.write("large,99,100,1.1,oops,0,0,0,0\n")


def run(tool, a, b, *flags):
    p = subprocess.run([sys.executable, tool, a, b, *flags], capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def main():
    tool, work = sys.argv[1], sys.argv[2]
    rng = np.random.default_rng(5)
    runs = 60
    scale = {"delta_rho": 0.005, "E_theta": 0.003, "K_rho": 1e-4, "K_theta": 2e-5, "pos_err_m": 0.004,
             "heading_err_rad": 0.001}
    base = {c: v * rng.standard_normal(runs) for c, v in scale.items()}
    fails = []

    def expect(cond, what):
        print(("ok   " if cond else "FAIL ") + what)
        if not cond:
            fails.append(what)

    write(os.path.join(work, "paper"), base, runs, "paper")
    for name, factor, code in (("worse", 1.3, 1), ("better", 0.8, 0), ("same", 1.0, 0)):
        other = {c: factor * e + (0.02 * scale[c] * rng.standard_normal(runs) if factor != 1.0 else 0)
                 for c, e in base.items()}
        write(os.path.join(work, name), other, runs, "ml")
        rc, out, err = run(tool, os.path.join(work, "paper"), os.path.join(work, name), "--no-worse")
        expect(rc == code, f"{name} ({factor}x): exit {rc}, expected {code} {err.strip()}")
        if name == "worse":
            m = re.search(r"from above: E_theta ([0-9.]+)x", out)
            expect("significantly worse than 'paper'" in out and m and 1.25 < float(m.group(1)) < 1.35,
                   "worse: the verdict names E_theta from above at about 1.3x")
        else:
            expect("no worse than 'paper'" in out, f"{name}: the verdict says no worse")
    write(os.path.join(work, "missing"), base, runs, "ml", drop_seed=7)
    rc, out, err = run(tool, os.path.join(work, "paper"), os.path.join(work, "missing"), "--paired")
    expect(rc == 2 and "runs_sync.csv" in err and "other seeds" in err, f"a seed missing: exit {rc}, {err.strip()}")
    write(os.path.join(work, "bad"), base, runs, "ml", bad_row=True)
    rc, out, err = run(tool, os.path.join(work, "paper"), os.path.join(work, "bad"), "--paired")
    expect(rc == 2 and "runs_sync.csv:" in err and "malformed row" in err, f"a malformed row: exit {rc}, {err.strip()}")
    write(os.path.join(work, "nocol"), base, runs, "ml", drop_col="heading_err_rad")
    rc, out, err = run(tool, os.path.join(work, "paper"), os.path.join(work, "nocol"), "--paired")
    expect(rc == 2 and "no column 'heading_err_rad'" in err, f"a column missing: exit {rc}, {err.strip()}")
    few = {c: e[:5] for c, e in base.items()}
    write(os.path.join(work, "few_a"), few, 5, "paper")
    write(os.path.join(work, "few_b"), few, 5, "ml")
    rc, out, err = run(tool, os.path.join(work, "few_a"), os.path.join(work, "few_b"), "--paired")
    expect(rc == 2 and "at least 10" in err, f"5 runs: exit {rc}, {err.strip()}")
    print(f"{len(fails)} failed" if fails else "all checks passed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
