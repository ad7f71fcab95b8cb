"""extract.py: line segments from the occupied cells of an occupancy grid.

Method `skeleton` (the default; docs/map-format.md gives the reasons and the measurements);
lengths in cells, parameters in DEFAULTS:
 1. specks: 8-connected components of fewer than `min_cells` cells are dropped (segfit.py);
 2. holes of at most `hole_cells` cells inside walls are filled (skeleton.py);
 3. Zhang-Suen thinning to a one-cell-wide skeleton: one centre line per wall band;
 4. tracing into chains between end points and junctions; short spurs dropped;
 5. split: each chain split recursively at its farthest cell from the chord while that
    exceeds `tol_cells`; pieces fitted by total least squares;
 6. merge: pieces whose ends are within `merge_gap_cells` merged when one line fits them;
 7. bridge: collinear pieces up to `bridge_cells` apart joined when the gap is covered by
    occupied cells (never across a doorway);
 8. refit: each segment refitted to the occupied cells nearest to it, its extent grown to
    cover them;
 9. junctions: ends moved to where their line meets another within `snap_cells`.
Method `ransac` (ransac.py): the measured alternative. Segments come out in world metres;
fit_metrics (segfit.py) gives the RMS distance of the occupied cells to the segments and the
share within one cell.
"""

import math
import time

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from segfit import (drop_specks, fit_metrics, fits, point_segment_distance, segment_from, segment_samples,  # noqa: F401
                    tls_fit)
from skeleton import close_small_gaps, thin, trace_chains

DEFAULTS = dict(min_cells=4, spur_cells=3, tol_cells=1.0, merge_gap_cells=2.0, min_points=2, hole_cells=4,
                snap_cells=2.5, bridge_cells=8.0, closing=False, faces=False)


def split(pts, tol):
    """Recursive split of an ordered point chain; a list of index ranges [i, j] (inclusive)."""
    out, stack = [], [(0, len(pts) - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            out.append((i, j))
            continue
        a, b = pts[i], pts[j]
        ab = b - a
        L = math.hypot(ab[0], ab[1])
        seg = pts[i + 1:j] - a
        if L < 1e-9:
            d = np.hypot(seg[:, 0], seg[:, 1])
        else:
            d = np.abs(seg[:, 0] * ab[1] - seg[:, 1] * ab[0]) / L
        k = int(np.argmax(d))
        if d[k] > tol:
            stack.append((i + 1 + k, j))
            stack.append((i, i + 1 + k))
        else:
            out.append((i, j))
    return sorted(out)


def merge(segs, pts_list, tol, gap, max_angle_deg=15.0):
    """Merges segments end to end (see the module docstring, step 5). Lengths in cells."""
    alive = [True] * len(segs)
    segs, pts_list = list(segs), list(pts_list)
    cos_max = math.cos(math.radians(max_angle_deg))
    for _ in range(20):
        idx = [i for i in range(len(segs)) if alive[i]]
        if len(idx) < 2:
            break
        ends = np.array([segs[i][0:2] for i in idx] + [segs[i][2:4] for i in idx])
        owner = idx + idx
        tree = cKDTree(ends)
        pairs = sorted(tree.query_pairs(gap, output_type="ndarray").tolist(),
                       key=lambda pq: np.hypot(*(ends[pq[0]] - ends[pq[1]])))
        merged = False
        for p, q in pairs:
            i, j = owner[p], owner[q]
            if i == j or not (alive[i] and alive[j]):
                continue
            di = segs[i][2:4] - segs[i][0:2]
            dj = segs[j][2:4] - segs[j][0:2]
            ni, nj = np.hypot(*di), np.hypot(*dj)
            # the angle pre-filter only between segments long enough to have a direction
            if min(ni, nj) > 3.0 and abs(di @ dj) / (ni * nj) < cos_max:
                continue
            pts = np.vstack([pts_list[i], pts_list[j]])
            if not fits(pts, tol):
                continue
            segs[i] = segment_from(pts)
            pts_list[i] = pts
            alive[j] = False
            merged = True
        if not merged:
            break
    keep = [i for i in range(len(segs)) if alive[i]]
    return [segs[i] for i in keep], [pts_list[i] for i in keep]


def _distance_to(pts, seg):
    """Distance from each point (N x 2) to one segment (x1, y1, x2, y2)."""
    a, ab = seg[0:2], seg[2:4] - seg[0:2]
    ap = pts - a
    t = np.clip((ap * ab).sum(axis=1) / max((ab ** 2).sum(), 1e-18), 0.0, 1.0)
    d = ap - t[:, None] * ab
    return np.sqrt((d ** 2).sum(axis=1))


def bridge(segs, pts_list, occ, tol, max_gap, max_angle_deg=10.0, covered=1.5, short=4.0):
    """Joins two collinear segments (at less than max_angle_deg when both are `short` cells
    or longer; else one line must fit both) across a gap of up to max_gap cells when the gap is NOT
    free space: every point of the bridge (every half cell) lies within `covered` cells of an
    occupied cell (a wall with a wobble round drop-outs, which split-and-merge cut into a
    jog). Segments shorter than `short` cells whose both ends lie within 2 tol of the joined
    segment (the jog itself) are then dropped. A doorway (free cells) is never bridged."""
    if len(segs) < 2:
        return segs, pts_list
    dist_occ = ndimage.distance_transform_edt(~occ)
    rows, cols = occ.shape
    cos_max = math.cos(math.radians(max_angle_deg))
    segs, pts_list = [np.array(x, dtype=float) for x in segs], list(pts_list)
    alive = [True] * len(segs)

    def on_wall(a, b):
        n = max(int(np.ceil(2 * np.hypot(*(b - a)))), 1)
        t = np.linspace(0, 1, n + 1)
        q = a[None, :] + t[:, None] * (b - a)[None, :]
        c = np.clip(q[:, 0].astype(int), 0, cols - 1)
        r = np.clip(q[:, 1].astype(int), 0, rows - 1)
        return bool(np.all(dist_occ[r, c] <= covered))

    for _ in range(10):
        idx = [i for i in range(len(segs)) if alive[i]]
        ends = np.array([segs[i][0:2] for i in idx] + [segs[i][2:4] for i in idx])
        owner = idx + idx
        which = [0] * len(idx) + [1] * len(idx)
        pairs = sorted(cKDTree(ends).query_pairs(max_gap, output_type="ndarray").tolist(),
                       key=lambda pq: np.hypot(*(ends[pq[0]] - ends[pq[1]])))
        joined = []
        for p, q in pairs:
            i, j = owner[p], owner[q]
            if i == j or not (alive[i] and alive[j]):
                continue
            di, dj = segs[i][2:4] - segs[i][0:2], segs[j][2:4] - segs[j][0:2]
            ni, nj = np.hypot(*di), np.hypot(*dj)
            if ni == 0 or nj == 0 or (min(ni, nj) >= short and abs(di @ dj) / (ni * nj) < cos_max):
                continue
            ea = segs[i][0:2] if which[p] == 0 else segs[i][2:4]
            eb = segs[j][0:2] if which[q] == 0 else segs[j][2:4]
            pts = np.vstack([pts_list[i], pts_list[j]])
            if not fits(pts, tol) or not on_wall(ea, eb):
                continue
            segs[i] = segment_from(pts)
            pts_list[i] = pts
            alive[j] = False
            joined.append(i)
        if not joined:
            break
        # the jogs under each joined segment, all short segments at once (a long corridor
        # joins hundreds of pieces among thousands of segments)
        S = np.array(segs)
        is_short = np.hypot(S[:, 2] - S[:, 0], S[:, 3] - S[:, 1]) < short
        for i in joined:
            if not alive[i]:
                continue
            cand = np.flatnonzero(is_short & np.array(alive))
            cand = cand[cand != i]
            if len(cand) == 0:
                continue
            d = np.maximum(_distance_to(S[cand, 0:2], S[i]), _distance_to(S[cand, 2:4], S[i]))
            for k in cand[d <= 2 * tol]:
                alive[k] = False
    keep = [i for i in range(len(segs)) if alive[i]]
    return [segs[i] for i in keep], [pts_list[i] for i in keep]


def snap_junctions(segs, reach):
    """Extends or trims each segment end to where its line meets another segment's line, when
    that point lies within `reach` of the end and on (or within reach of) the other segment,
    at more than 20 deg: the corners and T-junctions that thinning and tracing leave open."""
    segs = [np.array(s, dtype=float) for s in segs]
    if len(segs) < 2:
        return segs
    # the candidates for an end e: the new end x lies within reach of e and on the other
    # segment's line within reach of its extent, so e lies within 2 reach of that segment:
    # the segments with a point sampled every `reach` along them within 2.5 reach of e
    S = np.array(segs)
    ab = S[:, 2:4] - S[:, 0:2]
    spts, owner = segment_samples(S[:, 0:2], ab, np.hypot(ab[:, 0], ab[:, 1]), reach)
    tree = cKDTree(spts)
    orig = [s.copy() for s in segs]
    for i, s in enumerate(orig):
        d = s[2:4] - s[0:2]
        L = np.hypot(*d)
        if L == 0:
            continue
        u = d / L
        for end in (0, 1):
            e = s[0:2] if end == 0 else s[2:4]
            best = None
            for j in np.unique(owner[tree.query_ball_point(e, 2.5 * reach)]):
                if j == i:
                    continue
                o = orig[j]
                od = o[2:4] - o[0:2]
                oL = np.hypot(*od)
                if oL == 0:
                    continue
                v = od / oL
                cross = u[0] * v[1] - u[1] * v[0]
                if abs(cross) < math.sin(math.radians(20)):
                    continue
                w = o[0:2] - s[0:2]
                t = (w[0] * v[1] - w[1] * v[0]) / cross     # along s (m from its start)
                tv = (w[0] * u[1] - w[1] * u[0]) / cross    # along o
                x = s[0:2] + t * u
                if np.hypot(*(x - e)) > reach or tv < -reach or tv > oL + reach:
                    continue
                # only the end's side: the new end must stay on the far side of the start
                if (end == 1 and t <= 0) or (end == 0 and t >= L):
                    continue
                dist = np.hypot(*(x - e))
                if best is None or dist < best[0]:
                    best = (dist, x)
            if best is not None:
                if end == 0:
                    segs[i][0:2] = best[1]
                else:
                    segs[i][2:4] = best[1]
    return segs


def refit_to_cells(segs, occ, reach=1.5, margin=2.0, min_cells=5):
    """Each segment refitted to the occupied cells it is nearest to (within `reach` cells):
    its line by total least squares over those cells, leaving out the ones within `margin`
    cells of its ends (where a crossing wall's cells lie), and its extent grown to cover
    them all (thinning shortens free ends by a cell or so). Segments with fewer than
    min_cells such cells keep their line. In cell units, like the segments."""
    if not segs:
        return segs
    r, c = np.nonzero(occ)
    pts = np.column_stack([c + 0.5, r + 0.5]).astype(float)
    S = np.array(segs, dtype=float)
    d, idx = point_segment_distance(pts, S, return_index=True)
    near = d <= reach
    order = np.argsort(idx[near], kind="stable")
    ids, starts = np.unique(idx[near][order], return_index=True)
    groups = np.split(pts[near][order], starts[1:])
    out = [s.copy() for s in S]
    for i, g in zip(ids, groups):
        s = S[i]
        a, b = s[0:2], s[2:4]
        L = np.hypot(*(b - a))
        if L == 0:
            continue
        u = (b - a) / L
        t = (g - a) @ u
        core = g[(t > margin) & (t < L - margin)]
        if len(core) >= min_cells:
            cen, v, _ = tls_fit(core)
            if v @ u < 0:
                v = -v
        else:
            cen, v = a, u
        ta, tb = (a - cen) @ v, (b - cen) @ v
        tg = (g - cen) @ v
        lo, hi = min(ta, tg.min()), max(tb, tg.max())
        out[i] = np.concatenate([cen + lo * v, cen + hi * v])
    return out


def to_faces(segs, occ, free, min_sep=2.5, reach=3.0, max_shift=2.0):
    """Moves each segment from the middle of its band of occupied cells to the band's face:
    the free-facing cells (occupied cells with a free 4-neighbour), where the laser's returns
    are. In a grid built from laser returns the cells in front of a surface are cleared by
    the beams that pass through them, while returns scattered beyond it pile up behind: the
    band's middle lies about half a band behind the surface (measured on the Intel grid:
    docs/map-format.md). For each segment, the free-facing cells nearest to it (within
    `reach`) are sorted by the side their free neighbour is on:
    - one side only (at least 30 % of its length in cells, and 3): the segment is moved
      parallel to the median offset of those cells (at most max_shift cells);
    - both sides, their medians at least min_sep cells apart (a wall seen from both sides):
      two segments, one on each face;
    - else it stays. In cell units."""
    if not segs:
        return segs
    four = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], dtype=bool)
    rows, cols = occ.shape
    facing = occ & ndimage.binary_dilation(free, structure=four)
    r, c = np.nonzero(facing)
    pts = np.column_stack([c + 0.5, r + 0.5]).astype(float)
    S = np.array(segs, dtype=float)
    d, idx = point_segment_distance(pts, S, return_index=True)
    out = []
    for i, s in enumerate(S):
        a, b = s[0:2], s[2:4]
        L = np.hypot(*(b - a))
        sel = (idx == i) & (d <= reach)
        if L < 4 or sel.sum() < 6:
            out.append(s)
            continue
        u = (b - a) / L
        n = np.array([-u[1], u[0]])
        q = pts[sel]
        off = (q - a) @ n
        # which side the free neighbour is on: sample free one cell further out each way
        side = []
        for k, p0 in enumerate(q):
            ahead = p0 + n
            back = p0 - n
            fa = free[min(max(int(ahead[1]), 0), rows - 1), min(max(int(ahead[0]), 0), cols - 1)]
            fb = free[min(max(int(back[1]), 0), rows - 1), min(max(int(back[0]), 0), cols - 1)]
            side.append(1 if fa and not fb else (-1 if fb and not fa else 0))
        side = np.array(side)
        plus, minus = off[side > 0], off[side < 0]
        need = max(3, int(0.3 * L))
        has_p, has_m = len(plus) >= need, len(minus) >= need
        if has_p and has_m:
            if np.median(plus) - np.median(minus) >= min_sep:
                for o in (np.median(plus), np.median(minus)):
                    out.append(np.concatenate([a + o * n, b + o * n]))
            else:
                out.append(s)
        elif has_p or has_m:
            o = float(np.clip(np.median(plus if has_p else minus), -max_shift, max_shift))
            out.append(np.concatenate([a + o * n, b + o * n]))
        else:
            out.append(s)
    return out


def extract_skeleton(occ, p, free=None):
    """Segments in cell units (x = col + 0.5, y = row + 0.5), and statistics."""
    kept, dropped = drop_specks(occ, p["min_cells"])
    sk = thin(close_small_gaps(kept, p["hole_cells"], p["closing"]))
    chains = trace_chains(sk, p["spur_cells"])
    segs, pts_list = [], []
    for ch in chains:
        pts = np.array([(c + 0.5, r + 0.5) for r, c in ch], dtype=float)
        for i, j in split(pts, p["tol_cells"]):
            piece = pts[i:j + 1]
            if len(piece) < p["min_points"]:
                continue
            segs.append(segment_from(piece))
            pts_list.append(piece)
    segs, pts_list = merge(segs, pts_list, p["tol_cells"], p["merge_gap_cells"])
    segs, pts_list = bridge(segs, pts_list, kept, p["tol_cells"], p["bridge_cells"])
    segs = refit_to_cells(segs, kept)
    if p["faces"] and free is not None:
        segs = to_faces(segs, kept, free)
    segs = snap_junctions(segs, p["snap_cells"])
    segs = [s for s in segs if np.hypot(s[2] - s[0], s[3] - s[1]) > 1e-9]
    return segs, dict(dropped_cells=dropped, skeleton_cells=int(sk.sum()), chains=len(chains))


def _ransac(occ, p, free=None):
    import ransac
    return ransac.extract_ransac(occ, p)


METHODS = {"skeleton": extract_skeleton, "ransac": _ransac}

# When a grid gives no map (docs/map-format.md, "When import refuses a grid"): measured on
# the five CARMEN buildings, whose grids keep 3 to 32 % of their occupied cells in specks
# and give 150 to 220 segments of 10 cells or more, against 74 and 93 % and 11 and 4 when
# built with the wrong beam step (and the TurtleBot3 map: 0 %, 10 segments).
MAX_SPECK_SHARE = 0.5      # more than half of the occupied cells in specks: a broken-up grid
MIN_LONG_SEGMENTS = 4      # fewer segments of LONG_CELLS or more than a room has walls
LONG_CELLS = 10


def map_problems(grid, segs, stats):
    """Why the segments extracted from grid are not a map (a list of reasons; empty when
    they are): no occupied cell or no segment, more than MAX_SPECK_SHARE of the occupied
    cells in specks, fewer than MIN_LONG_SEGMENTS segments of LONG_CELLS cells or more."""
    occ, specks = stats["occupied_cells"], stats["dropped_cells"]
    if occ == 0:
        return ["the grid has no occupied cell"]
    out = []
    min_cells = stats["params"]["min_cells"]
    if specks > MAX_SPECK_SHARE * occ:
        out.append(f"{specks} of its {occ} occupied cells ({100 * specks / occ:.0f} %, more than "
                   f"{100 * MAX_SPECK_SHARE:.0f} %) are specks (8-connected clusters of fewer than {min_cells} "
                   f"cells): mostly specks, no walls")
    s = np.asarray(segs, dtype=float).reshape(-1, 4)
    cells = np.hypot(s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]) / grid.resolution
    n_long = int((cells >= LONG_CELLS).sum())
    if len(s) == 0:
        out.append("no segment was extracted")
    elif n_long < MIN_LONG_SEGMENTS:
        out.append(f"{n_long} of its {len(s)} segments are {LONG_CELLS} cells ({LONG_CELLS * grid.resolution:g} m) "
                   f"or longer, fewer than {MIN_LONG_SEGMENTS}")
    return out


def extract(grid, method="skeleton", **params):
    """Segments (M x 4 array, world frame, metres) from grid.occ, and statistics (cell
    counts, parameters, run time in seconds)."""
    p = dict(DEFAULTS)
    unknown = set(params) - set(p)
    if unknown:
        raise ValueError(f"unknown extraction parameter(s): {', '.join(sorted(unknown))}")
    p.update(params)
    if method not in METHODS:
        raise ValueError(f"unknown extraction method '{method}' ({', '.join(METHODS)})")
    t0 = time.perf_counter()
    segs, stats = METHODS[method](grid.occ, p, free=grid.free)
    secs = time.perf_counter() - t0
    s = np.array(segs, dtype=float).reshape(-1, 4)
    x1, y1 = grid.to_world(s[:, 0], s[:, 1])
    x2, y2 = grid.to_world(s[:, 2], s[:, 3])
    stats.update(method=method, seconds=secs, occupied_cells=int(grid.occ.sum()), params=p)
    return np.column_stack([x1, y1, x2, y2]), stats
