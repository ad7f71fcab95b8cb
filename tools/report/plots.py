"""The report's figures (matplotlib, Agg): each fig_* returns a Figure; png_uri embeds it."""
import base64
import io
import math

import numpy as np

from fmt import fedge
from report_io import is_num

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

C_CP = "#d35400"          # change points: the line at t and the band [t_lo, t_hi]


def mark_change_points(axs, cps, to_x=None, label_ax=None):
    """Shade each change point's [t_lo, t_hi] and draw a line at its t on every axis in axs;
    to_x maps a time to the axis' x (e.g. distance travelled); labels C1... on label_ax."""
    conv = (lambda t: t) if to_x is None else to_x
    for i, c in enumerate(cps):
        t, lo, hi = c.get("t"), c.get("t_lo"), c.get("t_hi")
        if t is None:
            continue
        x = conv(t)
        for k, ax in enumerate(axs):
            if lo is not None and hi is not None:
                ax.axvspan(conv(lo), conv(hi), color=C_CP, alpha=0.12, lw=0, zorder=0,
                           label="change point: interval" if i == 0 and ax is label_ax else None)
            ax.axvline(x, color=C_CP, lw=1.4, ls="-", zorder=0.5,
                       label="change point: time" if i == 0 and ax is label_ax else None)
        if label_ax is not None:
            label_ax.text(x, 0.02, f" C{i + 1}", color=C_CP, fontsize=9.5, fontweight="bold", va="bottom",
                          transform=label_ax.get_xaxis_transform())


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


def alarm_stretches(t, x, y, clusters):
    """The path of each cluster from its first alarm to its last (an alarm alone: nothing), as
    line segments for one LineCollection, with the cluster's direction."""
    segs, dirs = [], []
    if len(t) < 2:
        return segs, dirs
    for c in clusters:
        if c["t1"] <= c["t0"]:
            continue
        i0, i1 = np.searchsorted(t, [c["t0"], c["t1"]])
        xs, ys = x[max(i0 - 1, 0):i1 + 1], y[max(i0 - 1, 0):i1 + 1]
        f = np.isfinite(xs) & np.isfinite(ys)
        if f.sum() >= 2:
            segs.append(np.column_stack([xs[f], ys[f]]))
            dirs.append(c["direction"])
    return segs, dirs


def fig_trajectory(plt, traj, walls, clusters, has_truth):
    """The path on the map with the CUSUM alarms' clusters (alarms.cluster_alarms): each drawn
    once, a triangle at its first alarm and the path its alarms cover thick underneath; only the
    first alarms.LABELLED clusters carry a label."""
    from matplotlib.collections import LineCollection
    from alarms import LABELLED, label
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
    style = {"up": ("^", "alarm cluster: NIS rising", C_BAD), "down": ("v", "alarm cluster: NIS falling", "#7b3fa0")}
    segs, dirs = alarm_stretches(traj["t"], x, y, clusters)
    if segs:
        ax.add_collection(LineCollection(segs, colors=[style[d][2] for d in dirs], linewidths=7, alpha=0.28,
                                         capstyle="round", joinstyle="round", zorder=2.5,
                                         label="path during a cluster"))
    for d in ("up", "down"):
        sel = [c for c in clusters if c["direction"] == d]
        if sel:
            sym, lab, col = style[d]
            ax.scatter([c["x"] for c in sel], [c["y"] for c in sel], marker=sym, s=150, color=col,
                       edgecolor="white", linewidth=1.2, zorder=6, label=lab)
    for k, c in enumerate(clusters[:LABELLED]):
        ax.annotate(label(k, c), (c["x"], c["y"]), xytext=(8, 7), textcoords="offset points",
                    fontsize=9, fontweight="bold", color="#222222", zorder=7,
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))
    if len(clusters) > LABELLED:
        ax.text(0.99, 0.01, f"{len(clusters)} alarm clusters; the first {LABELLED} labelled",
                transform=ax.transAxes, ha="right", va="bottom", fontsize=8, color="#444444", zorder=7)
    map_limits(ax, walls, (x, y))
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return fig


def path_distance(x, y):
    d = np.hypot(np.diff(x), np.diff(y))
    d[~np.isfinite(d)] = 0.0
    return np.concatenate([[0.0], np.cumsum(d)])


def fig_truth_error(plt, traj, cps=()):
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
    if cps and len(dist) > 1:
        mark_change_points((a1, a2), cps, lambda t: float(np.interp(t, traj["t"], dist)), a1)
    return fig


def rolling_mean(v, w):
    ok = np.isfinite(v)
    vv = np.where(ok, v, 0.0)
    k = np.ones(w)
    s = np.convolve(vv, k, "same")
    n = np.convolve(ok.astype(float), k, "same")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > w / 3, s / np.maximum(n, 1), np.nan)


def mark_alarm_clusters(axs, clusters, to_x, label_ax):
    """On every axis, each cluster of CUSUM alarms once: a dotted line at its first alarm and a
    pale band to its last, all in one collection per axis (their number does not grow with
    the alarms'); the first alarms.LABELLED clusters labelled on label_ax."""
    from matplotlib.collections import LineCollection, PolyCollection
    from alarms import LABELLED, label
    x0 = to_x(np.array([c["t0"] for c in clusters], float))
    x1 = to_x(np.array([c["t1"] for c in clusters], float))
    wide = x1 > x0
    for a in axs:
        tr = a.get_xaxis_transform()              # x in data, y in axes fraction
        if wide.any():
            a.add_collection(PolyCollection([[(p, 0), (q, 0), (q, 1), (p, 1)] for p, q in zip(x0[wide], x1[wide])],
                                            facecolors="#7b3fa0", alpha=0.10, lw=0, zorder=0, transform=tr),
                             autolim=False)
        a.add_collection(LineCollection([[(p, 0), (p, 1)] for p in x0], colors="#7b3fa0", linewidths=0.9,
                                        linestyles=":", zorder=0, transform=tr), autolim=False)
    for k, c in enumerate(clusters[:LABELLED]):
        label_ax.text(x0[k], 1.005, label(k, c), color="#7b3fa0", fontsize=8.5, va="bottom", ha="center",
                      fontweight="bold", transform=label_ax.get_xaxis_transform(), clip_on=False)


def fig_nis(plt, scans, clusters, cps=()):
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
    if clusters and len(dist) > 1:
        mark_alarm_clusters(axs, clusters, lambda t: np.interp(t, scans["t"], dist), ax)
    if cps and len(dist) > 1:
        mark_change_points(axs, cps, lambda t: float(np.interp(t, scans["t"], dist)), ax)
    ax.legend(loc="upper left", ncol=3 if cps else 4, frameon=True, framealpha=0.85)
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


def fig_heldout(plt, held, blocks, cps=()):
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
    if cps:
        mark_change_points(axs, cps, None, axs[0])
    return fig
