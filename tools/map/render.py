"""render.py: a PNG of line segments drawn over an occupancy grid (matplotlib, Agg)."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402


def render(path, segs, grid=None, title="", dpi=150, max_inches=12.0):
    """Writes PATH (PNG): the grid (occupied black, free white, unknown grey; world frame,
    only when the origin has no yaw the image is drawn) and the segments in red, their end
    points as dots. segs: M x 4 (m)."""
    segs = np.asarray(segs, dtype=float).reshape(-1, 4)
    if grid is not None:
        rows, cols = grid.shape
        x0, y0, _ = grid.origin
        ext = (x0, x0 + cols * grid.resolution, y0, y0 + rows * grid.resolution)
    elif len(segs):
        ext = (segs[:, [0, 2]].min(), segs[:, [0, 2]].max(), segs[:, [1, 3]].min(), segs[:, [1, 3]].max())
    else:
        ext = (0, 1, 0, 1)
    w, h = max(ext[1] - ext[0], 1e-3), max(ext[3] - ext[2], 1e-3)
    scale = max_inches / max(w, h)
    fig, ax = plt.subplots(figsize=(max(w * scale, 3), max(h * scale, 3)))
    if grid is not None:
        img = np.full(grid.shape, 0.8)
        img[grid.free] = 1.0
        img[grid.occ] = 0.0
        if abs(grid.origin[2]) < 1e-12:
            ax.imshow(img, origin="lower", extent=ext, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
        else:  # a rotated grid: its cells as points
            pts = grid.occupied_centres()
            ax.plot(pts[:, 0], pts[:, 1], "s", color="k", ms=1)
    if len(segs):
        ax.add_collection(LineCollection(segs.reshape(-1, 2, 2), colors="red", linewidths=0.8))
        ends = segs.reshape(-1, 2)
        ax.plot(ends[:, 0], ends[:, 1], ".", color="blue", ms=1.5)
    if grid is not None:
        # zoom on what is known
        known = ~grid.unknown
        if known.any():
            r, c = np.nonzero(known)
            xa, ya = grid.to_world(np.array([c.min(), c.max() + 1]), np.array([r.min(), r.max() + 1]))
            m = 10 * grid.resolution
            ax.set_xlim(min(xa) - m, max(xa) + m)
            ax.set_ylim(min(ya) - m, max(ya) + m)
    else:
        ax.set_xlim(ext[0], ext[1])
        ax.set_ylim(ext[2], ext[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or f"{len(segs)} segments")
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
