#!/usr/bin/env python3
"""K's accuracy and mean in `odoerr paper`, estimators side by side, against the Cramér-Rao bound.

usage: plot_k_bound.py --run LABEL=DIR [--run LABEL=DIR ...] --out PNG [--title TEXT]
Each DIR is an `odoerr paper --out DIR` directory (summary.json and paper_<drive>.csv with
the _bound_pct columns), of either drive; give each estimator's directory for each drive
(e.g. "paper's OF=out/paper-sync", "ml=out/paper-sync-ml", and the same for diff). All
directories must share one path (circle or eight). Columns: K_rho, K_theta (sync), K_w
(diff), for the drives given; top row the accuracy (std / mean over the runs, %) with the
bound dotted (K's bound_pct: the systematic parameters unknown), bottom row the mean over
the truth. Solid: the start 100x below the truth; dashed: 100x above. Used for
docs/img/nonsystematic-*.png and scripts/paper.sh's out/k-bound.png. A malformed input
exits with a message naming the file (and the line of a bad CSV row).
"""
import argparse
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

PANELS = [("sync", "K_rho", r"$K_\rho$"), ("sync", "K_theta", r"$K_\theta$"), ("diff", "K_w", r"$K_w$")]


def fail(msg):
    sys.exit("plot_k_bound.py: " + msg)


def load(spec):
    if "=" not in spec:
        fail("--run %s: expected LABEL=DIR" % spec)
    label, d = spec.split("=", 1)
    path = os.path.join(d, "summary.json")
    try:
        with open(path) as f:
            summary = json.load(f)
        drive = summary["drive"]
        path_kind = summary.get("path", "circle")
    except (OSError, ValueError, KeyError, TypeError) as e:
        fail("%s: %s" % (path, e))
    if drive not in ("sync", "diff"):
        fail("%s: drive %r is neither sync nor diff" % (path, drive))
    if not isinstance(path_kind, str):
        fail("%s: path %r is not a name" % (path, path_kind))
    fn = os.path.join(d, "paper_%s.csv" % drive)
    out = {}
    try:
        with open(fn, newline="") as f:
            reader = csv.DictReader(f)
            for r in reader:
                try:
                    row = {k: float(v) for k, v in r.items() if k != "init"}
                except (TypeError, ValueError) as e:
                    fail("%s:%d: malformed row (%s)" % (fn, reader.line_num, e))
                if "init" not in r or "distance_m" not in row:
                    fail("%s:%d: malformed row (no init or distance_m)" % (fn, reader.line_num))
                out.setdefault(r["init"], []).append(row)
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        fail("cannot read %s: %s" % (fn, getattr(e, "strerror", None) or e))
    if not out:
        fail("%s has no rows" % fn)
    return label, drive, path_kind, out, fn


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", action="append", required=True, metavar="LABEL=DIR")
    ap.add_argument("--out", required=True)
    ap.add_argument("--title", default=None)
    a = ap.parse_args()
    runs = [load(s) for s in a.run]
    paths = {r[2] for r in runs}
    if len(paths) != 1:
        fail("the directories differ in path: %s" % ", ".join(sorted(paths)))
    labels = []
    for r in runs:
        if r[0] not in labels:
            labels.append(r[0])
    colors = {lab: "C%d" % i for i, lab in enumerate(labels)}
    drives = {r[1] for r in runs}
    panels = [p for p in PANELS if p[0] in drives]  # the drives given only
    fig, axes = plt.subplots(2, len(panels), figsize=(4.7 * len(panels), 7.5), dpi=100, sharex=True, squeeze=False)
    for col, (drive, name, sym) in enumerate(panels):
        acc, mean = axes[0][col], axes[1][col]
        bound_drawn = False
        for label, rdrive, _, data, fn in runs:
            if rdrive != drive:
                continue
            for init, ls, start in (("small", "-", "below"), ("large", "--", "above")):
                rows = [x for x in data.get(init, []) if x["distance_m"] > 0]
                if not rows:
                    fail("%s: no rows for the start from %s" % (fn, start))
                for suffix in ("_accuracy_pct", "_bound_pct", "_mean", "_true"):
                    if name + suffix not in rows[0]:
                        fail("%s: no %s%s column" % (fn, name, suffix))
                if any(not x[name + "_true"] > 0 for x in rows):
                    fail("%s: %s_true is not positive" % (fn, name))
                dist = [x["distance_m"] for x in rows]
                acc.plot(dist, [x[name + "_accuracy_pct"] for x in rows], color=colors[label], ls=ls, lw=1.2,
                         label="%s, from %s" % (label, start))
                mean.plot(dist, [x[name + "_mean"] / x[name + "_true"] for x in rows], color=colors[label], ls=ls,
                          lw=1.2, label="%s, from %s" % (label, start))
                if not bound_drawn:
                    acc.plot(dist, [x[name + "_bound_pct"] for x in rows], color="k", ls=":", lw=1.5,
                             label="Cramér-Rao bound")
                    bound_drawn = True
        acc.set_ylim(0, 50)
        acc.set_title("accuracy of %s (%s drive)" % (sym, drive))
        acc.set_ylabel("std / mean over runs [%]")
        mean.set_yscale("log")
        mean.set_ylim(1e-4, 20)
        mean.axhline(1.0, color="k", lw=0.8)
        mean.set_title("mean of %s / truth (%s drive)" % (sym, drive))
        mean.set_xlabel("travelled distance [m]")
        for ax in (acc, mean):
            ax.set_xlim(0, 30)
            ax.grid(True, alpha=0.3)
        acc.legend(fontsize=7)
    fig.suptitle(a.title or "K against its bound, %s" % paths.pop())
    fig.tight_layout()
    fig.savefig(a.out)
    print("wrote " + a.out)


if __name__ == "__main__":
    main()
