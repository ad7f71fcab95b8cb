"""skeleton.py: the raster steps of the skeleton method (extract.py): small holes filled,
Zhang-Suen thinning to a one-cell-wide skeleton, the skeleton traced into chains of cells.
Cells are (row, col) pairs of a boolean grid."""

import numpy as np
from scipy import ndimage

from segfit import EIGHT

_OFFS = ((-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1))  # P2..P9 clockwise


def close_small_gaps(occ, hole_cells, closing=False):
    """occ with its holes of at most hole_cells cells filled (4-connected pockets of
    non-occupied cells not touching the border): a wall with drop-outs then thins to one
    line instead of loops round each hole. With closing, first a morphological closing by
    a 3 x 3 square (bridges one-cell gaps; measured worse on the Intel grid, where it fuses
    clutter with walls: off by default)."""
    closed = occ.copy()
    if closing:
        closed |= ndimage.binary_closing(np.pad(occ, 2), structure=EIGHT)[2:-2, 2:-2]
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
    lab, n = ndimage.label(mask, structure=EIGHT)
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
