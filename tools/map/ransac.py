"""ransac.py: the sequential-RANSAC alternative to the skeleton method, kept for the
measured comparison (docs/map-format.md). Segments in cell units."""

import math

import numpy as np
from scipy.spatial import cKDTree

from segfit import drop_specks, segment_from


def extract_ransac(occ, p, seed=1, iters=60, radius_cells=60.0, min_inliers=5):
    """The sequential-RANSAC alternative (module docstring); segments in cell units."""
    rng = np.random.default_rng(seed)
    kept, dropped = drop_specks(occ, p["min_cells"])
    r, c = np.nonzero(kept)
    pts = np.column_stack([c + 0.5, r + 0.5]).astype(float)
    tree = cKDTree(pts)
    remaining = np.ones(len(pts), dtype=bool)
    tol, gap = 0.5 * p["tol_cells"] + 0.25, p["merge_gap_cells"]
    segs, pts_list, fails = [], [], 0
    while remaining.sum() >= min_inliers and fails < 200:
        rem_idx = np.nonzero(remaining)[0]
        seed_i = rem_idx[rng.integers(len(rem_idx))]
        near = np.array(tree.query_ball_point(pts[seed_i], radius_cells), dtype=int)
        near = near[remaining[near]]
        if len(near) < min_inliers:
            remaining[seed_i] = False
            continue
        best = None
        for _ in range(iters):
            j = near[rng.integers(len(near))]
            d = pts[j] - pts[seed_i]
            L = math.hypot(d[0], d[1])
            if L < 1.0:
                continue
            nrm = np.array([-d[1], d[0]]) / L
            dist = np.abs((pts[near] - pts[seed_i]) @ nrm)
            inl = near[dist <= tol]
            t = (pts[inl] - pts[seed_i]) @ (d / L)
            order = np.argsort(t)
            ts, inl = t[order], inl[order]
            cuts = np.nonzero(np.diff(ts) > gap)[0]
            starts = np.concatenate([[0], cuts + 1])
            stops = np.concatenate([cuts + 1, [len(ts)]])
            k = int(np.argmax(stops - starts))
            run = inl[starts[k]:stops[k]]
            if best is None or len(run) > len(best):
                best = run
        if best is None or len(best) < min_inliers:
            fails += 1
            continue
        fails = 0
        piece = pts[best]
        segs.append(segment_from(piece))
        pts_list.append(piece)
        remaining[best] = False
    from extract import merge  # noqa: E402 (extract imports this module lazily)
    segs, pts_list = merge(segs, pts_list, p["tol_cells"], gap)
    return segs, dict(dropped_cells=dropped, unexplained_cells=int(remaining.sum()))
