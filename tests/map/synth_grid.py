"""synth_grid.py: a synthetic occupancy grid with known walls, written as a ROS map
(PGM + YAML) for the map tests.

The building (metres, world frame; origin of the grid at (-1.0, -2.0)): an outer room, two
interior walls with a door gap, a diagonal wall and a short stub. Each wall is drawn with a
thickness of `thick` cells (cells whose centre lies within thick/2 cells of the wall line,
inside its extent); then noise: a share `holes` of the wall cells is erased (laser
drop-outs), and `specks` lone occupied cells are scattered in the free space (stray returns).
Cells inside the outer room are free, outside unknown.
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "map"))
import rosmap  # noqa: E402

WALLS = np.array([
    [0.0, 0.0, 8.0, 0.0],
    [8.0, 0.0, 8.0, 6.0],
    [8.0, 6.0, 0.0, 6.0],
    [0.0, 6.0, 0.0, 0.0],
    [3.0, 0.0, 3.0, 2.2],      # interior wall, door gap 2.2 .. 3.2 m
    [3.0, 3.2, 3.0, 6.0],
    [4.5, 1.0, 7.0, 3.5],      # diagonal (45 deg)
    [5.0, 4.5, 6.5, 4.9],      # a short slanted stub (15 deg), free-standing
])
ORIGIN = (-1.0, -2.0, 0.0)


def render_grid(res=0.05, thick=2.0, holes=0.05, specks=30, seed=1, walls=WALLS):
    rng = np.random.default_rng(seed)
    cols, rows = int(round(10.0 / res)), int(round(10.0 / res))
    c, r = np.meshgrid(np.arange(cols), np.arange(rows))
    x = ORIGIN[0] + (c + 0.5) * res
    y = ORIGIN[1] + (r + 0.5) * res
    occ = np.zeros((rows, cols), dtype=bool)
    for x1, y1, x2, y2 in walls:
        d = np.array([x2 - x1, y2 - y1])
        L = np.hypot(*d)
        u = d / L
        t = (x - x1) * u[0] + (y - y1) * u[1]
        n = np.abs(-(x - x1) * u[1] + (y - y1) * u[0])
        occ |= (n <= thick * res / 2 + 1e-9) & (t >= -thick * res / 2) & (t <= L + thick * res / 2)
    inside = (x > 0) & (x < 8) & (y > 0) & (y < 6)
    free = inside & ~occ
    wall_cells = np.argwhere(occ)
    k = int(holes * len(wall_cells))
    if k:
        drop = wall_cells[rng.choice(len(wall_cells), k, replace=False)]
        occ[drop[:, 0], drop[:, 1]] = False
    # lone specks in the free space, at least 0.5 m from any wall
    far = free.copy()
    from scipy import ndimage
    far &= ~ndimage.binary_dilation(occ, iterations=int(0.5 / res))
    cand = np.argwhere(far)
    if specks:
        sp = cand[rng.choice(len(cand), specks, replace=False)]
        occ[sp[:, 0], sp[:, 1]] = True
    return rosmap.Grid(occ, free & ~occ, res, ORIGIN, source="synthetic")


def write(prefix, **kw):
    g = render_grid(**kw)
    return rosmap.save(g, prefix, "synthetic grid (tests/map/synth_grid.py)")


if __name__ == "__main__":
    print(*write(sys.argv[1]))
