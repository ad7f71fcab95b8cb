#!/usr/bin/env python3
"""The non-systematic parameters' accuracy in `odoerr paper` against their Cramér-Rao bound.

usage: plot_k_bound.py --sync DIR --diff DIR --out PNG
DIR is an `odoerr paper --out DIR` directory (its paper_<drive>.csv, with the
_bound_pct columns). One panel per parameter: accuracy (std/mean over the runs, %) from
both starts, and the bound (dotted). Used for docs/img/nonsystematic-bound.png.
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def load(path):
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        sys.exit("plot_k_bound.py: cannot read %s: %s" % (path, e.strerror or e))
    if not rows:
        sys.exit("plot_k_bound.py: %s has no rows" % path)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sync", required=True)
    ap.add_argument("--diff", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    panels = [("sync", "K_rho", r"$K_\rho$"), ("sync", "K_theta", r"$K_\theta$"), ("diff", "K_w", r"$K_w$")]
    data = {"sync": load(os.path.join(a.sync, "paper_sync.csv")), "diff": load(os.path.join(a.diff, "paper_diff.csv"))}
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), dpi=100)
    for ax, (drive, name, sym) in zip(axes, panels):
        rows = data[drive]
        if name + "_bound_pct" not in rows[0]:
            sys.exit("plot_k_bound.py: %s has no %s_bound_pct column" % (drive, name))
        for init, label, color in (("small", "paper's OF, start 100x below", "C0"),
                                   ("large", "paper's OF, start 100x above", "C1")):
            r = [x for x in rows if x["init"] == init]
            ax.plot([float(x["distance_m"]) for x in r], [float(x[name + "_accuracy_pct"]) for x in r],
                    color=color, lw=1.2, label=label)
        r = [x for x in rows if x["init"] == "small"]
        ax.plot([float(x["distance_m"]) for x in r], [float(x[name + "_bound_pct"]) for x in r],
                color="k", ls=":", lw=1.5, label="Cramér-Rao bound")
        ax.set_ylim(0, 50)
        ax.set_xlim(0, 30)
        ax.set_title("accuracy of %s (%s drive)" % (sym, drive))
        ax.set_xlabel("travelled distance [m]")
        ax.set_ylabel("std / mean over runs [%]")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out)
    print("wrote " + a.out)


if __name__ == "__main__":
    main()
