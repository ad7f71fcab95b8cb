"""Self-check of the map errors (--map-error; check_odosim.py runs it on a 1-minute drive
against the clean drive of the same seed): the objects (a cabinet against a wall and a pillar
in the open) are absent from the wall records, the beams that differ from the clean drive are
exactly those whose ray cast (check_base.py's) meets an object first, each shorter by the ray
cast's difference; the phantom is the last wall record and no measured range ends on it; the
shifted wall record is the real wall moved exactly d along its left normal, the other records
unchanged; encoders and truth are those of the clean drive."""

import math

import numpy as np

import world as sim_world
from check_base import check, ray_ranges

MAP_OBJECTS = [[5.0, 0.2, 0.6, 0.4], [4.3, 3.2, 0.3, 0.3]]    # cabinet, pillar
MAP_PHANTOM = [1.5, 3.0, 1.5, 4.5]
MAP_SHIFT = [0, 0.1]


def box_segments(x, y, w, h):
    x0, x1, y0, y1 = x - w / 2, x + w / 2, y - h / 2, y + h / 2
    return [[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]]


def map_error_args():
    out = []
    for o in MAP_OBJECTS:
        out += ["--map-error", "object=" + ",".join(repr(v) for v in o)]
    out += ["--map-error", "phantom=" + ",".join(repr(v) for v in MAP_PHANTOM),
            "--map-error", "shift=%d,%r" % tuple(MAP_SHIFT)]
    return out


def check_map_errors(log, log0):
    """log: the drive with MAP_OBJECTS, MAP_PHANTOM and MAP_SHIFT; log0: the clean drive
    of the same seed."""
    nominal = np.array(sim_world.WALLS, dtype=float)
    walls = log["walls"]
    metas = [m for m in log["meta"] if m[0] == "truth_map_error"]
    want_meta = ([["truth_map_error", "object"] + [repr(v) for v in o] for o in MAP_OBJECTS]
                 + [["truth_map_error", "phantom"] + [repr(v) for v in MAP_PHANTOM]]
                 + [["truth_map_error", "shift", "0", "0.1"]])
    check(metas == want_meta, f"map errors: meta truth_map_error records {metas}")
    same = (np.array_equal(log["enc"], log0["enc"])
            and np.array_equal(log["truth"], log0["truth"]))
    check(same, "map errors: same seed, same encoders and truth as the clean drive")

    # --- objects: in the world, not in the map -------------------------------------
    obj_segs = [sg for o in MAP_OBJECTS for sg in box_segments(*o)]
    in_records = [sg for sg in obj_segs
                  if any(np.allclose(sg, w) or np.allclose(sg[2:] + sg[:2], w) for w in walls)]
    check(len(walls) == len(nominal) + 1 and not in_records,
          f"map errors: {len(walls)} wall records (the {len(nominal)} real ones and the "
          f"phantom), no edge of the objects among them")
    # the world the laser sees: the real walls (not shifted, no phantom) and the objects
    world = np.concatenate([nominal, np.array(obj_segs)])
    truth = {round(row[0], 6): row[1:] for row in log["truth"]}
    r_meas, r_clean = log["scan"][:, 1:], log0["scan"][:, 1:]
    hit_obj = np.zeros(r_meas.shape, bool)
    want_d = np.zeros(r_meas.shape)
    r_phantom = np.full(r_meas.shape, np.nan)
    for k, row in enumerate(log["scan"]):
        x, y, th = truth[round(row[0], 6)]
        r_wall = ray_ranges(x, y, th, log["laser"], nominal)
        r_world = ray_ranges(x, y, th, log["laser"], world)
        r_obj = ray_ranges(x, y, th, log["laser"], np.array(obj_segs))
        hit_obj[k] = np.isfinite(r_obj) & (r_obj <= r_world + 1e-9)
        want_d[k] = r_world - r_wall
        r_phantom[k] = ray_ranges(x, y, th, log["laser"], [MAP_PHANTOM])
    differ = ~((r_meas == r_clean) | (np.isnan(r_meas) & np.isnan(r_clean)))
    n_hit = int(hit_obj.sum())
    err = float(np.nanmax(np.abs((r_meas - r_clean - want_d)[hit_obj]))) if n_hit else math.inf
    shorter = bool(np.all((r_meas - r_clean)[hit_obj] < 0.0))
    scans_hit = int(hit_obj.any(axis=1).sum())
    check(n_hit > 50 and np.array_equal(differ, hit_obj) and shorter and err < 2e-6,
          f"map errors: the objects shorten exactly the {n_hit} beams (in {scans_hit} scans) "
          f"whose ray meets an object first, by the ray cast's difference (median "
          f"{np.median((r_meas - r_clean)[hit_obj]):+.2f} m, error {err:.1e}); every other "
          f"beam is the clean drive's")

    # --- phantom: in the map, not in the world ---------------------------------------
    on_phantom = np.abs(r_meas - r_phantom) < 5 * log["laser"][4]
    n_cross = int(np.isfinite(r_phantom).sum())
    check(np.allclose(walls[-1], MAP_PHANTOM, atol=0, rtol=0) and n_cross > 50
          and not on_phantom.any(),
          f"map errors: the phantom is the last wall record {walls[-1].tolist()}; "
          f"{n_cross} beams cross it, none of the measured ranges ends on it (5 sigma)")

    # --- shift: wall i written d along its left normal -------------------------------
    i, d = MAP_SHIFT
    x1, y1, x2, y2 = nominal[i]
    length = math.hypot(x2 - x1, y2 - y1)
    nx, ny = -(y2 - y1) / length, (x2 - x1) / length
    want = np.array([x1 + d * nx, y1 + d * ny, x2 + d * nx, y2 + d * ny])
    moved = walls[i] - nominal[i]
    others = np.array_equal(np.delete(walls[:len(nominal)], i, axis=0),
                            np.delete(nominal, i, axis=0))
    check(np.abs(walls[i] - want).max() < 1e-12 and others,
          f"map errors: shift {i},{d}: wall record {i}'s end points moved by "
          f"({moved[0]:+.3f}, {moved[1]:+.3f}) and ({moved[2]:+.3f}, {moved[3]:+.3f}) "
          f"= d x its left normal "
          f"({nx:+.0f}, {ny:+.0f}); the other real walls' records unchanged")
