"""odosim.py's laser: ray casting against the true walls, the scans with the measurement
effects and the map errors applied."""

from __future__ import annotations

import numpy as np

import world_events
from world import (ANGLE_INC, ANGLE_MIN, DT, INCIDENCE_COS_MIN, MOUNT, N_BEAMS, RANGE_MAX,
                   RANGE_SIGMA, SCAN_EVERY, WALLS, box_walls, map_walls, object_walls)

# ---------------------------------------------------------------------------
# Laser
# ---------------------------------------------------------------------------

def true_walls(effects):
    """Wall segments as they really are (wall_offset applied), shape (W, 4)."""
    w = np.array(WALLS, dtype=float)
    off = effects.get("wall_offset")
    if off is not None:
        dx, dy = w[:, 2] - w[:, 0], w[:, 3] - w[:, 1]
        length = np.hypot(dx, dy)
        nx, ny = -dy / length, dx / length
        o = np.asarray(off)
        w = w + np.stack([o * nx, o * ny, o * nx, o * ny], axis=1)
    return w


def cast_rays(ox, oy, ang, walls, incidence=False):
    """Vectorised ray casting. ox, oy: (S,), ang: (S, B) world beam angles,
    walls: (W, 4). Returns (S, B) ranges, inf where no wall is hit; with incidence=True
    also (S, B) |cos| of the angle between the beam and the hit wall's normal (nan where
    no wall is hit)."""
    dx, dy = np.cos(ang)[..., None], np.sin(ang)[..., None]          # (S, B, 1)
    ax, ay = walls[:, 0], walls[:, 1]                                  # (W,)
    ex, ey = walls[:, 2] - ax, walls[:, 3] - ay
    qx = ax - ox[:, None, None]                                        # (S, 1, W)
    qy = ay - oy[:, None, None]
    den = dx * ey - dy * ex                                            # (S, B, W)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = (qx * ey - qy * ex) / den
        u = (qx * dy - qy * dx) / den
    hit = (np.abs(den) > 1e-12) & (r > 1e-9) & (u >= 0.0) & (u <= 1.0)
    r = np.where(hit, r, np.inf)
    if not incidence:
        return r.min(axis=2)
    iw = r.argmin(axis=2)                                              # (S, B)
    rng = np.take_along_axis(r, iw[..., None], axis=2)[..., 0]
    length = np.hypot(ex, ey)
    # |beam . unit normal| = |dx ey - dy ex| / length = |den| / length of the hit wall
    cos_inc = np.abs(np.take_along_axis(den, iw[..., None], axis=2)[..., 0]) / length[iw]
    return rng, np.where(np.isfinite(rng), cos_inc, np.nan)


def simulate_scans(truth, n_steps, effects, rng_scan, map_errors=None, seen=None):
    """Scan times (S,) and ranges (S, B) with nan for no return. map_errors: the
    objects of parse_map_errors stand in the world (phantoms and shifts change only the
    map written). A list given as ``seen`` receives, per map error, (kind, values,
    beams, scans): how many beams (in how many scans) meet it: an object that is the
    first thing a beam hits, a phantom or shifted wall that is the map's first wall on
    the beam (its predicted hit)."""
    k_scan = np.arange(SCAN_EVERY, n_steps + 1, SCAN_EVERY)
    t_scan = k_scan * DT
    t_truth = np.arange(n_steps + 1) * DT
    tau = effects.get("scan_latency", [0.0])[0]
    t_take = np.clip(t_scan - tau, 0.0, t_truth[-1])
    x = np.interp(t_take, t_truth, truth[:, 0])
    y = np.interp(t_take, t_truth, truth[:, 1])
    th = np.interp(t_take, t_truth, truth[:, 2])         # theta is unwrapped

    dmx, dmy = effects.get("laser_mount_xy", [0.0, 0.0])
    dpsi = effects.get("laser_mount_yaw", [0.0])[0]
    mx, my, myaw = MOUNT[0] + dmx, MOUNT[1] + dmy, MOUNT[2] + dpsi
    c, s = np.cos(th), np.sin(th)
    ox = x + c * mx - s * my
    oy = y + s * mx + c * my
    alpha = ANGLE_MIN + ANGLE_INC * np.arange(N_BEAMS)      # beam angles, laser frame
    alpha = alpha * (1.0 + effects.get("ooc_beam_angle_scale", [0.0])[0])
    beams = myaw + alpha
    ang = th[:, None] + beams[None, :]

    world = np.concatenate([true_walls(effects), object_walls(map_errors)])
    r_true, cos_inc = cast_rays(ox, oy, ang, world, incidence=True)
    r_true, changed = world_events.apply(r_true, t_scan, ox, oy, ang, map_errors, cast_rays, box_walls)
    if seen is not None and map_errors:
        seen.extend(map_error_visibility(ox, oy, ang, r_true, map_errors))
        ok = np.isfinite(r_true) & (r_true <= RANGE_MAX)
        for (kind, i), m in changed.items():
            seen.append((kind, map_errors[kind][i], int((m & ok).sum()), int((m & ok).any(axis=1).sum())))
    r = r_true
    c_inc = effects.get("ooc_incidence_bias", [0.0])[0]
    if c_inc:
        # held at its 80 degree value beyond 80 degrees of incidence (1/cos would reach
        # metres at grazing beams; those beams hit near corners and are gated anyway)
        cos_c = np.maximum(cos_inc, INCIDENCE_COS_MIN)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = r + c_inc * (1.0 / cos_c - 1.0)
    c_t = effects.get("ooc_range_time_drift", [0.0])[0]
    if c_t:
        r = r + c_t * t_scan[:, None]
    r = r + effects.get("range_bias", [0.0])[0]
    r = r * (1.0 + effects.get("range_scale", [0.0])[0])
    r = r + RANGE_SIGMA * rng_scan.standard_normal(r.shape)
    r[~np.isfinite(r_true) | (r_true > RANGE_MAX) | (r <= 0.0) | (r > RANGE_MAX)] = np.nan
    return k_scan, r


def map_error_visibility(ox, oy, ang, r_true, map_errors):
    """[(kind, values, beams, scans)] of each map error (see simulate_scans)."""
    out = []
    ok = np.isfinite(r_true) & (r_true <= RANGE_MAX)

    def count(mask):
        mask = mask & ok
        return int(mask.sum()), int(mask.any(axis=1).sum())

    for o in map_errors.get("object", []):
        r_o = cast_rays(ox, oy, ang, np.array(box_walls(*o), dtype=float))
        out.append(("object", o, *count(np.isfinite(r_o) & (r_o <= r_true + 1e-9))))
    walls = np.array(map_walls(map_errors), dtype=float)
    r_map = cast_rays(ox, oy, ang, walls)
    n_real = len(WALLS)
    for j, p in enumerate(map_errors.get("phantom", [])):
        r_wo = cast_rays(ox, oy, ang, np.delete(walls, n_real + j, axis=0))
        out.append(("phantom", p, *count(r_map < r_wo - 1e-9)))
    for i, d in map_errors.get("shift", []):
        r_wo = cast_rays(ox, oy, ang, np.delete(walls, i, axis=0))
        out.append(("shift", [i, d], *count(r_map < r_wo - 1e-9)))
    return out


def min_clearance(truth, map_errors=None):
    """Smallest distance of the true path to any (nominal) wall or object, m."""
    p = truth[:, :2]
    w = np.concatenate([np.array(WALLS, dtype=float), object_walls(map_errors)])
    a, e = w[:, :2], w[:, 2:] - w[:, :2]
    rel = p[:, None, :] - a[None, :, :]
    u = np.clip((rel * e).sum(-1) / (e * e).sum(-1), 0.0, 1.0)
    d = rel - u[..., None] * e[None]
    return float(np.sqrt((d * d).sum(-1)).min())
