"""carmen_grid.py: an occupancy grid from a SLAM-corrected CARMEN laser log (the buildings of
../shared/data/carmen: Intel, ACES, Freiburg 079, CSAIL, Orebro).

Input: the FLASER and PARAM lines of the log: `FLASER n r1..rn x y theta odom_x odom_y
odom_theta ts host lts`, x y theta being the SLAM-corrected pose. The laser is read by the
importer's rules (tools/import/carmen_laser.py; docs/real-data.md, "CARMEN logs: what the
importer reads"): the beam directions from the beam count (180 and 181 beams 1 deg apart,
360 and 361 beams 0.5 deg apart, the first at -90 deg) unless PARAM
laser_front_laser_resolution / _fov state them; a reading at or above the no-return limit
(--no-return, else PARAM robot_front_laser_max, else 80 m) is no return. Beam i leaves the
FLASER pose along theta + start + i * step: CARMEN writes the laser's pose there (the
robot's pose plus the mount), so the mount PARAMs (robot_frontlaser_offset, _side_offset,
_angular_offset) are read and reported but not added again. Measured: Freiburg 079 states
an offset of -0.04 m; its returns agree best with beams from the FLASER pose itself (74.9 %
on an occupied cell, against 68.2 % with the offset added; docs/map-format.md).

Mapping: log-odds occupancy on a square grid (default 0.05 m). For each scan, the cells a
beam crosses before its return are observed free (once per scan, however many beams cross
them) and the cell of its return is observed occupied:
    l += L_OCC (+0.85, p = 0.70) for a hit, l += L_FREE (-0.40, p = 0.40) for a pass,
clamped to [-L_CLAMP, L_CLAMP] = [-5, 5]. A cell crossed and hit in the same scan counts as
hit. Returns beyond the usable range (--max-range, default 20 m) clear the cells up to it
and add no hit; a beam with no return (and a reading of 0) is not used at all (it clears
nothing: no return may be glass or a dark surface as well as open space). A ray is sampled
every half cell, and clears the cells up to `free_stop` (0.5) cells short of its return.
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
import carmen_laser  # noqa: E402  (tools/import: the CARMEN laser's rules, shared with the importer)
import import_common  # noqa: E402  (tools/import: the importers' shared file helpers)

L_OCC, L_FREE, L_CLAMP = 0.85, -0.40, 5.0


class LogError(Exception):
    """A malformed log; the message names FILE:LINE."""


class Geometry:
    """Where the beams of a scan go: the first at `start` rad, `step` rad apart, from the
    mount (x, y, yaw) on the FLASER pose (0 for the logs read here; kept for measurements)."""
    __slots__ = ("start", "step", "mount")

    def __init__(self, start, step, mount=(0.0, 0.0, 0.0)):
        self.start, self.step, self.mount = float(start), float(step), tuple(float(v) for v in mount)


class Log:
    """A CARMEN log's scans: `scans` a list of (pose (x, y, theta), ranges array, line
    number), the no-return readings (and readings of 0) as nan; `laser` the
    carmen_laser.Laser; `pile_up` None or (lowest reading, what piles up): a no-return code
    the log does not state (carmen_laser.pile_up); `no_returns`, `readings` counts.
    `geometry`: the beams from the FLASER pose (the laser's own; the mount not added)."""

    def __init__(self, scans, laser, pile_up, no_returns, readings):
        self.scans, self.laser, self.pile_up = scans, laser, pile_up
        self.no_returns, self.readings = no_returns, readings

    @property
    def geometry(self):
        return Geometry(self.laser.start, self.laser.step)


def read_log(path, max_scans=None, no_return=None):
    """The FLASER scans and the laser of a CARMEN log (the PARAMs of the whole file, also
    with max_scans). no_return: the --no-return limit (m), None for the log's."""
    try:
        data = import_common.read_bytes(path)
    except import_common.InputError as e:
        raise LogError(str(e)) from None
    raw_scans = []
    params = {}
    n_beams = first_where = None
    for no, raw in enumerate(data.split(b"\n"), start=1):
        if raw.startswith(b"PARAM"):
            try:
                f = raw.decode("ascii").split()
                if f[0] == "PARAM":
                    carmen_laser.parse_param(f, f"{path}:{no}", no, params)
            except UnicodeDecodeError:
                raise LogError(f"{path}:{no}: the line is not ASCII text") from None
            except import_common.InputError as e:
                raise LogError(str(e)) from None
            continue
        if not raw.startswith(b"FLASER") or (max_scans is not None and len(raw_scans) >= max_scans):
            continue
        f = raw.split()
        if f[0] != b"FLASER":
            continue
        try:
            n = int(f[1])
        except (IndexError, ValueError):
            raise LogError(f"{path}:{no}: FLASER: the beam count is not an integer") from None
        if n <= 0 or len(f) != n + 11:
            raise LogError(f"{path}:{no}: FLASER with {n} beams takes {n + 10} fields, got {len(f) - 1}")
        if n_beams is None:
            n_beams, first_where = n, f"{path}:{no}"
        elif n != n_beams:
            raise LogError(f"{path}:{no}: FLASER with {n} beams, the first one ({first_where}) had {n_beams}: "
                           f"one laser cannot have both")
        try:
            vals = np.array([float(v) for v in f[2:n + 5]])
        except ValueError:
            raise LogError(f"{path}:{no}: FLASER: a range or pose field is not a number") from None
        if not np.all(np.isfinite(vals)):
            raise LogError(f"{path}:{no}: FLASER: a range or pose field is not finite")
        if np.any(vals[:n] < 0):
            raise LogError(f"{path}:{no}: FLASER: a negative range")
        raw_scans.append((tuple(vals[n:n + 3]), vals[:n], no))
    if not raw_scans:
        raise LogError(f"{path}: no FLASER line: no scan to build a grid from")
    try:
        laser = carmen_laser.laser_setup(n_beams, params, first_where, no_return=no_return)
    except import_common.InputError as e:
        raise LogError(str(e)) from None
    allr = np.concatenate([r for _, r, _ in raw_scans])
    below = allr[allr < laser.no_return]
    vals, counts = np.unique(below, return_counts=True)
    pile = carmen_laser.pile_up(dict(zip(vals.tolist(), counts.tolist())), allr.size)
    scans = []
    for pose, r, no in raw_scans:
        r = r.copy()
        r[(r >= laser.no_return) | (r <= 0)] = np.nan
        scans.append((pose, r, no))
    return Log(scans, laser, pile, int(allr.size - below.size), int(allr.size))


def read_scans(path, max_scans=None, no_return=None):
    """The scans of read_log (a list of (pose, ranges with nan for no return, line))."""
    return read_log(path, max_scans, no_return).scans


def _beams(scan, geo, max_range):
    """The beam origin (x, y), directions, the length each clears or reaches, and which end
    in a hit (a return within max_range)."""
    (x, y, th), r, _ = scan
    mx, my, myaw = geo.mount
    c, s = math.cos(th), math.sin(th)
    ox, oy = x + mx * c - my * s, y + mx * s + my * c
    ang = th + myaw + geo.start + geo.step * np.arange(len(r))
    ret = np.isfinite(r)
    rr = np.where(ret, r, 0.0)
    hit = ret & (rr <= max_range)
    reach = np.where(hit, rr, np.where(ret, max_range, 0.0))
    return ox, oy, ang, reach, hit


def _extent(scans, geo, max_range, res, margin=1.0):
    lo = np.array([np.inf, np.inf])
    hi = -lo
    for s in scans:
        x, y, ang, reach, _ = _beams(s, geo, max_range)
        px = np.append(x + reach * np.cos(ang), x)
        py = np.append(y + reach * np.sin(ang), y)
        lo = np.minimum(lo, [px.min(), py.min()])
        hi = np.maximum(hi, [px.max(), py.max()])
    x0 = math.floor((lo[0] - margin) / res) * res
    y0 = math.floor((lo[1] - margin) / res) * res
    cols = int(math.ceil((hi[0] + margin - x0) / res))
    rows = int(math.ceil((hi[1] + margin - y0) / res))
    return x0, y0, cols, rows


def build(scans, resolution=0.05, max_range=20.0, geo=None, free_stop=0.5, returns=None):
    """Log-odds grid (rows x cols float array, row 0 = bottom) and the origin (x0, y0).
    geo: the Geometry (default: 180 beams' rule, 1 deg from -90 deg, no mount); returns: a
    list to which the cell index (row * cols + col) of every return is appended, one array
    a scan."""
    geo = geo or Geometry(-math.pi / 2, math.radians(1.0))
    x0, y0, cols, rows = _extent(scans, geo, max_range, resolution)
    lo = np.zeros(rows * cols)
    # one write per cell and scan without sorting: stamp[cell] holds the position of the last
    # sample written there, so exactly one sample per cell reads its own position back
    stamp = np.full(rows * cols, -1, dtype=np.int64)
    hit_scan = np.full(rows * cols, -1, dtype=np.int64)
    half = resolution / 2
    tgrid = np.arange(0.0, max_range, half)
    for k, s in enumerate(scans):
        x, y, ang, reach, hit = _beams(s, geo, max_range)
        c, si = np.cos(ang), np.sin(ang)
        # free: samples t = 0, res/2, ... while t < reach - free_stop * res (half a cell short)
        nsam = np.searchsorted(tgrid, reach - free_stop * resolution, side="left").astype(np.int64)
        tot = int(nsam.sum())
        hx, hy = x + reach[hit] * c[hit], y + reach[hit] * si[hit]
        hits = ((hy - y0) // resolution).astype(np.int64) * cols + ((hx - x0) // resolution).astype(np.int64)
        hit_scan[hits] = k
        if returns is not None:
            returns.append(hits)
        if tot:
            beam = np.repeat(np.arange(len(nsam)), nsam)
            t = tgrid[np.arange(tot) - np.repeat(np.cumsum(nsam) - nsam, nsam)]
            cells = (((y + t * si[beam]) - y0) // resolution).astype(np.int64) * cols + \
                (((x + t * c[beam]) - x0) // resolution).astype(np.int64)
            pos = np.arange(tot)
            stamp[cells] = pos
            free = cells[(stamp[cells] == pos) & (hit_scan[cells] != k)]
            lo[free] = np.maximum(lo[free] + L_FREE, -L_CLAMP)
        if len(hits):
            pos = np.arange(len(hits))
            stamp[hits] = pos
            hits = hits[stamp[hits] == pos]
            lo[hits] = np.minimum(lo[hits] + L_OCC, L_CLAMP)
    return lo.reshape(rows, cols), (x0, y0)


def to_grid(lo, origin, resolution, source, occupied_thresh=0.65, free_thresh=0.196):
    """A rosmap.Grid from log-odds (never-observed cells, l == 0 exactly, are unknown)."""
    p = 1.0 - 1.0 / (1.0 + np.exp(lo))
    seen = lo != 0
    return rosmap.Grid(seen & (p > occupied_thresh), seen & (p < free_thresh), resolution,
                       (origin[0], origin[1], 0.0), source=source)


def returns_share(grid, returns):
    """Share of the returns (cell indices from build) that land in an occupied cell, and
    within one cell of one (3 x 3 neighbourhood): with the right beam geometry the returns
    of every scan fall on the cells the other scans made occupied."""
    from scipy import ndimage
    idx = np.concatenate(returns) if returns else np.zeros(0, dtype=np.int64)
    if len(idx) == 0:
        raise ValueError("no beam return within range: no endpoint share to report")
    near = ndimage.binary_dilation(grid.occ, structure=np.ones((3, 3), dtype=bool))
    # build's rows count up from the bottom, as the Grid's do
    return float(grid.occ.ravel()[idx].mean()), float(near.ravel()[idx].mean())


def endpoint_share(scans, grid, geo, max_range):
    """Share of the beam returns (<= max_range) that land in an occupied cell, and within one
    cell of one (3 x 3 neighbourhood)."""
    from scipy import ndimage
    near = ndimage.binary_dilation(grid.occ, structure=np.ones((3, 3), dtype=bool))
    x0, y0, _ = grid.origin
    rows, cols = grid.shape
    n = on = nb = 0
    for s in scans:
        x, y, ang, reach, hit = _beams(s, geo, max_range)
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


def beam_geometry_check(scans, candidates, resolution=0.05, max_range=20.0):
    """For each (name, Geometry) of candidates: the grid's occupied cell count (a sharper map
    has fewer) and the share of returns on / within one cell of an occupied cell (a
    consistent map has more: with the right geometry, the returns of every scan fall on the
    cells the other scans made occupied)."""
    out = []
    for name, geo in candidates:
        lo, org = build(scans, resolution, max_range, geo)
        g = to_grid(lo, org, resolution, "")
        on, nb = endpoint_share(scans, g, geo, max_range)
        out.append(dict(step=name, occupied_cells=int(g.occ.sum()), returns_on_occupied=on,
                        returns_within_one_cell=nb))
    return out


def grid_from_log(path, out_prefix, resolution=0.05, max_range=20.0, max_scans=None, no_return=None,
                  step_deg=None):
    """Builds and writes OUT_PREFIX.pgm/.yaml; returns the Grid and statistics (among them
    the laser as read and the pile-up note). step_deg overrides the beam step (degrees; the
    first beam stays where the log's rules put it)."""
    if resolution <= 0 or max_range <= 0:
        raise ValueError("resolution and max range must be > 0")
    if no_return is not None and not no_return > 0:
        raise ValueError("the no-return limit must be > 0")
    t0 = time.perf_counter()
    log = read_log(path, max_scans, no_return)
    t_read = time.perf_counter() - t0
    geo = log.geometry
    la = log.laser
    if step_deg is not None:
        geo = Geometry(geo.start, math.radians(step_deg), geo.mount)
    if not any(np.any(r <= max_range) for _, r, _ in log.scans):   # nan compares False
        raise LogError(f"{path}: none of the {log.readings} readings of its {len(log.scans)} scans is a return within "
                       f"{max_range:g} m ({log.no_returns} at or above the no-return limit {la.no_return:g} m, from "
                       f"{la.no_return_src}; the others beyond the range or 0): nothing to map")
    rets = []
    lo, org = build(log.scans, resolution, max_range, geo, returns=rets)
    g = to_grid(lo, org, resolution, os.path.abspath(path))
    on, near = returns_share(g, rets)
    beams = (f"{la.n} beams from {math.degrees(geo.start):.6g} deg, {math.degrees(geo.step):.6g} deg apart"
             + (" (--beam-step)" if step_deg is not None else ""))
    stated = [f"{k} {v:g}" for k, v in zip(("x", "y", "yaw"), la.mount) if v != 0]
    mount = "from the FLASER pose, the laser's" + (f" (the PARAM mount, {', '.join(stated)}, not added again)"
                                                   if stated else "")
    comment = (f"odoerr map grid-from-carmen {os.path.basename(path)}: {len(log.scans)} scans, "
               f"{resolution:g} m, max range {max_range:g} m, {beams}, {mount}, "
               f"no return >= {la.no_return:g} m")
    pgm, yml = rosmap.save(g, out_prefix, comment)
    stats = dict(scans=len(log.scans), rows=g.shape[0], cols=g.shape[1], occupied=int(g.occ.sum()),
                 free=int(g.free.sum()), unknown=int(g.unknown.sum()), seconds=time.perf_counter() - t0,
                 read_seconds=t_read, pgm=pgm, yaml=yml, laser=la, beams=beams, mount=mount,
                 no_returns=log.no_returns, readings=log.readings, pile_up=log.pile_up,
                 step_override=step_deg, returns=int(sum(len(r) for r in rets)), returns_on=on,
                 returns_near=near)
    return g, stats
