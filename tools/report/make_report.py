#!/usr/bin/python3
"""Turn what `odoerr diagnose` wrote into DIR into one self-contained page, DIR/report.html.

usage: make_report.py DIR [--out FILE] [--max-points N]

Reads DIR/diagnose.json, scans.csv, beams.csv, trajectory.csv and, when the held-out check
ran, heldout_before.csv / heldout_after.csv. Writes one HTML file with inline CSS and every
plot embedded as a base64 PNG: no JavaScript, no external links, readable offline.

Exit status: 0 written; 1 an input file is missing or malformed (one line on stderr that
names the file, and the line or key when there is one); 2 bad command line.
Needs only numpy and matplotlib (Agg backend).
"""
import argparse
import base64
import csv
import html
import io
import json
import math
import os
import sys
import time

import numpy as np

PROG = "make_report"

BIN_ORDER = ["turn_rate", "speed", "v_omega", "heading", "since_reversal", "wheel_angle",
             "map_cell"]
BIN_LABEL = {
    "turn_rate": ("turn rate", "rad/s"),
    "speed": ("speed", "m/s"),
    "v_omega": ("v·ω (centripetal acc.)", "m/s²"),
    "heading": ("heading", "rad"),
    "since_reversal": ("travel since last reversal", "m"),
    "wheel_angle": ("wheel angle", "rad"),
    "map_cell": ("map cell (3×3 grid, 0 = lower left)", "cell"),
}
C_EST, C_TRUTH, C_SIG, C_NONSIG, C_BAD, C_OK = "#1f5fa8", "#e07b00", "#c0392b", "#9aa5b1", "#c0392b", "#2e8b57"


class InputError(Exception):
    """An input file is missing or malformed; the message names the file."""


# ----------------------------------------------------------------------------------------
# Reading and checking the inputs
# ----------------------------------------------------------------------------------------

def read_json(path):
    if not os.path.isfile(path):
        raise InputError(f"{path}: file not found (odoerr diagnose writes it)")
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except json.JSONDecodeError as e:
        raise InputError(f"{path}: not valid JSON: {e.msg} (line {e.lineno}, column {e.colno})")
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{path}: cannot read: {e}")


def read_csv(path, columns, str_columns=()):
    """Columns of a CSV file as numpy arrays (float; '' -> nan), str_columns as str arrays."""
    if not os.path.isfile(path):
        raise InputError(f"{path}: file not found (odoerr diagnose writes it)")
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = [r for r in csv.reader(f) if r]
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise InputError(f"{path}: cannot read: {e}")
    if not rows:
        raise InputError(f"{path}: empty file; expected the header {','.join(columns)}")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in columns if c not in header]
    if missing:
        raise InputError(f"{path}: header lacks column(s) {', '.join(missing)} "
                         f"(header is: {','.join(header)})")
    body = rows[1:]
    width = len(header)
    if any(len(r) != width for r in body):
        for i, r in enumerate(body):
            if len(r) != width:
                raise InputError(f"{path}:{i + 2}: {len(r)} fields where the header has {width}")
    cols = list(zip(*body)) if body else [()] * width
    out = {}
    for c in columns:
        raw = cols[header.index(c)]
        if c in str_columns:
            out[c] = np.array([s.strip() for s in raw], dtype=object)
            continue
        try:
            out[c] = np.array(raw, dtype=float) if raw else np.zeros(0)
        except ValueError:
            vals = np.empty(len(raw))
            for i, s in enumerate(raw):
                s = s.strip()
                if s == "":
                    vals[i] = np.nan
                    continue
                try:
                    vals[i] = float(s)
                except ValueError:
                    raise InputError(f"{path}:{i + 2}: column '{c}': '{s[:40]}' is not a number")
            out[c] = vals
    return out


def is_num(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def num(obj, key, where, path):
    """obj[key] as float, None when missing/null; a non-number is an error."""
    if not isinstance(obj, dict) or key not in obj or obj[key] is None:
        return None
    v = obj[key]
    if not is_num(v):
        raise InputError(f"{path}: '{where}.{key}' should be a number, found {json.dumps(v)[:60]}")
    return float(v)


def expect(cond, path, msg):
    if not cond:
        raise InputError(f"{path}: {msg}")


def check_diagnose(d, path):
    """Structural checks; values that are merely missing are shown as '—' later."""
    expect(isinstance(d, dict), path, "top level should be a JSON object")
    for k in ("log", "drive", "verdict", "tests", "ranking"):
        expect(k in d, path, f"missing key '{k}'")
    for k in ("log", "drive", "verdict"):
        expect(isinstance(d[k], str), path, f"'{k}' should be a string")
    expect(isinstance(d["tests"], dict), path, "'tests' should be an object")
    expect(isinstance(d["ranking"], list), path, "'ranking' should be a list")
    for i, r in enumerate(d["ranking"]):
        expect(isinstance(r, dict) and isinstance(r.get("effect"), str), path,
               f"'ranking[{i}]' should be an object with a string 'effect'")
        for k in ("delta_loglik", "bic_gain", "p_value", "informed_params"):
            num(r, k, f"ranking[{i}]", path)
        for k in ("estimate", "sigma"):
            v = r.get(k)
            expect(v is None or is_num(v) or (isinstance(v, list) and all(is_num(x) or x is None for x in v)),
                   path, f"'ranking[{i}].{k}' should be a list of numbers")
        cw = r.get("confused_with")
        expect(cw is None or (isinstance(cw, list) and all(isinstance(x, str) for x in cw)),
               path, f"'ranking[{i}].confused_with' should be a list of names")
    t = d["tests"]
    for k, v in t.items():
        if k == "nis_band":
            expect(v is None or (isinstance(v, list) and len(v) == 2 and all(is_num(x) for x in v)),
                   path, "'tests.nis_band' should be [lo, hi]")
        elif k == "ljung_box":
            expect(v is None or isinstance(v, dict), path, "'tests.ljung_box' should be an object")
            for kk in ("lags", "q", "p_value"):
                num(v, kk, "tests.ljung_box", path)
    h = d.get("heldout")
    if h is not None:
        expect(isinstance(h, dict), path, "'heldout' should be null or an object")
        for k in ("before", "after"):
            expect(isinstance(h.get(k), dict), path, f"'heldout.{k}' should be an object")
            for kk in h[k]:
                num(h[k], kk, f"heldout.{k}", path)
        bl = h.get("blocks") or []
        expect(isinstance(bl, list) and all(isinstance(b, list) and len(b) == 2 and all(is_num(x) for x in b)
                                            for b in bl), path, "'heldout.blocks' should be [[t0,t1],...]")
    e = d.get("excitation")
    if e is not None:
        expect(isinstance(e, dict), path, "'excitation' should be an object")
        ps = e.get("parameters") or []
        expect(isinstance(ps, list), path, "'excitation.parameters' should be a list")
        for i, p in enumerate(ps):
            expect(isinstance(p, dict), path, f"'excitation.parameters[{i}]' should be an object")
            for k in ("sigma_achievable", "prior_sigma"):
                num(p, k, f"excitation.parameters[{i}]", path)
        w = e.get("warnings") or []
        expect(isinstance(w, list), path, "'excitation.warnings' should be a list of sentences")
    b = d.get("bins")
    if b is not None:
        expect(isinstance(b, dict), path, "'bins' should be an object")
        for name, lst in b.items():
            expect(lst is None or isinstance(lst, list), path, f"'bins.{name}' should be a list")
            for i, e in enumerate(lst or []):
                expect(isinstance(e, dict), path, f"'bins.{name}[{i}]' should be an object")
                for k in ("lo", "hi", "count", "nis_mean", "mean_norm_innovation"):
                    num(e, k, f"bins.{name}[{i}]", path)
    c = d.get("cusum")
    if c is not None:
        expect(isinstance(c, dict), path, "'cusum' should be an object")
        al = c.get("alarms") or []
        expect(isinstance(al, list), path, "'cusum.alarms' should be a list")
        for i, a in enumerate(al):
            expect(isinstance(a, dict), path, f"'cusum.alarms[{i}]' should be an object")
            for k in ("t", "x", "y"):
                num(a, k, f"cusum.alarms[{i}]", path)
    m = d.get("map")
    if m is not None:
        expect(isinstance(m, dict), path, "'map' should be an object")
        walls = m.get("walls") or []
        expect(isinstance(walls, list) and all(isinstance(w, list) and len(w) == 4 and all(is_num(x) for x in w)
                                               for w in walls), path,
               "'map.walls' should be a list of [x1, y1, x2, y2]")


def load_inputs(d):
    if not os.path.isdir(d):
        raise InputError(f"{d}: not a directory (expected the output directory of odoerr diagnose)")
    p = lambda name: os.path.join(d, name)
    diag = read_json(p("diagnose.json"))
    check_diagnose(diag, p("diagnose.json"))
    scans = read_csv(p("scans.csv"), ["t", "dist_m", "x", "y", "theta", "dof", "nis_sum", "band_lo",
                                      "band_hi", "along_m", "cross_m", "heading_rad"])
    beams = read_csv(p("beams.csv"), ["t", "beam", "hit_x", "hit_y", "innovation_m", "nis", "status"],
                     str_columns=("status",))
    traj = read_csv(p("trajectory.csv"), ["t", "x", "y", "theta", "truth_x", "truth_y", "truth_theta"])
    held = {}
    if diag.get("heldout") is not None:
        for k in ("before", "after"):
            f = p(f"heldout_{k}.csv")
            if os.path.isfile(f):
                held[k] = read_csv(f, ["t", "nis", "pose_err_m"])
    return diag, scans, beams, traj, held


# ----------------------------------------------------------------------------------------
# Formatting helpers
# ----------------------------------------------------------------------------------------

E = html.escape


def fnum(v, sig=3, unit=""):
    """v with sig significant digits (integers as they are); '—' for null / nan."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "—"
    v = float(v)
    a = abs(v)
    if v == int(v) and a < 1e15 and (a >= 1 or v == 0):
        s = f"{int(v)}"
    elif a >= 1e6 or a < 1e-4:
        s = f"{v:.{max(sig - 1, 1)}e}"
    else:
        s = f"{v:.{max(0, sig - 1 - int(math.floor(math.log10(a))))}f}"
        if "." in s:
            s = s.rstrip("0").rstrip(".")
    return s + (f" {unit}" if unit else "")


def pm(e, s):
    """'estimate ± sigma', sigma to 2 significant digits and the estimate to the same decimal."""
    if not is_num(e):
        return "—"
    if not is_num(s) or not math.isfinite(s) or s <= 0:
        return f"{fnum(e, 3)} ± {fnum(s, 2)}"
    if s >= 1e6 or s < 1e-6 or abs(e) >= 1e6:
        return f"{e:.2e} ± {s:.1e}"
    dec = max(0, 1 - int(math.floor(math.log10(s))))
    return f"{e:.{dec}f} ± {s:.{dec}f}"


def fp(v):
    """A p-value."""
    if v is None or not math.isfinite(v):
        return "—"
    if v < 1e-4:
        return "&lt; 0.0001" if v > 0 else "&lt; 1e-300"
    return f"{v:.4f}".rstrip("0").rstrip(".") if v < 0.1 else f"{v:.2f}"


def peq(v):
    """'= 0.03' or '< 0.0001'."""
    s = fp(v)
    return s if s.startswith("&lt;") else "= " + s


def fpct(v):
    return "—" if v is None else f"{100 * v:.1f} %"


def fedge(v):
    if v is None or not math.isfinite(v) or abs(v) >= 1e6:
        return "∞" if (v is None or v > 0) else "−∞"
    return f"{v:.3g}".replace("-", "−")


# ----------------------------------------------------------------------------------------
# Plots
# ----------------------------------------------------------------------------------------

def setup_matplotlib():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    plt.rcParams.update({
        "font.size": 9.5, "axes.titlesize": 10, "axes.labelsize": 9.5, "legend.fontsize": 8.5,
        "xtick.labelsize": 8.5, "ytick.labelsize": 8.5, "axes.grid": True, "grid.alpha": 0.3,
        "axes.spines.top": False, "axes.spines.right": False, "figure.dpi": 100,
        "savefig.dpi": 100, "path.simplify": True, "agg.path.chunksize": 10000,
    })
    return plt


def png_uri(plt, fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", facecolor="white")
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def draw_walls(ax, walls, **kw):
    if not walls:
        return
    from matplotlib.collections import LineCollection
    segs = [[(w[0], w[1]), (w[2], w[3])] for w in walls]
    style = dict(colors="#222222", linewidths=2.2, zorder=1)
    style.update(kw)
    ax.add_collection(LineCollection(segs, **style))


def map_limits(ax, walls, *xy):
    xs, ys = [], []
    for w in walls:
        xs += [w[0], w[2]]
        ys += [w[1], w[3]]
    for x, y in xy:
        f = np.isfinite(x) & np.isfinite(y)
        if f.any():
            xs += [float(np.min(x[f])), float(np.max(x[f]))]
            ys += [float(np.min(y[f])), float(np.max(y[f]))]
    if xs:
        pad = 0.03 * max(max(xs) - min(xs), max(ys) - min(ys), 1e-3)
        ax.set_xlim(min(xs) - pad, max(xs) + pad)
        ax.set_ylim(min(ys) - pad, max(ys) + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def fig_trajectory(plt, traj, walls, alarms, has_truth):
    fig, ax = plt.subplots(figsize=(8.6, 6.4), layout="constrained")
    draw_walls(ax, walls)
    x, y = traj["x"], traj["y"]
    if has_truth:
        ax.plot(traj["truth_x"], traj["truth_y"], color=C_TRUTH, lw=1.2, ls="--", label="truth", zorder=2)
    ax.plot(x, y, color=C_EST, lw=1.1, label="estimated path", zorder=3)
    f = np.isfinite(x) & np.isfinite(y)
    if f.any():
        i0, i1 = np.argmax(f), len(f) - 1 - np.argmax(f[::-1])
        ax.plot(x[i1], y[i1], "s", color="#333333", ms=11, label="end", zorder=5)
        ax.plot(x[i0], y[i0], "o", color=C_OK, ms=7, label="start", zorder=5.5)
    for k, (sym, lab, col) in enumerate((("^", "CUSUM alarm: NIS rising", C_BAD),
                                         ("v", "CUSUM alarm: NIS falling", "#7b3fa0"))):
        sel = [a for a in alarms if (a.get("direction") == "down") == (k == 1)]
        if sel:
            ax.scatter([a["x"] for a in sel], [a["y"] for a in sel], marker=sym, s=150, color=col,
                       edgecolor="white", linewidth=1.2, zorder=6, label=lab)
    for i, a in enumerate(alarms):
        ax.annotate(f"A{i + 1}", (a["x"], a["y"]), xytext=(7, 7), textcoords="offset points",
                    fontsize=9, fontweight="bold", color="#222222", zorder=7)
    map_limits(ax, walls, (x, y))
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return fig


def path_distance(x, y):
    d = np.hypot(np.diff(x), np.diff(y))
    d[~np.isfinite(d)] = 0.0
    return np.concatenate([[0.0], np.cumsum(d)])


def fig_truth_error(plt, traj):
    dist = path_distance(traj["x"], traj["y"])
    ep = np.hypot(traj["x"] - traj["truth_x"], traj["y"] - traj["truth_y"])
    eh = np.angle(np.exp(1j * (traj["theta"] - traj["truth_theta"])))
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 4.2), sharex=True, layout="constrained")
    a1.plot(dist, 100 * ep, color=C_EST, lw=1)
    a1.set_ylabel("position error (cm)")
    a1.set_ylim(bottom=0)
    a2.plot(dist, np.degrees(eh), color=C_EST, lw=1)
    a2.axhline(0, color="#444", lw=0.8)
    a2.set_ylabel("heading error (°)")
    a2.set_xlabel("distance travelled (m)")
    return fig


def rolling_mean(v, w):
    ok = np.isfinite(v)
    vv = np.where(ok, v, 0.0)
    k = np.ones(w)
    s = np.convolve(vv, k, "same")
    n = np.convolve(ok.astype(float), k, "same")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > w / 3, s / np.maximum(n, 1), np.nan)


def fig_nis(plt, scans, alarms):
    dist, dof = scans["dist_m"], scans["dof"]
    with np.errstate(invalid="ignore", divide="ignore"):
        good = dof > 0
        nis = np.where(good, scans["nis_sum"] / np.where(good, dof, 1), np.nan)
        lo = np.where(good, scans["band_lo"] / np.where(good, dof, 1), np.nan)
        hi = np.where(good, scans["band_hi"] / np.where(good, dof, 1), np.nan)
    out = (nis < lo) | (nis > hi)
    fig, axs = plt.subplots(3, 1, figsize=(10, 7.2), sharex=True, layout="constrained",
                            gridspec_kw={"height_ratios": [2.2, 1, 1]})
    ax = axs[0]
    ax.fill_between(dist, lo, hi, step="mid", color="#7fbf7f", alpha=0.35, lw=0,
                    label="95 % band for the scan's beam count")
    ax.axhline(1.0, color="#2d6a2d", lw=0.9)
    ax.scatter(dist[~out], nis[~out], s=6, color=C_EST, alpha=0.6, lw=0, label="scan inside band")
    ax.scatter(dist[out], nis[out], s=9, color=C_BAD, alpha=0.8, lw=0, label="scan outside band")
    n_win = max(5, min(51, len(dist) // 40 * 2 + 1))
    ax.plot(dist, rolling_mean(nis, n_win), color="black", lw=1.4, label=f"running mean ({n_win} scans)")
    fin = nis[np.isfinite(nis)]
    if fin.size:
        top = max(np.nanpercentile(fin, 99.5), np.nanmax(hi) if np.isfinite(hi).any() else 1.0, 1.5) * 1.1
        ax.set_ylim(0, top)
        n_clip = int((fin > top).sum())
        if n_clip:
            ax.text(0.995, 0.98, f"{n_clip} scan(s) above {top:.2g} not shown", transform=ax.transAxes,
                    ha="right", va="top", fontsize=8, color=C_BAD)
    ax.set_ylabel("NIS per beam (nis_sum / dof)")
    if alarms and len(dist) > 1:
        t = scans["t"]
        for i, a in enumerate(alarms):
            da = float(np.interp(a["t"], t, dist))
            for axx in axs:
                axx.axvline(da, color="#7b3fa0", lw=0.9, ls=":", zorder=0)
            ax.text(da, ax.get_ylim()[1], f" A{i + 1}", color="#7b3fa0", fontsize=8.5, va="top")
    ax.legend(loc="upper left", ncol=4, frameon=True, framealpha=0.85)
    a2 = axs[1]
    a2.plot(dist, 1000 * scans["along_m"], lw=0.8, color="#1f77b4", label="along track")
    a2.plot(dist, 1000 * scans["cross_m"], lw=0.8, color="#d62728", label="cross track (left +)")
    a2.axhline(0, color="#444", lw=0.7)
    a2.set_ylabel("position\ncorrection (mm)")
    a2.legend(loc="upper left", ncol=2, frameon=True, framealpha=0.85)
    a3 = axs[2]
    a3.plot(dist, 1000 * scans["heading_rad"], lw=0.8, color="#2e8b57")
    a3.axhline(0, color="#444", lw=0.7)
    a3.set_ylabel("heading\ncorrection (mrad)")
    a3.set_xlabel("distance travelled (m)")
    return fig, int(out.sum()), int(good.sum())


def fig_residual_map(plt, beams, walls, traj, max_points, rng):
    """Left: a sample of individual beams; right: the mean innovation per small map cell."""
    inn = beams["innovation_m"]
    hx, hy = beams["hit_x"], beams["hit_y"]
    fin = np.isfinite(inn) & np.isfinite(hx) & np.isfinite(hy)
    used = fin & (beams["status"] == "used")
    other = fin & ~used
    iu = np.nonzero(used)[0]
    if iu.size > max_points:
        iu = rng.choice(iu, max_points, replace=False)
    else:
        iu = rng.permutation(iu)                 # random drawing order: no sign hides the other
    io_ = np.nonzero(other)[0]
    if io_.size > max_points // 4:
        io_ = rng.choice(io_, max_points // 4, replace=False)
    vmax = max(float(np.percentile(np.abs(inn[used]), 98)), 1e-4) * 1000

    # Mean innovation per square cell of about 1/80 of the map's extent.
    ux, uy, ui = hx[used], hy[used], inn[used]
    x0, y0 = float(ux.min()), float(uy.min())
    cell = max(float(ux.max()) - x0, float(uy.max()) - y0, 1e-3) / 80.0
    cx = ((ux - x0) / cell).astype(np.int64)
    cy = ((uy - y0) / cell).astype(np.int64)
    key = cx * (int(cy.max()) + 1) + cy
    uk, inv = np.unique(key, return_inverse=True)
    cnt = np.bincount(inv)
    mean = np.bincount(inv, weights=ui) / cnt
    keep = cnt >= 3
    kx = x0 + (uk // (int(cy.max()) + 1) + 0.5) * cell
    ky = y0 + (uk % (int(cy.max()) + 1) + 0.5) * cell
    cvmax = max(float(np.percentile(np.abs(mean[keep]), 98)) if keep.any() else 0.0, 1e-4) * 1000

    fig, axs = plt.subplots(1, 2, figsize=(13.5, 6.0), layout="constrained")
    for ax in axs:
        ax.plot(traj["x"], traj["y"], color="#aaaaaa", lw=0.6, zorder=1)
        draw_walls(ax, walls, colors="#555555", linewidths=0.8, zorder=2)
    ax = axs[0]
    if io_.size:
        ax.scatter(hx[io_], hy[io_], s=5, marker="x", color="#9aa5b1", lw=0.5, zorder=3,
                   label="gated / not used")
    sc = ax.scatter(hx[iu], hy[iu], c=1000 * inn[iu], cmap="RdBu_r", vmin=-vmax, vmax=vmax,
                    s=5, lw=0, zorder=4)
    cb = fig.colorbar(sc, ax=ax, extend="both", shrink=0.85, pad=0.01)
    cb.set_label("innovation (mm)")
    ax.set_title("every used beam" + (f" (random {iu.size} of {int(used.sum())})" if iu.size < used.sum() else ""))
    map_limits(ax, walls, (hx[fin], hy[fin]))
    if io_.size:
        ax.legend(loc="lower left", bbox_to_anchor=(0.0, 1.04), frameon=False, markerscale=2)
    ax = axs[1]
    # Marker area in points^2 that roughly fills a cell at this figure size.
    sc2 = ax.scatter(kx[keep], ky[keep], c=1000 * mean[keep], cmap="RdBu_r", vmin=-cvmax, vmax=cvmax,
                     s=16, marker="s", lw=0, zorder=4)
    cb2 = fig.colorbar(sc2, ax=ax, extend="both", shrink=0.85, pad=0.01)
    cb2.set_label("mean innovation in the cell (mm)")
    ax.set_title(f"mean per {100 * cell:.2g} cm cell (cells with ≥ 3 beams)")
    map_limits(ax, walls, (hx[fin], hy[fin]))
    return fig, int(used.sum()), int(iu.size), vmax, cvmax


def fig_beams(plt, beams):
    b = beams["beam"]
    fin = np.isfinite(b) & (b >= 0)
    bi = b[fin].astype(int)
    nb = int(bi.max()) + 1
    used = (beams["status"][fin] == "used") & np.isfinite(beams["innovation_m"][fin])
    inn = beams["innovation_m"][fin]
    nis = beams["nis"][fin]
    n_all = np.bincount(bi, minlength=nb).astype(float)
    n_used = np.bincount(bi[used], minlength=nb).astype(float)
    s1 = np.bincount(bi[used], weights=inn[used], minlength=nb)
    s2 = np.bincount(bi[used], weights=inn[used] ** 2, minlength=nb)
    okn = used & np.isfinite(nis)
    sn = np.bincount(bi[okn], weights=nis[okn], minlength=nb)
    nn = np.bincount(bi[okn], minlength=nb).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = s1 / n_used
        sd = np.sqrt(np.maximum(s2 / n_used - mean ** 2, 0.0))
        se = sd / np.sqrt(n_used)
        nis_m = sn / nn
        frac_not = 1.0 - n_used / n_all
    idx = np.arange(nb)
    fig, axs = plt.subplots(3, 1, figsize=(10, 6.2), sharex=True, layout="constrained",
                            gridspec_kw={"height_ratios": [1.6, 1, 0.8]})
    a = axs[0]
    a.fill_between(idx, 1000 * (mean - 2 * se), 1000 * (mean + 2 * se), color=C_EST, alpha=0.25, lw=0,
                   label="± 2 standard errors")
    a.plot(idx, 1000 * mean, color=C_EST, lw=1.3, marker="o", ms=2.5, label="mean innovation")
    a.axhline(0, color="#444", lw=0.8)
    a.set_ylabel("mean innovation (mm)")
    a.legend(loc="upper left", ncol=2, framealpha=0.85)
    a = axs[1]
    a.plot(idx, nis_m, color="#8e44ad", lw=1.2, marker="o", ms=2.5)
    a.axhline(1.0, color="#2d6a2d", lw=0.9)
    a.set_ylabel("mean NIS")
    a.set_ylim(bottom=0)
    a = axs[2]
    a.bar(idx, 100 * frac_not, width=0.9, color=C_NONSIG)
    a.set_ylabel("not used (%)")
    a.set_xlabel("beam index")
    a.set_xlim(-0.5, nb - 0.5)
    return fig, nb


def bin_positions(entries, name):
    """Tick positions and labels for categorical bars: edges between bins, or cell names."""
    los = [e.get("lo") for e in entries]
    his = [e.get("hi") for e in entries]
    integer_cells = all(is_num(l) and is_num(h) and abs(h - l - 1) < 1e-9 and abs(l - round(l)) < 1e-9
                        for l, h in zip(los, his))
    if name == "map_cell" or integer_cells:
        return list(range(len(entries))), [fedge(l) if is_num(l) else str(i) for i, l in enumerate(los)]
    ticks = [i - 0.5 for i in range(len(entries))] + [len(entries) - 0.5]
    labels = [fedge(l) for l in los] + [fedge(his[-1])]
    # Non-contiguous bins: label every bin as lo–hi at its centre instead.
    contiguous = all(is_num(his[i]) and is_num(los[i + 1]) and abs(his[i] - los[i + 1]) < 1e-9
                     for i in range(len(entries) - 1))
    if not contiguous:
        return list(range(len(entries))), [f"{fedge(l)}–{fedge(h)}" for l, h in zip(los, his)]
    return ticks, labels


def fig_bins(plt, bins, names):
    ncols = 4 if len(names) > 4 else len(names)
    nrows = int(math.ceil(len(names) / ncols))
    fig = plt.figure(figsize=(12.5, 4.6 * nrows), layout="constrained")
    gs = fig.add_gridspec(2 * nrows, ncols, height_ratios=[1.15, 1] * nrows)
    for k, name in enumerate(names):
        r, c = divmod(k, ncols)
        ent = bins[name]
        a1 = fig.add_subplot(gs[2 * r, c])
        a2 = fig.add_subplot(gs[2 * r + 1, c], sharex=a1)
        x = np.arange(len(ent))
        cnt = np.array([e.get("count") or 0 for e in ent], float)
        nism = np.array([e.get("nis_mean") if is_num(e.get("nis_mean")) else np.nan for e in ent], float)
        mni = np.array([e.get("mean_norm_innovation") if is_num(e.get("mean_norm_innovation")) else np.nan
                        for e in ent], float)
        with np.errstate(divide="ignore", invalid="ignore"):
            band_nis = 1.96 * np.sqrt(2.0 / cnt)       # NIS of one beam: chi2(1), variance 2
            band_mni = 1.96 / np.sqrt(cnt)
        off1 = np.abs(nism - 1.0) > band_nis
        off2 = np.abs(mni) > band_mni
        a1.bar(x, np.nan_to_num(nism), width=0.8, color=np.where(off1, C_BAD, C_EST),
               alpha=0.85, edgecolor="none")
        for i in np.nonzero(cnt < 30)[0]:
            a1.text(x[i], 0.02, f"n={int(cnt[i])}", rotation=90, ha="center", va="bottom", fontsize=7,
                    color="#555555", transform=a1.get_xaxis_transform())
        a1.axhline(1.0, color="#2d6a2d", lw=1.0)
        a1.set_ylim(bottom=0)
        lab, unit = BIN_LABEL.get(name, (name.replace("_", " "), ""))
        a1.set_title(lab, fontweight="bold")
        if c == 0:
            a1.set_ylabel("NIS mean")
            a2.set_ylabel("mean normalised\ninnovation")
        a2.axhline(0.0, color="#444", lw=0.8)
        a2.errorbar(x, np.nan_to_num(mni, nan=np.nan), yerr=np.where(np.isfinite(band_mni), band_mni, 0),
                    fmt="none", ecolor="#bbbbbb", elinewidth=4, alpha=0.8)
        a2.scatter(x, mni, s=22, color=np.where(off2, C_BAD, C_EST), zorder=3)
        ticks, labels = bin_positions(ent, name)
        a2.set_xticks(ticks)
        a2.set_xticklabels(labels, rotation=45 if len(labels) > 6 else 0,
                           ha="right" if len(labels) > 6 else "center")
        plt.setp(a1.get_xticklabels(), visible=False)
        a2.set_xlim(-0.6, len(ent) - 0.4)
        a2.set_xlabel(unit)
    return fig


def fig_ranking(plt, ranking):
    names = [r["effect"] for r in ranking]
    gain = np.array([r.get("bic_gain") if is_num(r.get("bic_gain")) else np.nan for r in ranking], float)
    sig = [bool(r.get("significant")) for r in ranking]
    fig, ax = plt.subplots(figsize=(9, 0.34 * len(names) + 1.1), layout="constrained")
    y = np.arange(len(names))
    ax.barh(y, np.nan_to_num(gain), color=[C_SIG if s else C_NONSIG for s in sig], height=0.7)
    ax.set_yticks(y)
    ax.set_yticklabels(names)
    for lbl, s in zip(ax.get_yticklabels(), sig):
        if s:
            lbl.set_fontweight("bold")
    ax.invert_yaxis()
    ax.axvline(0, color="#333", lw=0.9)
    fin = gain[np.isfinite(gain)]
    if fin.size and np.max(np.abs(fin)) > 50 * max(np.median(np.abs(fin)), 1.0):
        ax.set_xscale("symlog", linthresh=10)
        ax.set_xlabel("BIC gain (symmetric log scale; > 0 favours adding the effect)")
    else:
        ax.set_xlabel("BIC gain (> 0 favours adding the effect)")
    ax.grid(axis="y", visible=False)
    for yi, g in zip(y, gain):
        if math.isfinite(g):
            ax.text(g, yi, f" {g:.3g} " if abs(g) < 1e4 else f" {g:.2e} ", va="center",
                    ha="left" if g >= 0 else "right", fontsize=8)
    lo, hi = ax.get_xlim()
    span = hi - lo
    if ax.get_xscale() == "linear":
        ax.set_xlim(lo - 0.12 * span * (lo < 0), hi + 0.12 * span)
    else:
        ax.set_xlim(lo * 3 if lo < 0 else lo, hi * 3 if hi > 0 else hi)
    from matplotlib.patches import Patch
    ax.legend(handles=[Patch(color=C_SIG, label="significant"), Patch(color=C_NONSIG, label="not significant")],
              loc="lower right", frameon=True, framealpha=0.9)
    return fig


def fig_heldout(plt, held, blocks):
    """Per held-out block, the mean NIS (and pose error, with truth) before and after, against
    time: with cross-validation every block of the drive is held out once."""
    have_err = any(np.isfinite(held[k]["pose_err_m"]).any() for k in held)
    fig, axs = plt.subplots(2 if have_err else 1, 1, figsize=(10, 5.4 if have_err else 3.2), sharex=True,
                            layout="constrained", squeeze=False)
    axs = axs[:, 0]
    style = {"before": dict(color=C_BAD, label="before (model as it was)"),
             "after": dict(color=C_EST, label="after (with the effects added)")}
    edges = np.array([b[0] for b in blocks] + [blocks[-1][1]]) if blocks else None
    for k in ("before", "after"):
        if k not in held:
            continue
        h = held[k]
        t, nis, err = h["t"], h["nis"], h["pose_err_m"]
        if edges is not None and len(edges) > 1:
            idx = np.searchsorted(edges, t, side="right") - 1
            mids, mn, me = [], [], []
            for i in range(len(blocks)):
                m = idx == i
                if m.any():
                    mids.append(0.5 * (edges[i] + edges[i + 1]))
                    mn.append(np.nanmean(nis[m]))
                    me.append(np.sqrt(np.nanmean(err[m] ** 2)) if np.isfinite(err[m]).any() else np.nan)
            x, yn, ye = np.array(mids), np.array(mn), np.array(me)
        else:
            x, yn, ye = t, nis, err
        axs[0].plot(x, yn, lw=1.0, marker="o", ms=2.5, **style[k])
        if have_err:
            axs[1].plot(x, 100 * ye, lw=1.0, marker="o", ms=2.5, **style[k])
    axs[0].axhline(1.0, color="#2d6a2d", lw=0.9)
    axs[0].set_ylabel("mean NIS per beam")
    axs[0].legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=2, frameon=False)
    top = max([np.nanmax(held[k]["nis"]) for k in held if np.isfinite(held[k]["nis"]).any()] + [1.5])
    axs[0].set_ylim(0, min(top, 10.0) * 1.2)
    if have_err:
        axs[1].set_ylabel("pose error RMS (cm)")
        axs[1].set_ylim(bottom=0)
    axs[-1].set_xlabel("time of the held-out block (s)")
    return fig


# ----------------------------------------------------------------------------------------
# HTML
# ----------------------------------------------------------------------------------------

CSS = """
body{font-family:"DejaVu Sans",Arial,Helvetica,sans-serif;margin:0;background:#f4f5f7;color:#1d2328;
 line-height:1.45;font-size:15px}
main{max-width:1180px;margin:0 auto;padding:18px 26px 60px;background:#fff;min-height:100vh}
h1{font-size:25px;margin:8px 0 4px}
h2{font-size:20px;margin:34px 0 8px;padding-top:10px;border-top:2px solid #e3e6ea}
h3{font-size:16px;margin:18px 0 6px}
p.cap,p.note{color:#3c4650;margin:4px 0 10px;max-width:1000px}
p.note{font-style:italic;color:#6b7680}
figure{margin:8px 0 18px}
figure img{max-width:100%;height:auto;border:1px solid #e3e6ea}
figcaption{color:#3c4650;font-size:14px;margin-top:4px;max-width:1000px}
table{border-collapse:collapse;margin:8px 0 14px;font-size:14px}
th,td{border-bottom:1px solid #e3e6ea;padding:5px 9px;text-align:left;vertical-align:top}
th{background:#f0f2f5;font-weight:600}
td.n{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
tr.sig td{background:#fff3e0}
tr.sig td.eff{font-weight:700}
tr.undet td{background:#fdecea}
.small{font-size:12.5px;color:#5b6670}
.verdict{display:inline-block;padding:6px 16px;border-radius:6px;font-weight:700;font-size:20px;
 letter-spacing:.04em;color:#fff}
.v-ok{background:#2e8b57}.v-bad{background:#c0392b}.v-other{background:#7f8c8d}
.badge{display:inline-block;padding:1px 7px;border-radius:9px;font-size:12px;font-weight:600}
.b-yes{background:#c0392b;color:#fff}.b-no{background:#e3e6ea;color:#444}
.ok{color:#2e8b57;font-weight:600}.bad{color:#c0392b;font-weight:600}
nav{font-size:14px;margin:10px 0 4px}nav a{margin-right:12px;color:#1f5fa8;text-decoration:none}
ul.warn li{margin:4px 0}
.kv td:first-child{color:#5b6670}
details summary{cursor:pointer;color:#1f5fa8}
"""


def table(headers, rows, row_classes=None, num_cols=()):
    h = "".join(f"<th>{x}</th>" for x in headers)
    body = []
    for i, r in enumerate(rows):
        cls = f' class="{row_classes[i]}"' if row_classes and row_classes[i] else ""
        tds = []
        for j, cell in enumerate(r):
            if isinstance(cell, tuple):          # (html, td class)
                tds.append(f'<td class="{cell[1]}">{cell[0]}</td>')
            else:
                tds.append(f'<td class="n">{cell}</td>' if j in num_cols else f"<td>{cell}</td>")
        body.append(f"<tr{cls}>{''.join(tds)}</tr>")
    return f"<table><thead><tr>{h}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def figure(uri, alt, caption):
    return (f'<figure><img src="{uri}" alt="{E(alt)}"><figcaption>{caption}</figcaption></figure>')


def estimate_cell(r):
    est, sg = r.get("estimate"), r.get("sigma")
    est = est if isinstance(est, list) else ([] if est is None else [est])
    sg = sg if isinstance(sg, list) else ([] if sg is None else [sg])
    if not est:
        return "—"
    pairs = [(e, sg[i] if i < len(sg) else None) for i, e in enumerate(est)]

    def one(i, e, s):
        lab = f"[{i}] " if len(pairs) > 1 else ""
        return f"{lab}{pm(e, s)}"
    if len(pairs) <= 3:
        return "<br>".join(one(i, e, s) for i, (e, s) in enumerate(pairs))
    z = [abs(e) / s if (is_num(e) and is_num(s) and s > 0) else 0.0 for e, s in pairs]
    top = [i for i in np.argsort(z)[::-1][:3] if z[i] > 2.0]
    head = "<br>".join(one(i, *pairs[i]) for i in sorted(top))
    rest = (f"{len(pairs)} values; " + ("the others" if top else "all") + " within 2σ of 0")
    full = "<br>".join(one(i, e, s) for i, (e, s) in enumerate(pairs))
    return (f"{head}{'<br>' if head else ''}<span class='small'>{rest}</span>"
            f"<details><summary class='small'>all values</summary><span class='small'>{full}</span></details>")


def tests_section(d):
    t = d["tests"]
    rows = []
    band = t.get("nis_band")
    nm = t.get("nis_mean")
    if is_num(nm):
        inside = band is not None and band[0] <= nm <= band[1]
        flag = ("" if band is None else
                ("<span class='ok'>inside</span>" if inside else "<span class='bad'>outside</span>"))
        rows.append(["Mean NIS per beam", fnum(nm, 4),
                     f"{fnum(band[0], 4)} – {fnum(band[1], 4)} {flag}" if band else "about 1",
                     "1 when the filter's predicted uncertainty matches its real errors; above 1 it is "
                     "over-confident, below 1 too cautious."])
    if is_num(t.get("scans_outside_band_frac")):
        rows.append(["Scans outside their 95 % band", fpct(t["scans_outside_band_frac"]), "about 5 %",
                     "Share of scans whose summed NIS falls outside the chi-square band for their beam count."])
    if is_num(t.get("windowed_nis_outside_frac")):
        rows.append(["Windows outside their band", fpct(t["windowed_nis_outside_frac"]), "about 5 %",
                     "The same over sliding windows of scans: catches slow drifts that single scans hide."])
    lb = t.get("ljung_box")
    if isinstance(lb, dict):
        p = lb.get("p_value")
        flag = "" if not is_num(p) else (" <span class='bad'>correlated</span>" if p < 0.05
                                          else " <span class='ok'>no evidence</span>")
        rows.append([f"Ljung–Box whiteness ({fnum(lb.get('lags'), 0)} lags)",
                     f"Q = {fnum(lb.get('q'), 4)}, p {peq(p)}", f"p ≥ 0.05{flag}",
                     "Tests whether successive innovations are correlated in time; a small p means errors "
                     "repeat from scan to scan, the sign of a systematic effect."])
    for k, lab, what in (("nees_pose", "NEES of the pose", "pose"),
                         ("nees_params", "NEES of the parameters", "parameter")):
        if k in t:
            v = t[k]
            rows.append([lab, fnum(v, 4) if is_num(v) else "— (no truth in the log)", "about its dimension",
                         f"Squared {what} error against the truth, scaled by the filter's covariance."])
    known = {"nis_mean", "nis_band", "scans_outside_band_frac", "windowed_nis_outside_frac", "ljung_box",
             "nees_pose", "nees_params"}
    for k, v in t.items():
        if k in known:
            continue
        val = fnum(v, 4) if is_num(v) else E(json.dumps(v)[:120])
        rows.append([E(k.replace("_", " ")), val, "", ""])
    return table(["test", "value", "expected", "what it means"], rows, num_cols=(1,))


def ranking_section(ranking):
    rows, cls = [], []
    for i, r in enumerate(ranking):
        sig = bool(r.get("significant"))
        cls.append("sig" if sig else "")
        det = r.get("detectable")
        cw = r.get("confused_with") or []
        rows.append([
            str(i + 1),
            (f"{E(r['effect'])}<br><span class='small'>{E(str(r.get('description') or ''))}</span>", "eff"),
            "<span class='badge b-yes'>yes</span>" if sig else "<span class='badge b-no'>no</span>",
            fnum(r.get("delta_loglik"), 4), fnum(r.get("bic_gain"), 4), fp(r.get("p_value")),
            fnum(r.get("informed_params"), 0),
            (estimate_cell(r), "n"),
            "yes" if det else ("—" if det is None else "<span class='bad'>no</span>"),
            E(", ".join(cw)) if cw else "—",
        ])
    return table(["#", "effect", "significant", "Δ log-lik", "BIC gain", "p", "params", "estimate ± σ",
                  "detectable", "confused with"], rows, cls, num_cols=(0, 3, 4, 5, 6))


def heldout_table(h):
    b, a = h["before"], h["after"]
    spec = [("nis_mean", "Mean NIS per beam", 1.0, "", 3),
            ("nll_mean", "Predictive NLL per innovation", 1.0, "", 4),
            ("innovation_rms_m", "Innovation RMS (beams inside the gate)", 1000.0, "mm", 3),
            ("pose_rmse_m", "Pose RMSE against truth", 100.0, "cm", 3),
            ("heading_rmse_rad", "Heading RMSE against truth", 180.0 / math.pi, "°", 3)]
    keys = [s[0] for s in spec] + [k for k in list(b) + list(a) if k not in [s[0] for s in spec]]
    rows = []
    seen = set()
    for k in keys:
        if k in seen:
            continue
        seen.add(k)
        s = next((x for x in spec if x[0] == k), (k, k.replace("_", " "), 1.0, "", 4))
        vb, va = b.get(k), a.get(k)
        if vb is None and va is None and k in ("pose_rmse_m", "heading_rmse_rad"):
            rows.append([s[1], "—", "—", "no truth in the log"])
            continue
        ch = "—"
        if is_num(vb) and is_num(va) and vb != 0:
            better = abs(va - 1.0) < abs(vb - 1.0) if k == "nis_mean" else va < vb
            # the NLL is a log: its change is a difference, not a percentage
            txt = f"{va - vb:+.4f}" if k == "nll_mean" else f"{100.0 * (va - vb) / abs(vb):+.1f} %"
            ch = f"<span class='{'ok' if better else 'bad'}'>{txt}</span>"
        f = lambda v: fnum(v * s[2], s[4], s[3]) if is_num(v) else "—"
        rows.append([s[1], f(vb), f(va), ch])
    out = table(["metric", "before", "after", "change"], rows, num_cols=(1, 2, 3))
    pr = h.get("paired") or {}
    lines = []
    for k, label in (("pose_err_m", "pose error"), ("nll", "NLL"), ("nis", "NIS")):
        q = pr.get(k)
        if isinstance(q, dict) and is_num(q.get("blocks")) and q["blocks"] > 0 and is_num(q.get("change_z")):
            lines.append(f"{label}: better in {int(q['blocks_better'])} of {int(q['blocks'])} blocks, "
                         f"paired z {q['change_z']:+.1f}")
    if lines:
        out += ("<p class='note'>Block by block (after minus before; z below −2 is a consistent fall): "
                + E("; ".join(lines)) + ".</p>")
    return out


def excitation_section(ex):
    if not ex:
        return "<p class='note'>No excitation analysis in diagnose.json.</p>"
    ps = ex.get("parameters") or []
    out = []
    if ps:
        rows, cls = [], []
        for p in ps:
            sa, pr = p.get("sigma_achievable"), p.get("prior_sigma")
            ratio = sa / pr if is_num(sa) and is_num(pr) and pr > 0 else None
            det = p.get("determined")
            cls.append("" if det or det is None else "undet")
            rows.append([E(str(p.get("name", "?"))), fnum(sa, 3), fnum(pr, 3),
                         "—" if ratio is None else f"{ratio:.2g}",
                         "—" if det is None else ("<span class='ok'>yes</span>" if det
                                                  else "<span class='bad'>no</span>")])
        out.append(table(["parameter", "achievable σ", "prior σ", "achievable / prior", "determined"],
                         rows, cls, num_cols=(1, 2, 3)))
    else:
        out.append("<p class='note'>No parameters listed.</p>")
    w = ex.get("warnings") or []
    out.append("<h3>Warnings about this drive</h3>")
    if w:
        out.append("<ul class='warn'>" + "".join(f"<li>{E(str(x))}</li>" for x in w) + "</ul>")
    else:
        out.append("<p class='note'>None: the drive excites every parameter enough.</p>")
    return "".join(out)


def bins_table(bins, names):
    parts = []
    for name in names:
        rows = []
        for e in bins[name]:
            rows.append([f"{fedge(e.get('lo'))} – {fedge(e.get('hi'))}", fnum(e.get("count"), 0),
                         fnum(e.get("nis_mean"), 3), fnum(e.get("mean_norm_innovation"), 3),
                         fnum(None if e.get("along_mean_m") is None else 1000 * e["along_mean_m"], 3),
                         fnum(None if e.get("cross_mean_m") is None else 1000 * e["cross_mean_m"], 3),
                         fnum(None if e.get("heading_mean_rad") is None else 1000 * e["heading_mean_rad"], 3)])
        lab, unit = BIN_LABEL.get(name, (name, ""))
        parts.append(f"<h3>{E(lab)} ({E(unit)})</h3>" + table(
            ["bin", "beams", "NIS mean", "mean norm. innovation", "along corr. (mm)", "cross corr. (mm)",
             "heading corr. (mrad)"], rows, num_cols=(1, 2, 3, 4, 5, 6)))
    return "".join(parts)


def build(args):
    t_start = time.monotonic()
    d, scans, beams, traj, held = load_inputs(args.dir)
    plt = setup_matplotlib()
    rng = np.random.default_rng(0)
    walls = (d.get("map") or {}).get("walls") or []
    alarms = [a for a in ((d.get("cusum") or {}).get("alarms") or [])
              if is_num(a.get("x")) and is_num(a.get("y"))]
    has_truth = bool(len(traj["t"]) and np.isfinite(traj["truth_x"]).any() and np.isfinite(traj["truth_y"]).any())
    n_imgs = 0
    s = []
    verdict = d["verdict"]
    vcls = {"consistent": "v-ok", "inconsistent": "v-bad"}.get(verdict, "v-other")
    vtext = {
        "consistent": "The filter's errors are the size and shape its model predicts: the odometry model "
                      "explains this log.",
        "inconsistent": "The errors are larger or more structured than the model allows: something physical "
                        "is missing from the odometry or laser model. The effect ranking below lists the "
                        "likely causes.",
    }.get(verdict, "")
    sig_names = [r["effect"] for r in d["ranking"] if r.get("significant")]
    dist_total = float(np.nanmax(scans["dist_m"])) if len(scans["dist_m"]) and np.isfinite(scans["dist_m"]).any() else None
    n_used = int((beams["status"] == "used").sum())
    s.append(f"<h1>odoerr diagnose report</h1>")
    s.append("<table class='kv'><tbody>"
             f"<tr><td>log</td><td><code>{E(d['log'])}</code></td></tr>"
             f"<tr><td>drive</td><td>{E(d['drive'])} "
             f"{'(differential)' if d['drive'] == 'diff' else '(synchronous)' if d['drive'] == 'sync' else ''}</td></tr>"
             f"<tr><td>data</td><td>{len(scans['t'])} scans, {len(beams['t'])} predicted beams "
             f"({n_used} used), {fnum(dist_total, 4, 'm') if dist_total is not None else '—'} driven</td></tr>"
             "</tbody></table>")
    s.append(f"<p><span class='verdict {vcls}'>{E(verdict.upper())}</span></p><p class='cap'>{E(vtext)}</p>")
    if sig_names:
        s.append(f"<p class='cap'><b>Significant effects, best first:</b> {E(', '.join(sig_names))}.</p>")
    else:
        s.append("<p class='cap'>No candidate effect improves the model significantly.</p>")
    s.append("<nav><a href='#tests'>Tests</a><a href='#trajectory'>Trajectory</a><a href='#nis'>NIS</a>"
             "<a href='#residuals'>Residual map</a><a href='#beams'>Per beam</a><a href='#bins'>Bins</a>"
             "<a href='#ranking'>Effects</a><a href='#heldout'>Held-out</a><a href='#excitation'>Excitation</a></nav>")

    s.append("<h2 id='tests'>Consistency tests</h2>")
    s.append("<p class='cap'>Each test asks whether the filter's innovations (measured minus predicted "
             "laser ranges) behave as its own uncertainty says they should.</p>")
    s.append(tests_section(d))

    s.append("<h2 id='trajectory'>Trajectory on the map</h2>")
    if len(traj["t"]):
        cap = ("The estimated path (blue) over the map's walls (black)"
               + (", with the true path dashed in orange" if has_truth else "; the log has no truth")
               + ". " + (f"Triangles mark the {len(alarms)} CUSUM alarm(s), A1… in time order: places where the "
                         "NIS drifted up (▲) or down (▼) for long enough to be a change, not noise."
                         if alarms else "There were no CUSUM alarms: the NIS never drifted for long."))
        s.append(figure(png_uri(plt, fig_trajectory(plt, traj, walls, alarms, has_truth)),
                        "trajectory on the map", E(cap)))
        n_imgs += 1
        if has_truth:
            s.append(figure(png_uri(plt, fig_truth_error(plt, traj)), "error against truth",
                            "How far the estimate is from the truth along the drive: position error in cm "
                            "(top) and heading error in degrees (bottom)."))
            n_imgs += 1
    else:
        s.append("<p class='note'>trajectory.csv has no rows.</p>")
    if not walls:
        s.append("<p class='note'>diagnose.json has no map walls.</p>")

    s.append("<h2 id='nis'>NIS per scan along the drive</h2>")
    if len(scans["t"]):
        fig, n_out, n_good = fig_nis(plt, scans, alarms)
        s.append(figure(png_uri(plt, fig), "NIS per scan against distance",
                        E(f"Top: each dot is one scan's normalised innovation squared divided by its number "
                          f"of beams; it should scatter around 1 inside the green band. {n_out} of {n_good} "
                          f"scans are outside it (red); runs of them, or a running mean (black) away from 1, "
                          f"point to a systematic error at that part of the drive. Below: the pose "
                          f"correction each scan made, in the robot frame; corrections that repeat with the "
                          f"same sign show what the odometry gets wrong (e.g. cross-track in every turn). "
                          f"Dotted lines: CUSUM alarms.")))
        n_imgs += 1
    else:
        s.append("<p class='note'>scans.csv has no rows: nothing to plot.</p>")

    s.append("<h2 id='residuals'>Residual map</h2>")
    if len(beams["t"]) and (beams["status"] == "used").any():
        fig, nu, nshown, vmax, cvmax = fig_residual_map(plt, beams, walls, traj, args.max_points, rng)
        s.append(figure(png_uri(plt, fig), "residual map",
                        E(f"Where the used beams hit the map, coloured by their innovation (measured minus "
                          f"predicted range): red means the laser measured farther than the map predicts, "
                          f"blue nearer. Left: individual beams (scale ±{vmax:.3g} mm, the 98th percentile; "
                          + (f"{nshown} of {nu} drawn" if nshown < nu else f"all {nu} drawn")
                          + f"). Right: the same averaged over small cells, which removes the noise "
                          f"(scale ±{cvmax:.3g} mm). A wall that is red or blue all along is probably not "
                          f"where the map says; everything shifted one way suggests a range bias; colour "
                          f"that changes with where the robot was points to the odometry.")))
        n_imgs += 1
    else:
        s.append("<p class='note'>beams.csv has no used beams: nothing to plot.</p>")

    s.append("<h2 id='beams'>Residuals per beam</h2>")
    if len(beams["t"]) and np.isfinite(beams["beam"]).any():
        fig, nb = fig_beams(plt, beams)
        s.append(figure(png_uri(plt, fig), "per-beam residuals",
                        E(f"For each of the {nb} beams of the scanner (index 0 = first beam of a scan): the mean "
                          f"innovation with ±2 standard errors (top), the mean NIS (middle, 1 expected) and the "
                          f"share of its predictions not used (bottom). A smooth trend across the beams points "
                          f"to the laser (mounting yaw or offset, range scale); a single odd beam to a fault "
                          f"or an obstacle.")))
        n_imgs += 1
    else:
        s.append("<p class='note'>beams.csv has no rows: nothing to plot.</p>")

    s.append("<h2 id='bins'>Innovations binned by driving conditions</h2>")
    bins = d.get("bins") or {}
    names = [n for n in BIN_ORDER if bins.get(n)] + sorted(n for n in bins if n not in BIN_ORDER and bins.get(n))
    empty = [n for n in BIN_ORDER if n in bins and not bins.get(n)]
    empty += sorted(n for n in bins if n not in BIN_ORDER and not bins.get(n))
    if names:
        s.append(figure(png_uri(plt, fig_bins(plt, bins, names)), "binned NIS and innovation",
                        E("Beams grouped by the conditions when they were taken. In each panel, top: the mean "
                          "NIS of the bin (1 expected, green line); bottom: the mean innovation divided by its "
                          "sigma (0 expected), with the grey bar showing what chance allows for the bin's beam "
                          "count if beams were independent. Red marks a bin outside that range. A trend with "
                          "turn rate or v·ω suggests slip; with speed, a speed-dependent scale; right after a "
                          "reversal, backlash; in one map cell, a floor region or a wrong wall. Bins with fewer "
                          "than 30 beams are labelled n=.")))
        n_imgs += 1
        s.append("<details><summary>Numbers per bin, with the mean pose corrections</summary>"
                 + bins_table(bins, names) + "</details>")
    else:
        s.append("<p class='note'>diagnose.json has no bins.</p>")
    if empty:
        s.append(f"<p class='note'>No data for: {E(', '.join(empty))}"
                 + (" (the wheel angle exists only for a synchronous drive)." if "wheel_angle" in empty
                    and d["drive"] == "diff" else ".") + "</p>")

    s.append("<h2 id='ranking'>Effect ranking</h2>")
    if d["ranking"]:
        s.append(figure(png_uri(plt, fig_ranking(plt, d["ranking"])), "BIC gain per effect",
                        E("How much adding each candidate effect to the model improves it, after the BIC "
                          "penalty for its extra parameters: above 0 the data favour the effect. Red bars are "
                          "significant.")))
        n_imgs += 1
        s.append("<p class='cap'>Each candidate physical effect, fitted to this log one at a time, best first. "
                 "Significant rows are highlighted. <i>params</i>: how many of its parameters the log informs; "
                 "<i>detectable</i>: whether this drive could reveal the effect at all; <i>confused with</i>: "
                 "effects this log cannot tell apart from it.</p>")
        s.append(ranking_section(d["ranking"]))
    else:
        s.append("<p class='note'>The ranking is empty.</p>")

    s.append("<h2 id='heldout'>Held-out check</h2>")
    h = d.get("heldout")
    if h is None:
        s.append("<p class='note'>No held-out check was run (heldout is null).</p>")
    else:
        wn = h.get("with") or []
        bl = h.get("blocks") or []
        folds = h.get("folds")
        span = f"{bl[0][0]:.4g}–{bl[-1][1]:.4g} s" if bl else "none"
        s.append(f"<p class='cap'>Cross-validated: the drive ({E(span)}) was cut into {len(bl)} block(s)"
                 + (f" in {int(folds)} folds" if is_num(folds) else "") +
                 f". Each block was held out once: the model, before and with <b>{E(', '.join(wn) or 'no effect')}</b>, "
                 f"was fitted on the other folds' data and then predicted the block it had not seen. If the "
                 f"effects are real, the held-out predictions get better too: smaller errors and NLL, NIS "
                 f"closer to 1.</p>")
        ff = h.get("folds_failed") or []
        if ff:
            s.append(f"<p class='note bad'>Left out of the comparison: fold(s) {E(', '.join(str(f) for f in ff))}. "
                     f"There the fit lost the robot while it dead-reckoned through a held-out block, so its "
                     f"parameters mean nothing. If this happens often, the drive has long stretches where the "
                     f"laser cannot relocalise the robot.</p>")
        s.append(heldout_table(h))
        if held:
            s.append(figure(png_uri(plt, fig_heldout(plt, held, bl)), "held-out before and after",
                            E("Before (red) and after (blue) adding the effects: the held-out scans' NIS per "
                              "beam (top, 1 expected)" + (" and its pose error against the truth (bottom)"
                                                          if len(held) and any(np.isfinite(held[k]['pose_err_m']).any() for k in held)
                                                          else "") + ", averaged over each held-out block.")))
            n_imgs += 1
        else:
            s.append("<p class='note'>heldout_before.csv / heldout_after.csv are not in the directory: "
                     "no per-scan plot.</p>")

    s.append("<h2 id='excitation'>Excitation: what this drive can determine</h2>")
    s.append("<p class='cap'>For each parameter, the smallest sigma this drive could give it (achievable) "
             "against what was known before (prior). A parameter is determined when the drive pins it down well "
             "below its prior; undetermined ones are highlighted, and the warnings say what driving would fix "
             "that.</p>")
    s.append(excitation_section(d.get("excitation")))

    elapsed = time.monotonic() - t_start
    s.append(f"<p class='small' style='margin-top:40px'>Made by tools/report/make_report.py from "
             f"{E(os.path.abspath(args.dir))} in {elapsed:.1f} s; {n_imgs} figures.</p>")
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>odoerr diagnose: {E(verdict)} — {E(os.path.basename(d['log']))}</title>"
            f"<style>{CSS}</style></head><body><main>" + "\n".join(s) + "</main></body></html>\n")
    return page, n_imgs


def main(argv=None):
    ap = argparse.ArgumentParser(prog=PROG, description="Write DIR/report.html from the files "
                                 "`odoerr diagnose` wrote into DIR.")
    ap.add_argument("dir", metavar="DIR", help="output directory of odoerr diagnose")
    ap.add_argument("--out", "-o", help="where to write the page (default DIR/report.html)")
    ap.add_argument("--max-points", type=int, default=40000,
                    help="at most this many beams drawn on the residual map (default 40000)")
    args = ap.parse_args(argv)
    if args.max_points < 100:
        ap.error("--max-points must be at least 100")
    t0 = time.monotonic()
    try:
        page, n_imgs = build(args)
    except InputError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 1
    out = args.out or os.path.join(args.dir, "report.html")
    tmp = out + ".tmp"
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(page)
        os.replace(tmp, out)
    except OSError as e:
        print(f"{PROG}: error: cannot write {out}: {e}", file=sys.stderr)
        return 1
    print(f"{PROG}: wrote {out} ({len(page) / 1e6:.1f} MB, {n_imgs} figures) in {time.monotonic() - t0:.1f} s",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
