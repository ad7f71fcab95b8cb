"""segfit.py: what the extraction methods and the fit figures share: the speck filter,
the total-least-squares line, the point-to-segment distance and the fit metrics.
Lengths are in whatever unit the caller's points use (cells in extract/ransac, metres in
fit_metrics)."""

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

EIGHT = np.ones((3, 3), dtype=bool)


def drop_specks(occ, min_cells):
    """occ without its 8-connected components of fewer than min_cells cells; and how many
    cells were dropped."""
    lab, n = ndimage.label(occ, structure=EIGHT)
    if n == 0:
        return occ.copy(), 0
    sizes = np.bincount(lab.ravel())
    keep = sizes >= min_cells
    keep[0] = False
    out = keep[lab]
    return out, int(occ.sum() - out.sum())


def tls_fit(pts):
    """Total least squares line: centroid and unit direction; and the max distance to it."""
    c = pts.mean(axis=0)
    d = pts - c
    if len(pts) < 2:
        return c, np.array([1.0, 0.0]), 0.0
    _, _, vt = np.linalg.svd(d, full_matrices=False)
    u = vt[0]
    dist = np.abs(d[:, 0] * u[1] - d[:, 1] * u[0])
    return c, u, float(dist.max())


def segment_from(pts):
    c, u, _ = tls_fit(pts)
    t = (pts - c) @ u
    return np.concatenate([c + t.min() * u, c + t.max() * u])


def fits(pts, tol):
    """One line fits the points: none farther than 2 tol from it, at most 1 in 10 farther
    than tol (a short jog round a drop-out does not keep two pieces of a wall apart)."""
    c, u, dmax = tls_fit(pts)
    if dmax <= tol:
        return True
    if dmax > 2 * tol:
        return False
    d = np.abs((pts[:, 0] - c[0]) * u[1] - (pts[:, 1] - c[1]) * u[0])
    return (d > tol).mean() <= 0.1


def segment_samples(a, ab, L, h):
    """Points every h (at most) along each segment, both ends included, and the index of
    the segment of each point."""
    n = np.ceil(L / h).astype(np.int64) + 1
    owner = np.repeat(np.arange(len(L)), n)
    k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    t = k / (n[owner] - 1).clip(min=1)
    return a[owner] + t[:, None] * ab[owner], owner


def point_segment_distance(pts, segs, chunk=8192, return_index=False):
    """Distance (N) from each point to the nearest of the segments (M x 4); with
    return_index, also that segment's index (the lowest one among equally near segments).

    Exact, and fast however long the segments: each segment is sampled every h (the mean
    segment length), so any point of a segment lies within h/2 of a sample; the segments
    that may be nearest to a point q are those with a sample within d_n + h/2 of q, d_n
    being q's distance to the nearest sample; the exact distance is taken over those."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    if len(segs) == 0:
        d = np.full(len(pts), np.inf)
        return (d, np.full(len(pts), -1)) if return_index else d
    segs = np.asarray(segs, dtype=float)
    a, b = segs[:, 0:2], segs[:, 2:4]
    ab = b - a
    ll = np.maximum((ab ** 2).sum(axis=1), 1e-18)
    L = np.sqrt((ab ** 2).sum(axis=1))
    h = max(float(L.mean()), 1e-9)
    spts, owner = segment_samples(a, ab, L, h)
    tree = cKDTree(spts)
    slack = h / 2 * (1 + 1e-9) + 1e-12
    out = np.empty(len(pts))
    arg = np.empty(len(pts), dtype=np.int64)
    for k in range(0, len(pts), chunk):
        q = pts[k:k + chunk]
        dn, _ = tree.query(q)
        lists = tree.query_ball_point(q, dn + slack)
        cnt = np.fromiter((len(x) for x in lists), dtype=np.int64, count=len(lists))
        pi = np.repeat(np.arange(len(q)), cnt)
        si = owner[np.fromiter((j for x in lists for j in x), dtype=np.int64, count=int(cnt.sum()))]
        # one (point, segment) pair each: a segment has several samples near a point
        key = np.unique(pi * len(segs) + si)
        pi, si = key // len(segs), key % len(segs)
        ap = q[pi] - a[si]
        t = np.clip((ap * ab[si]).sum(axis=1) / ll[si], 0.0, 1.0)
        dv = ap - t[:, None] * ab[si]
        dd = np.sqrt((dv ** 2).sum(axis=1))
        # pairs are sorted by point, then segment: the first minimum of each point
        order = np.lexsort((si, dd, pi))
        first = np.ones(len(order), dtype=bool)
        first[1:] = pi[order][1:] != pi[order][:-1]
        sel = order[first]
        out[k:k + chunk] = dd[sel]
        arg[k:k + chunk] = si[sel]
    return (out, arg) if return_index else out


def fit_metrics(grid, segs, min_cells=None):
    """RMS distance (m) of the occupied cell centres to the nearest segment, the share of them
    within one cell (grid.resolution) of a segment, and the cell count. With min_cells, the
    same over the cells outside specks (components of fewer cells) as *_kept."""
    pts = grid.occupied_centres()
    if len(pts) == 0:
        raise ValueError("the grid has no occupied cell: no fit to report")
    if len(segs) == 0:
        return dict(rms_m=float("inf"), within_one_cell=0.0, cells=len(pts))
    d = point_segment_distance(pts, np.asarray(segs, dtype=float))
    tol = grid.resolution + 1e-4  # + the odomap files' 0.1 mm rounding
    out = dict(rms_m=float(np.sqrt((d ** 2).mean())), within_one_cell=float((d <= tol).mean()),
               cells=int(len(pts)))
    if min_cells is not None:
        kept, _ = drop_specks(grid.occ, min_cells)
        r, c = np.nonzero(grid.occ)
        k = kept[r, c]
        if k.any():
            out.update(rms_m_kept=float(np.sqrt((d[k] ** 2).mean())),
                       within_one_cell_kept=float((d[k] <= tol).mean()), cells_kept=int(k.sum()))
    return out
