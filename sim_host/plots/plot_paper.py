#!/usr/bin/python3
"""Plot the Martinelli & Siegwart Section 5 figures from paper_sync.csv.

Usage: /usr/bin/python3 plot_paper.py --csv DIR/paper_sync.csv --drive sync|diff
                                      --out DIR [--runs N]

Writes DIR/fig1_sync.png or DIR/fig2_diff.png (8 panels laid out as the
paper's Fig. 1 / Fig. 2) and DIR/pose_<drive>.png (pose RMS error vs distance).
Needs only numpy and matplotlib (Agg backend); bad input gives a one-line error.
"""
import argparse
import csv
import math
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

# Per parameter: CSV name -> (mathtext label, unit label, SI-to-paper scale).
# The paper shows lengths in cm and angles in rad.
PARAMS = {
    "delta_rho": (r"\delta_\rho", "", 1.0),
    "E_theta": (r"E_\theta", "rad/cm", 0.01),
    "K_rho": (r"K_\rho", "cm", 100.0),
    "K_theta": (r"K_\theta", "rad$^2$/cm", 0.01),
    "delta_R": (r"\delta_R", "", 1.0),
    "delta_L": (r"\delta_L", "", 1.0),
    "delta_d": (r"\delta_d", "", 1.0),
    "K_w": (r"K_w", "cm", 100.0),
}
# Panel order (a)..(h), row-major on a 4x2 grid: (kind, parameter).
LAYOUT = {
    "sync": [("mean", "delta_rho"), ("mean", "E_theta"),
             ("acc", "delta_rho"), ("acc", "E_theta"),
             ("mean", "K_rho"), ("mean", "K_theta"),
             ("acc", "K_rho"), ("acc", "K_theta")],
    "diff": [("mean", "delta_R"), ("mean", "delta_L"),
             ("mean", "delta_d"), ("acc", "delta_R"),
             ("acc", "delta_L"), ("acc", "delta_d"),
             ("mean", "K_w"), ("acc", "K_w")],
}
FIG_NAME = {"sync": ("fig1_sync.png", "Fig. 1", "synchronous drive"),
            "diff": ("fig2_diff.png", "Fig. 2", "differential drive")}
POSE_COLS = ["pos_rms_m", "heading_rms_rad",
             "pos_sigma_mean_m", "heading_sigma_mean_rad"]
STARTS = [("small", "start 100x below", "tab:blue"),
          ("large", "start 100x above", "tab:orange")]


def die(msg):
    """Print a one-line error and exit non-zero (no traceback)."""
    print("plot_paper.py: error: " + msg, file=sys.stderr)
    sys.exit(1)


def load_csv(path, needed):
    """Return {init: {column: np.array}} for the needed numeric columns."""
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except OSError as e:
        die("cannot read %s: %s" % (path, e.strerror or e))
    except (UnicodeDecodeError, csv.Error) as e:
        die("%s is not a readable text CSV: %s" % (path, e))
    rows = [(n, r) for n, r in enumerate(rows, 1) if any(c.strip() for c in r)]
    if not rows:
        die("%s is empty" % path)
    header = [c.strip() for c in rows[0][1]]
    missing = [c for c in ["init", "distance_m"] + needed if c not in header]
    if missing:
        hint = " (wrong --drive?)" if len(missing) >= len(needed) // 2 else ""
        die("%s: line %d: missing column(s): %s%s"
            % (path, rows[0][0], ", ".join(missing), hint))
    if len(rows) < 2:
        die("%s has a header but no data rows" % path)
    idx = {c: header.index(c) for c in ["init", "distance_m"] + needed}
    data = {}
    for lineno, r in rows[1:]:
        if len(r) != len(header):
            die("%s: line %d: expected %d fields, found %d"
                % (path, lineno, len(header), len(r)))
        init = r[idx["init"]].strip()
        if init not in ("small", "large"):
            die("%s: line %d: init must be 'small' or 'large', got '%s'"
                % (path, lineno, init))
        vals = data.setdefault(init, {c: [] for c in idx if c != "init"})
        for c, v in vals.items():
            try:
                v.append(float(r[idx[c]]))
            except ValueError:
                die("%s: line %d: column %s: non-numeric value '%s'"
                    % (path, lineno, c, r[idx[c]].strip()))
    out = {}
    for init, cols in data.items():
        arr = {c: np.asarray(v) for c, v in cols.items()}
        order = np.argsort(arr["distance_m"], kind="stable")
        out[init] = {c: a[order] for c, a in arr.items()}
    return out


def plot_mean(ax, data, name):
    """Mean estimate of one parameter for both starts, truth dashed."""
    sym, unit, scale = PARAMS[name]
    log = name.startswith("K_")
    truth = None
    for init, label, color in STARTS:
        if init not in data:
            continue
        d = data[init]
        y = d[name + "_mean"] * scale
        if log:  # log axis: hide non-positive values instead of failing
            y = np.where(y > 0, y, np.nan)
        ax.plot(d["distance_m"], y, color=color, lw=1.2, label=label)
        t = d[name + "_true"][np.isfinite(d[name + "_true"])]
        if t.size:  # the truth is constant; the median guards against noise
            truth = float(np.median(t)) * scale
    if truth is not None:
        ax.axhline(truth, color="k", ls="--", lw=1.0, label="true value")
    if log:
        ax.set_yscale("log")
    else:
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4),
                            useOffset=False)
    ax.set_ylabel("$%s$" % sym + (" [%s]" % unit if unit else ""))
    return "mean $%s$" % sym


def plot_acc(ax, data, name):
    """Accuracy (relative spread over runs, %) for both starts."""
    sym = PARAMS[name][0]
    late = []
    for init, label, color in STARTS:
        if init not in data:
            continue
        d = data[init]
        y = d[name + "_accuracy_pct"]
        ax.plot(d["distance_m"], y, color=color, lw=1.2, label=label)
        late.append(y[d["distance_m"] >= 1.0])
    # The Cramér-Rao bound on the experiment's nominal drive (the same for both starts).
    for init in ("small", "large"):
        if init in data and name + "_bound_pct" in data[init]:
            d = data[init]
            ax.plot(d["distance_m"], d[name + "_bound_pct"], color="k", ls=":",
                    lw=1.4, label="Cramér-Rao bound")
            b = d[name + "_bound_pct"]
            late.append(b[d["distance_m"] >= 1.0])
            break
    # Clip to the 99th percentile after the first metre so the early
    # transient does not flatten the rest of the curve.
    late = np.concatenate(late) if late else np.array([])
    late = late[np.isfinite(late)]
    if late.size:
        top = float(np.percentile(late, 99))
        if top > 0:
            ax.set_ylim(0.0, 1.1 * top)
    ax.set_ylabel("accuracy [%]")
    return "accuracy of $%s$ [%%]" % sym


def runs_text(runs):
    return "" if runs is None else " (%d runs)" % runs


def save(fig, path):
    try:
        fig.savefig(path)
    except OSError as e:
        die("cannot write %s: %s" % (path, e.strerror or e))
    plt.close(fig)
    print("wrote " + path)


def param_figure(data, drive, out_dir, runs):
    fname, tag, title = FIG_NAME[drive]
    fig, axes = plt.subplots(4, 2, figsize=(10, 13), dpi=100)
    xmax = max(float(np.nanmax(d["distance_m"])) for d in data.values())
    for i, (ax, (kind, name)) in enumerate(zip(axes.flat, LAYOUT[drive])):
        text = (plot_mean if kind == "mean" else plot_acc)(ax, data, name)
        ax.set_title("(%s) %s" % ("abcdefgh"[i], text), fontsize=11)
        ax.set_xlabel("travelled distance [m]")
        ax.set_xlim(0.0, xmax if xmax > 0 else 1.0)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    fig.suptitle("%s: %s parameter estimates%s"
                 % (tag, title, runs_text(runs)), fontsize=13)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    save(fig, os.path.join(out_dir, fname))


def pose_figure(data, drive, out_dir, runs):
    fig, axes = plt.subplots(2, 1, figsize=(9, 7), dpi=100, sharex=True)
    panels = [("pos_rms_m", "pos_sigma_mean_m", 100.0,
               "position error [cm]"),
              ("heading_rms_rad", "heading_sigma_mean_rad", 180.0 / math.pi,
               "heading error [deg]")]
    for ax, (rms, sig, scale, ylabel) in zip(axes, panels):
        for init, label, color in STARTS:
            if init not in data:
                continue
            d = data[init]
            ax.plot(d["distance_m"], d[rms] * scale, color=color, lw=1.2,
                    label=label + ": RMS error")
            ax.plot(d["distance_m"], d[sig] * scale, color=color, lw=1.0,
                    ls="--", label=label + ": mean filter $\\sigma$")
        ax.set_ylabel(ylabel)
        ax.set_ylim(bottom=0)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    axes[-1].set_xlabel("travelled distance [m]")
    fig.suptitle("%s: pose error vs distance%s"
                 % (FIG_NAME[drive][2], runs_text(runs)), fontsize=13)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    save(fig, os.path.join(out_dir, "pose_%s.png" % drive))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--csv", required=True, help="paper_sync.csv from the C++ tool")
    ap.add_argument("--drive", required=True, choices=["sync", "diff"])
    ap.add_argument("--out", required=True, help="output directory")
    ap.add_argument("--runs", type=int, default=None,
                    help="number of Monte-Carlo runs (for the title only)")
    args = ap.parse_args()

    names = sorted({n for _, n in LAYOUT[args.drive]})
    needed = [n + s for n in names for s in ("_mean", "_accuracy_pct", "_true", "_bound_pct")]
    data = load_csv(args.csv, needed + POSE_COLS)
    for init, label, _ in STARTS:
        if init not in data:
            print("plot_paper.py: warning: %s has no init=%s rows; plotting "
                  "only the other start" % (args.csv, init), file=sys.stderr)
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        die("output path %s exists and is not a directory" % args.out)
    try:
        os.makedirs(args.out, exist_ok=True)
    except OSError as e:
        die("cannot create output directory %s: %s" % (args.out, e.strerror or e))
    param_figure(data, args.drive, args.out, args.runs)
    pose_figure(data, args.drive, args.out, args.runs)


if __name__ == "__main__":
    main()
