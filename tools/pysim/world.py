"""The room the simulated robot drives in: fixed set-up, walls, controller gains, and the
map errors (the map written differs from the world the laser sees). Part of odosim.py."""

from __future__ import annotations

import math

import numpy as np

import world_events  # doors and walkers: the world changing during the drive

# ---------------------------------------------------------------------------
# Fixed set-up
# ---------------------------------------------------------------------------

DT = 0.01                 # encoder / truth period (s)
SCAN_EVERY = 10           # one scan every 10 encoder cycles (10 Hz)

# diff drive: nominal constants and the truth's systematic / non-systematic errors
WHEEL_RADIUS = 0.05
TICKS_PER_REV = 4096
WHEELBASE = 0.5
DIFF_TRUTH = {"delta_R": 1.01, "delta_L": 0.99, "delta_d": 1.02, "K_w": 2.5e-4}

# sync drive
TICKS_PER_M = 20000
TICKS_PER_RAD = 20000
SYNC_TRUTH = {"delta_rho": 1.02, "E_theta": math.radians(0.5), "K_rho": 1e-4,
              "K_theta": 3e-5}

# laser
N_BEAMS = 36
ANGLE_MIN = -math.pi
ANGLE_INC = 2.0 * math.pi / N_BEAMS
RANGE_MAX = 20.0
RANGE_SIGMA = 0.03
MOUNT = (0.1, 0.0, 0.0)   # x, y, yaw in the robot frame
INCIDENCE_COS_MIN = math.cos(math.radians(80.0))   # ooc_incidence_bias saturates at 80 deg
OBJECT_CLEARANCE = 0.5    # m, least distance of a --map-error object from the reference path
SHIFT_MAX = 1.0           # m, largest |d| of a --map-error shift

# Map: each polygon counter-clockwise; walls are consecutive vertex pairs.
ROOM = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]
BOX_A = [(7.0, 6.0), (8.2, 6.0), (8.2, 7.2), (7.0, 7.2)]
BOX_B = [(1.0, 8.0), (1.8, 8.0), (1.8, 8.8), (1.0, 8.8)]


def polygon_walls(poly):
    """Closed polygon -> list of segments (x1, y1, x2, y2)."""
    return [(*poly[i], *poly[(i + 1) % len(poly)]) for i in range(len(poly))]


WALLS = polygon_walls(ROOM) + polygon_walls(BOX_A) + polygon_walls(BOX_B)

# Controller
K1 = 0.25                 # 1/m^2, lateral error gain
K2 = 1.0                  # 1/m, heading error gain
U_MAX = 0.5               # 1/m, limit of the curvature correction
CONTROL_EVERY = 100       # cycles between corrections (1 Hz)
ACCEL = 0.6               # m/s^2, limit of the commanded speed change


# ---------------------------------------------------------------------------
# Map errors: the map written differs from the world the laser sees
# ---------------------------------------------------------------------------

# kind -> (number of values, summary)
MAP_ERRORS = {
    "object": (4, "x, y, w, h (m): a box centred at (x, y), w x h, in the world, not in "
                  "the map (ranges shorter)"),
    "phantom": (4, "x1, y1, x2, y2 (m): a wall in the map, not in the world (ranges longer)"),
    "shift": (2, "i, d (index, m): map wall i written d along its left normal"),
    **world_events.KINDS,
}

# Suggested test placements (tests/diagnose/check_map.py): name -> (kind, values, note)
MAP_ERROR_CASES = {
    "cabinet": ("object", [5.0, 0.2, 0.6, 0.4],
                "0.6 x 0.4 cabinet against the bottom wall (y 0..0.4)"),
    "pillar": ("object", [4.3, 3.2, 0.3, 0.3],
               "0.3 x 0.3 pillar in the open, at the centre of the lower lobe"),
    "pallet": ("object", [7.5, 3.0, 1.0, 0.5],
               "1.0 x 0.5 pallet in the open, right of the lower lobe"),
    "phantom": ("phantom", [1.5, 3.0, 1.5, 4.5],
                "1.5 m partition drawn at x = 1.5 that is not there"),
    "shift_room": ("shift", [0, 0.10],
                   "bottom room wall (index 0) drawn 0.10 m into the room"),
    "shift_box": ("shift", [4, 0.10],
                  "bottom wall of the 1.2 m box (index 4) drawn 0.10 m into the box"),
}


def box_walls(x, y, w, h):
    """Segments of an axis-aligned box, counter-clockwise."""
    x0, x1, y0, y1 = x - w / 2.0, x + w / 2.0, y - h / 2.0, y + h / 2.0
    return polygon_walls([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def segment_distance(px, py, seg):
    """Distance of the points (px, py) (arrays) from the segment (x1, y1, x2, y2)."""
    x1, y1, x2, y2 = seg
    ex, ey = x2 - x1, y2 - y1
    ee = ex * ex + ey * ey
    u = np.clip(((px - x1) * ex + (py - y1) * ey) / ee, 0.0, 1.0) if ee > 0 else 0.0
    return np.hypot(px - x1 - u * ex, py - y1 - u * ey)


def box_distance(px, py, x, y, w, h):
    """Distance of the points (px, py) from the filled box (0 inside)."""
    dx = np.maximum(np.abs(px - x) - w / 2.0, 0.0)
    dy = np.maximum(np.abs(py - y) - h / 2.0, 0.0)
    return np.hypot(dx, dy)


def parse_values(flag, spec, vals, parser):
    """The comma-separated finite numbers of a NAME=V1,V2,... option (exit 2 otherwise)."""
    try:
        values = [float(v) for v in vals.split(",")]
    except ValueError:
        parser.error(f"{flag} {spec!r}: values must be numbers separated by commas")
    if not all(math.isfinite(v) for v in values):
        parser.error(f"{flag} {spec!r}: values must be finite")
    return values


def parse_map_errors(specs, parser, path=None):
    """['kind=v1,...', ...] -> {"object": [[x, y, w, h]..], "phantom": [[..]..],
    "shift": [[i, d]..]} (kinds absent when not given); errors go through parser.error
    (exit 2). With a Path, an object closer than OBJECT_CLEARANCE to it is refused."""
    out = {}
    rx = [p[0] for p in ROOM]
    ry = [p[1] for p in ROOM]
    room = (min(rx), max(rx), min(ry), max(ry))

    def inside(x, y):
        return room[0] <= x <= room[1] and room[2] <= y <= room[3]

    for spec in specs:
        if "=" not in spec:
            parser.error(f"--map-error {spec!r}: expected KIND=V1,... with KIND one of "
                         + ", ".join(MAP_ERRORS))
        kind, _, vals = spec.partition("=")
        kind = kind.strip()
        if kind not in MAP_ERRORS:
            parser.error(f"--map-error: unknown kind {kind!r}; known: " + ", ".join(MAP_ERRORS))
        values = parse_values("--map-error", spec, vals, parser)
        count = MAP_ERRORS[kind][0]
        if len(values) != count:
            parser.error(f"--map-error {kind}: takes {count} values "
                         f"({MAP_ERRORS[kind][1].split(':')[0]}), got {len(values)}")
        if kind == "object":
            x, y, w, h = values
            if w <= 0.0 or h <= 0.0:
                parser.error(f"--map-error {spec!r}: the size w, h must be > 0")
            if not (inside(x - w / 2, y - h / 2) and inside(x + w / 2, y + h / 2)):
                parser.error(f"--map-error {spec!r}: the object must lie inside the room "
                             f"({room[0]:g}..{room[1]:g} x {room[2]:g}..{room[3]:g})")
            if path is not None:
                d = float(box_distance(path.x_grid, path.y_grid, x, y, w, h).min())
                if d < OBJECT_CLEARANCE:
                    parser.error(f"--map-error {spec!r}: the object is {d:.2f} m from the "
                                 f"robot's path (it needs >= {OBJECT_CLEARANCE} m, or the "
                                 "robot would drive through it); the path is a figure-eight "
                                 "of circles centred (4.3, 3.2) r 1.4 and (4.3, 7.2) r 1.0 "
                                 "joined by their crossing tangents")
        elif kind == "phantom":
            x1, y1, x2, y2 = values
            if math.hypot(x2 - x1, y2 - y1) <= 1e-6:
                parser.error(f"--map-error {spec!r}: the phantom wall has zero length")
            if not (inside(x1, y1) and inside(x2, y2)):
                parser.error(f"--map-error {spec!r}: the phantom wall must lie inside the room")
        elif kind in world_events.KINDS:
            values = world_events.check(kind, values, spec, parser.error, inside, path, segment_distance)
        else:
            i, d = values
            if i != int(i) or not 0 <= int(i) < len(WALLS):
                parser.error(f"--map-error {spec!r}: the wall index must be an integer in "
                             f"0..{len(WALLS) - 1} (the real walls' records)")
            if abs(d) > SHIFT_MAX:
                parser.error(f"--map-error {spec!r}: |d| must be <= {SHIFT_MAX:g} m")
            values = [int(i), d]
            if any(v[0] == values[0] for v in out.get("shift", [])):
                parser.error(f"--map-error shift: wall {values[0]} shifted twice")
        out.setdefault(kind, []).append(values)
    return out


def map_walls(map_errors):
    """The wall records written: the real walls (shifted as asked), then the phantoms."""
    walls = [list(map(float, w)) for w in WALLS]
    for i, d in (map_errors or {}).get("shift", []):
        x1, y1, x2, y2 = walls[i]
        length = math.hypot(x2 - x1, y2 - y1)
        nx, ny = -(y2 - y1) / length, (x2 - x1) / length
        walls[i] = [x1 + d * nx, y1 + d * ny, x2 + d * nx, y2 + d * ny]
    walls += [list(map(float, p)) for p in (map_errors or {}).get("phantom", [])]
    walls += world_events.map_walls(map_errors)
    return walls


def object_walls(map_errors):
    """Segments of the map errors' objects (in the world, not in the map), shape (K, 4)."""
    segs = [s for o in (map_errors or {}).get("object", []) for s in box_walls(*o)]
    return np.array(segs, dtype=float).reshape(-1, 4)
