"""The figure of where the map is wrong: the map's walls with diagnose's residual grid over it
(mean normalised residual per cell), the regions outlined and labelled with their sign, the
candidate segments dashed and a few positions each region was seen from."""
import numpy as np

from plots import draw_walls, map_limits

C_SHORT, C_LONG, C_SEG, C_SEEN = "#1a4f8f", "#a3191c", "#148a3c", "#6a3d9a"
HIDE_BELOW = 5          # cells with fewer beams are not drawn
FADE_BELOW = 30         # cells with fewer beams are pale


def grid_arrays(grid, g, cell):
    """The CSV's rows on the regular grid: (edges_x, edges_y, mean, count, region), arrays
    (ny, nx) with nan / 0 / -1 where the CSV has no row. Cells off the grid are dropped."""
    x0, y0, nx, ny = float(g["x0"]), float(g["y0"]), int(g["nx"]), int(g["ny"])
    ix = np.floor((grid["x"] - x0) / cell).astype(np.int64)
    iy = np.floor((grid["y"] - y0) / cell).astype(np.int64)
    ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny) & np.isfinite(grid["mean_norm"])
    mean = np.full((ny, nx), np.nan)
    count = np.zeros((ny, nx))
    region = np.full((ny, nx), -1, dtype=np.int64)
    mean[iy[ok], ix[ok]] = grid["mean_norm"][ok]
    count[iy[ok], ix[ok]] = np.nan_to_num(grid["count"][ok])
    region[iy[ok], ix[ok]] = np.nan_to_num(grid["region"][ok], nan=-1).astype(np.int64)
    return x0 + cell * np.arange(nx + 1), y0 + cell * np.arange(ny + 1), mean, count, region


def region_outline(region, k, ex, ey):
    """The boundary edges of region k's cells: the edges a region cell does not share with
    another cell of the same region."""
    segs = []
    ny, nx = region.shape
    inr = region == k
    for j, i in zip(*np.nonzero(inr)):
        xl, xr, yb, yt = ex[i], ex[i + 1], ey[j], ey[j + 1]
        if i == 0 or not inr[j, i - 1]:
            segs.append([(xl, yb), (xl, yt)])
        if i == nx - 1 or not inr[j, i + 1]:
            segs.append([(xr, yb), (xr, yt)])
        if j == 0 or not inr[j - 1, i]:
            segs.append([(xl, yb), (xr, yb)])
        if j == ny - 1 or not inr[j + 1, i]:
            segs.append([(xl, yt), (xr, yt)])
    return segs


def fig_map_misfit(plt, m, grid, walls, traj, n_seen=3):
    """Returns (figure, vmax, cells drawn)."""
    import matplotlib.patheffects as pe
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    regs = m.get("regions") or []
    cell = float(m.get("cell_m") or 0.25)
    g = m.get("grid") or {}
    fig, ax = plt.subplots(figsize=(11.0, 7.6), layout="constrained")
    ax.grid(False)
    ax.plot(traj["x"], traj["y"], color="#c4c8cc", lw=0.7, zorder=1)
    halo = [pe.withStroke(linewidth=4.2, foreground="white")]
    xs, ys = [], []
    n_drawn, vmax = 0, 1.0
    have_grid = grid is not None and all(isinstance(g.get(k), (int, float)) for k in ("x0", "y0", "nx", "ny"))
    ex = ey = region = None
    if have_grid:
        ex, ey, mean, count, region = grid_arrays(grid, g, cell)
        shown = np.isfinite(mean) & (count >= HIDE_BELOW)
        full = shown & (count >= FADE_BELOW)
        n_drawn = int(shown.sum())
        ref = np.abs(mean[full]) if full.any() else np.abs(mean[shown])
        rmax = max([abs(float(r["mean_norm"])) for r in regs if isinstance(r.get("mean_norm"), (int, float))],
                   default=0.0)
        vmax = float(np.clip(max(np.percentile(ref, 98) if ref.size else 0.0, rmax), 1.0, 10.0))
        kw = dict(cmap="RdBu_r", vmin=-vmax, vmax=vmax, shading="flat", zorder=2, lw=0)
        ax.pcolormesh(ex, ey, np.ma.masked_where(~(shown & ~full), mean), alpha=0.35, **kw)
        qm = ax.pcolormesh(ex, ey, np.ma.masked_where(~full, mean), **kw)
        cb = fig.colorbar(qm, ax=ax, extend="both", shrink=0.8, pad=0.01)
        cb.set_label("mean normalised residual z in the cell\n(blue: shorter than the map says; red: longer)")
        jj, ii = np.nonzero(shown)
        if jj.size:
            xs += [ex[ii.min()], ex[ii.max() + 1]]
            ys += [ey[jj.min()], ey[jj.max() + 1]]
    draw_walls(ax, walls, colors="#111111", linewidths=1.3, zorder=3)

    for k, r in enumerate(regs):
        col = C_SHORT if r.get("sign") == "short" else C_LONG
        segs = region_outline(region, k, ex, ey) if have_grid else []
        w, h = (r.get("extent_m") or [cell, cell])[:2]
        cx, cy = float(r["x"]), float(r["y"])
        if segs:
            pts = np.array([p for s in segs for p in s])
            bx0, by0 = pts.min(axis=0)
            bx1, by1 = pts.max(axis=0)
        else:                                    # no grid: the region's extent around its centre
            bx0, bx1, by0, by1 = cx - w / 2, cx + w / 2, cy - h / 2, cy + h / 2
            segs = [[(bx0, by0), (bx1, by0)], [(bx1, by0), (bx1, by1)], [(bx1, by1), (bx0, by1)],
                    [(bx0, by1), (bx0, by0)]]
        ax.add_collection(LineCollection(segs, colors="black", linewidths=2.0, zorder=5, path_effects=halo))
        xs += [bx0, bx1]
        ys += [by0, by1]
        seen = [p for p in (r.get("seen_from") or [])][:n_seen]
        for p in seen:
            ax.plot([p[0], cx], [p[1], cy], color=C_SEEN, lw=0.8, ls=":", alpha=0.55, zorder=4)
        if seen:
            ax.scatter([p[0] for p in seen], [p[1] for p in seen], marker="o", s=46, color=C_SEEN,
                       edgecolor="white", linewidth=1.0, zorder=6)
        seg = r.get("candidate_segment")
        if seg:
            ax.plot([seg[0], seg[2]], [seg[1], seg[3]], color=C_SEG, lw=2.6, ls=(0, (4, 2.5)), zorder=6,
                    solid_capstyle="butt", path_effects=halo)
            xs += [seg[0], seg[2]]
            ys += [seg[1], seg[3]]
        # The label beside the region, on the side toward the middle of the map when it can.
        kind = (r.get("history") or {}).get("kind")
        ax.annotate(f"R{k + 1} {r.get('sign') or '?'}" + (f", {kind}" if kind else ""), (bx1, by1), xytext=(4, 4), textcoords="offset points",
                    fontsize=11, fontweight="bold", color=col, zorder=8, va="bottom", ha="left",
                    bbox=dict(boxstyle="round,pad=0.25", fc="white", ec=col, lw=1.3, alpha=0.92))
    map_limits(ax, walls, (np.array(xs, float), np.array(ys, float)), (traj["x"], traj["y"]))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    handles = [Line2D([], [], color="#111111", lw=1.3, label="map walls"),
               Line2D([], [], color="#c4c8cc", lw=0.9, label="estimated path")]
    if regs:
        handles += [Patch(fc="none", ec="black", lw=2.0, label="region the test flags (R1…)"),
                    Line2D([], [], color=C_SEG, lw=2.6, ls=(0, (4, 2.5)), label="candidate segment: where the surface is"),
                    Line2D([], [], color=C_SEEN, marker="o", ls=":", lw=0.8, ms=6, label="seen from (a few positions; dotted: the line of sight)")]
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.07), ncol=min(len(handles), 3),
              frameon=False, fontsize=9)
    return fig, vmax, n_drawn
