"""extract.py: line segments from the occupied cells of an occupancy grid.

Method (`skeleton`, the default; docs/map-format.md):
 1. specks: 8-connected components of occupied cells with fewer than `min_cells` cells are
    dropped (lone cells from a laser's stray return, dust, a person walking by);
 2. thinning: the occupied cells are thinned to a one-cell-wide skeleton (Zhang-Suen), so a
    wall two or three cells thick gives ONE centre line, not its two contours;
 3. tracing: the skeleton is cut into chains of cells between end points and junctions
    (cells whose crossing number is not 2); branches shorter than `spur_cells` that end
    free at one side (thinning spurs at corners) are dropped;
 4. split-and-merge: each chain is split recursively at its farthest cell from the chord
    while that distance exceeds `tol_cells`; each piece is refitted by total least squares
    (the line through its cells' centroid along their principal axis), its end points
    being its first and last cell projected on that line;
 5. merge: segments whose end points lie within `merge_gap_cells` of each other, at less
    than 15 deg (or either shorter than 3 cells), are merged when one line fits their cells
    (all within 2 `tol_cells`, 90 % within `tol_cells`) (this joins the pieces a junction or a drop-out cut).
Alternative (`ransac`, kept for the measured comparison): sequential RANSAC over the
occupied cell centres (after step 1), a line's inliers cut at gaps into runs, the
longest run kept as a segment and its cells removed; then the same merge (step 5).

fit_metrics(): RMS distance of ALL occupied cell centres (specks included) to their nearest
segment, and the share of them within one cell of a segment.
"""

import math
import time

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

DEFAULTS = dict(min_cells=4, spur_cells=3, tol_cells=1.0, merge_gap_cells=2.0, min_points=2, hole_cells=4,
                snap_cells=2.5, bridge_cells=8.0, closing=False)
_OFFS = ((-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1))  # P2..P9 clockwise
_EIGHT = np.ones((3, 3), dtype=bool)


def drop_specks(occ, min_cells):
    """occ without its 8-connected components of fewer than min_cells cells; and how many
    cells were dropped."""
    lab, n = ndimage.label(occ, structure=_EIGHT)
    if n == 0:
        return occ.copy(), 0
    sizes = np.bincount(lab.ravel())
    keep = sizes >= min_cells
    keep[0] = False
    out = keep[lab]
    return out, int(occ.sum() - out.sum())


def _neighbours(p):
    """The eight neighbour planes P2..P9 of a padded boolean image p (interior view)."""
    h, w = p.shape[0] - 2, p.shape[1] - 2
    return [p[1 + dr:1 + dr + h, 1 + dc:1 + dc + w] for dr, dc in _OFFS]


def thin(mask):
    """Zhang-Suen thinning (Comm. ACM 27(3), 1984) of a boolean image; components that
    would vanish entirely (2x2 blocks) keep one cell."""
    img = np.pad(mask.astype(bool), 1)
    while True:
        changed = False
        for step in (0, 1):
            core = img[1:-1, 1:-1]
            n = [v.astype(np.int8) for v in _neighbours(img)]
            b = sum(n)
            a = sum(((n[i] == 0) & (n[(i + 1) % 8] == 1)).astype(np.int8) for i in range(8))
            p2, p4, p6, p8 = n[0], n[2], n[4], n[6]
            if step == 0:
                c = (p2 * p4 * p6 == 0) & (p4 * p6 * p8 == 0)
            else:
                c = (p2 * p4 * p8 == 0) & (p2 * p6 * p8 == 0)
            rm = core & (b >= 2) & (b <= 6) & (a == 1) & c
            if rm.any():
                core[rm] = False
                changed = True
        if not changed:
            break
    sk = img[1:-1, 1:-1]
    lab, n = ndimage.label(mask, structure=_EIGHT)
    if n:
        present = np.zeros(n + 1, dtype=bool)
        present[lab[sk]] = True
        for k in np.nonzero(~present[1:])[0] + 1:
            r, c = np.argwhere(lab == k)[0]
            sk[r, c] = True
    return sk


def trace_chains(sk, spur_cells):
    """The skeleton as ordered chains of (row, col) cells between nodes (crossing number != 2)."""
    p = np.pad(sk, 1)
    n = [v.astype(np.int8) for v in _neighbours(p)]
    cross = sum(((n[i] == 0) & (n[(i + 1) % 8] == 1)).astype(np.int8) for i in range(8))
    is_node = sk & (cross != 2)
    cells = set(map(tuple, np.argwhere(sk)))
    nodes = set(map(tuple, np.argwhere(is_node)))
    visited = set()

    def nbrs(c):
        r, q = c
        four = [(r + dr, q + dc) for dr, dc in ((-1, 0), (0, 1), (1, 0), (0, -1))]
        diag = [(r + dr, q + dc) for dr, dc in ((-1, 1), (1, 1), (1, -1), (-1, -1))]
        return [x for x in four + diag if x in cells]

    def walk(start, first):
        chain = [start, first]
        prev, cur = start, first
        visited.add(first)
        while cur not in nodes:
            nxt = [x for x in nbrs(cur) if x != prev and x != start and (x in nodes or x not in visited)]
            if not nxt:
                # a loop closes on its start, or a dead end
                if start not in nodes and start in nbrs(cur) and len(chain) > 3:
                    chain.append(start)
                break
            nodes_first = [x for x in nxt if x in nodes]
            prev, cur = cur, (nodes_first[0] if nodes_first else nxt[0])
            chain.append(cur)
            if cur not in nodes:
                visited.add(cur)
        return chain

    chains = []
    seen_pairs = set()
    for nd in sorted(nodes):
        for m in nbrs(nd):
            if m in nodes:
                if (m, nd) not in seen_pairs:
                    seen_pairs.add((nd, m))
                    chains.append([nd, m])
            elif m not in visited:
                chains.append(walk(nd, m))
        if not nbrs(nd):
            chains.append([nd])
    for c in sorted(cells - nodes - visited):  # closed loops with no node
        if c in visited:
            continue
        visited.add(c)
        nb = [x for x in nbrs(c) if x not in visited]
        if nb:
            chains.append(walk(c, nb[0]))
        else:
            chains.append([c])
    # spurs: short branches with a free end and a junction at the other
    deg = {}
    for ch in chains:
        for e in (ch[0], ch[-1]):
            deg[e] = deg.get(e, 0) + 1
    out = []
    for ch in chains:
        a, b = ch[0], ch[-1]
        free_end = deg[a] == 1 or deg[b] == 1
        junction = deg[a] >= 3 or deg[b] >= 3
        if free_end and junction and len(ch) < spur_cells:
            continue
        out.append(ch)
    return out


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


def _segment_from(pts):
    c, u, _ = tls_fit(pts)
    t = (pts - c) @ u
    return np.concatenate([c + t.min() * u, c + t.max() * u])


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


def _fits(pts, tol):
    """One line fits the points: none farther than 2 tol from it, at most 1 in 10 farther
    than tol (a short jog round a drop-out does not keep two pieces of a wall apart)."""
    c, u, dmax = tls_fit(pts)
    if dmax <= tol:
        return True
    if dmax > 2 * tol:
        return False
    d = np.abs((pts[:, 0] - c[0]) * u[1] - (pts[:, 1] - c[1]) * u[0])
    return (d > tol).mean() <= 0.1


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
            if not _fits(pts, tol):
                continue
            segs[i] = _segment_from(pts)
            pts_list[i] = pts
            alive[j] = False
            merged = True
        if not merged:
            break
    keep = [i for i in range(len(segs)) if alive[i]]
    return [segs[i] for i in keep], [pts_list[i] for i in keep]


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
            if not _fits(pts, tol) or not on_wall(ea, eb):
                continue
            segs[i] = _segment_from(pts)
            pts_list[i] = pts
            alive[j] = False
            joined.append(i)
        if not joined:
            break
        for i in joined:
            if not alive[i]:
                continue
            a, b = segs[i][0:2], segs[i][2:4]
            for k in range(len(segs)):
                if k == i or not alive[k]:
                    continue
                sk = segs[k]
                if np.hypot(sk[2] - sk[0], sk[3] - sk[1]) >= short:
                    continue
                d = point_segment_distance(sk.reshape(2, 2), np.array([np.concatenate([a, b])]))
                if d.max() <= 2 * tol:
                    alive[k] = False
    keep = [i for i in range(len(segs)) if alive[i]]
    return [segs[i] for i in keep], [pts_list[i] for i in keep]


def close_small_gaps(occ, hole_cells, closing=False):
    """occ with its holes of at most hole_cells cells filled (4-connected pockets of
    non-occupied cells not touching the border): a wall with drop-outs then thins to one
    line instead of loops round each hole. With closing, first a morphological closing by
    a 3 x 3 square (bridges one-cell gaps; measured worse on the Intel grid, where it fuses
    clutter with walls: off by default)."""
    closed = occ.copy()
    if closing:
        closed |= ndimage.binary_closing(np.pad(occ, 2), structure=_EIGHT)[2:-2, 2:-2]
    if hole_cells <= 0:
        return closed
    lab, n = ndimage.label(~closed)
    if n:
        sizes = np.bincount(lab.ravel())
        border = np.unique(np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]]))
        small = sizes <= hole_cells
        small[0] = False
        small[border] = False
        closed |= small[lab]
    return closed


def snap_junctions(segs, reach):
    """Extends or trims each segment end to where its line meets another segment's line, when
    that point lies within `reach` of the end and on (or within reach of) the other segment,
    at more than 20 deg: the corners and T-junctions that thinning and tracing leave open."""
    segs = [np.array(s, dtype=float) for s in segs]
    if len(segs) < 2:
        return segs
    mids = np.array([(s[0:2] + s[2:4]) / 2 for s in segs])
    half = max(np.hypot(s[2] - s[0], s[3] - s[1]) for s in segs) / 2
    tree = cKDTree(mids)
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
            for j in tree.query_ball_point(e, half + reach):
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


def extract_skeleton(occ, p):
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
            segs.append(_segment_from(piece))
            pts_list.append(piece)
    segs, pts_list = merge(segs, pts_list, p["tol_cells"], p["merge_gap_cells"])
    segs, pts_list = bridge(segs, pts_list, kept, p["tol_cells"], p["bridge_cells"])
    segs = refit_to_cells(segs, kept)
    segs = snap_junctions(segs, p["snap_cells"])
    segs = [s for s in segs if np.hypot(s[2] - s[0], s[3] - s[1]) > 1e-9]
    return segs, dict(dropped_cells=dropped, skeleton_cells=int(sk.sum()), chains=len(chains))


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
        segs.append(_segment_from(piece))
        pts_list.append(piece)
        remaining[best] = False
    segs, pts_list = merge(segs, pts_list, p["tol_cells"], gap)
    return segs, dict(dropped_cells=dropped, unexplained_cells=int(remaining.sum()))


METHODS = {"skeleton": extract_skeleton, "ransac": extract_ransac}


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
    segs, stats = METHODS[method](grid.occ, p)
    secs = time.perf_counter() - t0
    s = np.array(segs, dtype=float).reshape(-1, 4)
    x1, y1 = grid.to_world(s[:, 0], s[:, 1])
    x2, y2 = grid.to_world(s[:, 2], s[:, 3])
    stats.update(method=method, seconds=secs, occupied_cells=int(grid.occ.sum()), params=p)
    return np.column_stack([x1, y1, x2, y2]), stats


def point_segment_distance(pts, segs, chunk=4096, return_index=False):
    """Distance (N) from each point to the nearest of the segments (M x 4); with
    return_index, also that segment's index."""
    if len(segs) == 0:
        d = np.full(len(pts), np.inf)
        return (d, np.full(len(pts), -1)) if return_index else d
    a, b = segs[:, 0:2], segs[:, 2:4]
    ab = b - a
    ll = np.maximum((ab ** 2).sum(axis=1), 1e-18)
    tree = cKDTree((a + b) / 2)
    half = float(np.sqrt(ll).max()) / 2
    out = np.empty(len(pts))
    arg = np.empty(len(pts), dtype=int)
    for k in range(0, len(pts), chunk):
        q = pts[k:k + chunk]
        # candidates: segments whose midpoint lies within (nearest midpoint distance + half
        # the longest segment); exact, because a segment lies within half its length of its midpoint
        dmid, _ = tree.query(q)
        best = np.full(len(q), np.inf)
        besti = np.full(len(q), -1)
        cand = tree.query_ball_point(q, dmid + half)
        for i, cs in enumerate(cand):
            cs = np.asarray(cs, dtype=int)
            ap = q[i] - a[cs]
            t = np.clip((ap * ab[cs]).sum(axis=1) / ll[cs], 0.0, 1.0)
            d = ap - t[:, None] * ab[cs]
            dd = np.sqrt((d ** 2).sum(axis=1))
            m = int(np.argmin(dd))
            best[i], besti[i] = dd[m], cs[m]
        out[k:k + chunk] = best
        arg[k:k + chunk] = besti
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
