"""carmen_grid.py: an occupancy grid from a SLAM-corrected CARMEN laser log (the Intel lab).

Input: the FLASER lines of the log (../shared/data/carmen/README.md): `FLASER n r1..rn x y
theta odom_x odom_y odom_theta ts host lts`, x y theta being the SLAM-corrected pose. Beam i
(0-based) points at theta + ANGLE_MIN + i * step in the world frame, ANGLE_MIN = -90 deg;
the step is 1 deg by default (180 beams cover -90 .. +89 deg): measured against the
alternative 180/179 deg by `beam_geometry_check` (docs/map-format.md gives the figures).
The laser is taken at the robot's pose (no mount offset is known for this log).

Mapping: log-odds occupancy on a square grid (default 0.05 m). For each scan, the cells a
beam crosses before its return are observed free (once per scan, however many beams cross
them) and the cell of its return is observed occupied:
    l += L_OCC (+0.85, p = 0.70) for a hit, l += L_FREE (-0.40, p = 0.40) for a pass,
clamped to [-L_CLAMP, L_CLAMP] = [-5, 5]. A cell crossed and hit in the same scan counts as
hit. Returns beyond MAX_RANGE (default 20 m) clear the cells up to MAX_RANGE and add no hit;
a beam with no return (81.83 m, or >= 81 m) is not used at all (it clears nothing: no return
may be glass or a dark surface as well as open space). A ray is sampled every half cell, and
clears the cells up to `free_stop` (0.5) cells short of its return.
Output cells as map_saver writes them (trinary): p > 0.65 occupied (0), p < 0.196 free
(254), else or never observed unknown (205).
"""

import math
import os
import sys
import time

import numpy as np

import rosmap

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "import"))
import import_common  # noqa: E402  (tools/import: the importers' shared file helpers)

L_OCC, L_FREE, L_CLAMP = 0.85, -0.40, 5.0
NO_RETURN_M = 81.0
ANGLE_MIN = -math.pi / 2


class LogError(Exception):
    """A malformed log; the message names FILE:LINE."""


def read_scans(path, max_scans=None):
    """The FLASER scans of a CARMEN log: list of (pose (x, y, theta), ranges array, line number)."""
    try:
        data = import_common.read_bytes(path)
    except import_common.InputError as e:
        raise LogError(str(e)) from None
    scans = []
    for no, raw in enumerate(data.split(b"\n"), start=1):
        if not raw.startswith(b"FLASER"):
            continue
        f = raw.split()
        try:
            n = int(f[1])
        except (IndexError, ValueError):
            raise LogError(f"{path}:{no}: FLASER: the beam count is not an integer") from None
        if n <= 0 or len(f) != n + 11:
            raise LogError(f"{path}:{no}: FLASER with {n} beams takes {n + 10} fields, got {len(f) - 1}")
        try:
            vals = np.array([float(v) for v in f[2:n + 5]])
        except ValueError:
            raise LogError(f"{path}:{no}: FLASER: a range or pose field is not a number") from None
        if not np.all(np.isfinite(vals)):
            raise LogError(f"{path}:{no}: FLASER: a range or pose field is not finite")
        if np.any(vals[:n] < 0):
            raise LogError(f"{path}:{no}: FLASER: a negative range")
        scans.append((tuple(vals[n:n + 3]), vals[:n], no))
        if max_scans is not None and len(scans) >= max_scans:
            break
    if not scans:
        raise LogError(f"{path}: no FLASER line: no scan to build a grid from")
    return scans


def _beams(scan, step, max_range):
    (x, y, th), r, _ = scan
    ang = th + ANGLE_MIN + step * np.arange(len(r))
    ret = r < NO_RETURN_M
    hit = ret & (r <= max_range) & (r > 0)
    reach = np.where(hit, r, np.where(ret, max_range, 0.0))
    return x, y, ang, reach, hit


def _extent(scans, step, max_range, res, margin=1.0):
    xs, ys = [], []
    for s in scans:
        x, y, ang, reach, _ = _beams(s, step, max_range)
        xs += [x, *(x + reach * np.cos(ang))]
        ys += [y, *(y + reach * np.sin(ang))]
    x0 = math.floor((min(xs) - margin) / res) * res
    y0 = math.floor((min(ys) - margin) / res) * res
    cols = int(math.ceil((max(xs) + margin - x0) / res))
    rows = int(math.ceil((max(ys) + margin - y0) / res))
    return x0, y0, cols, rows


def build(scans, resolution=0.05, max_range=20.0, step=math.radians(1.0), free_stop=0.5):
    """Log-odds grid (rows x cols float array, row 0 = bottom) and the origin (x0, y0)."""
    x0, y0, cols, rows = _extent(scans, step, max_range, resolution)
    lo = np.zeros(rows * cols)
    t = np.arange(0.0, max_range, resolution / 2)
    for s in scans:
        x, y, ang, reach, hit = _beams(s, step, max_range)
        c, si = np.cos(ang), np.sin(ang)
        # free: samples before the return (half a cell short of it)
        m = t[None, :] < (reach[:, None] - free_stop * resolution)
        px = (x + t[None, :] * c[:, None])[m]
        py = (y + t[None, :] * si[:, None])[m]
        free = np.unique(((py - y0) // resolution).astype(np.int64) * cols + ((px - x0) // resolution).astype(np.int64))
        hx, hy = x + reach[hit] * c[hit], y + reach[hit] * si[hit]
        hits = np.unique(((hy - y0) // resolution).astype(np.int64) * cols + ((hx - x0) // resolution).astype(np.int64))
        free = np.setdiff1d(free, hits, assume_unique=True)
        lo[free] = np.maximum(lo[free] + L_FREE, -L_CLAMP)
        lo[hits] = np.minimum(lo[hits] + L_OCC, L_CLAMP)
    return lo.reshape(rows, cols), (x0, y0)


def to_grid(lo, origin, resolution, source, occupied_thresh=0.65, free_thresh=0.196):
    """A rosmap.Grid from log-odds (never-observed cells, l == 0 exactly, are unknown)."""
    p = 1.0 - 1.0 / (1.0 + np.exp(lo))
    seen = lo != 0
    return rosmap.Grid(seen & (p > occupied_thresh), seen & (p < free_thresh), resolution,
                       (origin[0], origin[1], 0.0), source=source)


def endpoint_share(scans, grid, step, max_range):
    """Share of the beam returns (<= max_range) that land in an occupied cell, and within one
    cell of one (3 x 3 neighbourhood)."""
    from scipy import ndimage
    near = ndimage.binary_dilation(grid.occ, structure=np.ones((3, 3), dtype=bool))
    x0, y0, _ = grid.origin
    rows, cols = grid.shape
    n = on = nb = 0
    for s in scans:
        x, y, ang, reach, hit = _beams(s, step, max_range)
        hx, hy = x + reach[hit] * np.cos(ang[hit]), y + reach[hit] * np.sin(ang[hit])
        ci = ((hx - x0) // grid.resolution).astype(int)
        ri = ((hy - y0) // grid.resolution).astype(int)
        ok = (ci >= 0) & (ci < cols) & (ri >= 0) & (ri < rows)
        n += int(hit.sum())
        on += int(grid.occ[ri[ok], ci[ok]].sum())
        nb += int(near[ri[ok], ci[ok]].sum())
    if n == 0:
        raise ValueError("no beam return within range: no endpoint share to report")
    return on / n, nb / n


def beam_geometry_check(scans, resolution=0.05, max_range=20.0):
    """For the two readings of '180 beams over 180 deg' (step 1 deg, or 180/179 deg so that the
    last beam is at +90 deg): the grid's occupied cell count (a sharper map has fewer) and the
    share of returns on / within one cell of an occupied cell (a consistent map has more)."""
    out = []
    for name, step in (("1 deg", math.radians(1.0)), ("180/179 deg", math.pi / 179)):
        lo, org = build(scans, resolution, max_range, step)
        g = to_grid(lo, org, resolution, "")
        on, nb = endpoint_share(scans, g, step, max_range)
        out.append(dict(step=name, occupied_cells=int(g.occ.sum()), returns_on_occupied=on,
                        returns_within_one_cell=nb))
    return out


def grid_from_log(path, out_prefix, resolution=0.05, max_range=20.0, max_scans=None,
                  step_deg=1.0):
    """Builds and writes OUT_PREFIX.pgm/.yaml; returns the Grid and statistics."""
    if resolution <= 0 or max_range <= 0:
        raise ValueError("resolution and max range must be > 0")
    t0 = time.perf_counter()
    scans = read_scans(path, max_scans)
    lo, org = build(scans, resolution, max_range, math.radians(step_deg))
    g = to_grid(lo, org, resolution, os.path.abspath(path))
    comment = (f"odoerr map grid-from-carmen {os.path.basename(path)}: {len(scans)} scans, "
               f"{resolution:g} m, max range {max_range:g} m, beam step {step_deg:g} deg")
    pgm, yml = rosmap.save(g, out_prefix, comment)
    stats = dict(scans=len(scans), rows=g.shape[0], cols=g.shape[1], occupied=int(g.occ.sum()),
                 free=int(g.free.sum()), unknown=int(g.unknown.sum()), seconds=time.perf_counter() - t0,
                 pgm=pgm, yaml=yml)
    return g, stats
