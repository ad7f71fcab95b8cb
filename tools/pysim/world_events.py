"""Things in odosim's world that change while the robot drives (``--map-error`` kinds):
what a real building has and a map cannot hold.

    door=x1,y1,x2,y2,t_open
        a door (a wall segment) that is in the map and closed in the world until t_open
        seconds into the drive, then open (gone from the world) for the rest of it: beams
        the map says stop at it go further after t_open (LONGER than predicted, from then on).
    walker=x1,y1,x2,y2,speed
        a person, a 0.4 x 0.4 m box, walking to and fro along the segment at `speed` m/s
        for the whole drive, never in the map: the beams that meet it come back SHORTER,
        at each place only while the person passes.

Both must lie inside the room; a walker keeps 0.5 m from the robot's path (it would walk
into the robot otherwise). The ranges change only where a beam meets them; the robot's
motion, encoders and range-noise draws are those of the drive without them.
"""
import numpy as np

KINDS = {
    "door": (5, "x1, y1, x2, y2, t_open (m, s): a door in the map and closed in the world until "
                "t_open, open after (ranges longer from then on)"),
    "walker": (5, "x1, y1, x2, y2, speed (m, m/s): a 0.4 m person walking to and fro along the "
                  "segment, not in the map (ranges shorter where it passes)"),
}
WALKER_SIZE = 0.4     # m, the person's box
WALKER_CLEARANCE = 0.5  # m, least distance of the walker's line from the robot's path


def check(kind, values, spec, error, inside, path=None, distance=None):
    """The values of one event, checked (error(msg) exits). With a path, distance(px, py, seg)
    (odosim's segment_distance) keeps a walker's line clear of it."""
    x1, y1, x2, y2, v = values
    if np.hypot(x2 - x1, y2 - y1) <= 1e-6:
        error(f"--map-error {spec!r}: the {kind}'s segment has zero length")
    if not (inside(x1, y1) and inside(x2, y2)):
        error(f"--map-error {spec!r}: the {kind} must lie inside the room")
    if kind == "door" and not v > 0:
        error(f"--map-error {spec!r}: t_open must be > 0 s")
    if kind == "walker":
        if not v > 0:
            error(f"--map-error {spec!r}: the speed must be > 0 m/s")
        if path is not None:
            d = distance(path.x_grid, path.y_grid, (x1, y1, x2, y2)).min()
            if d < WALKER_CLEARANCE + WALKER_SIZE / 2:
                error(f"--map-error {spec!r}: the walker's line is {d:.2f} m from the robot's path "
                      f"(it needs >= {WALKER_CLEARANCE + WALKER_SIZE / 2:g} m)")
    return list(values)


def map_walls(events):
    """The wall records the events add to the map: the doors (closed, as drawn)."""
    return [list(map(float, d[:4])) for d in (events or {}).get("door", [])]


def walker_position(w, t):
    """Centre of walker w = (x1, y1, x2, y2, speed) at the times t: a triangle wave along
    the segment, at its first end at t = 0."""
    x1, y1, x2, y2, v = w
    length = np.hypot(x2 - x1, y2 - y1)
    s = (v * np.asarray(t)) % (2 * length)
    u = np.where(s <= length, s, 2 * length - s) / length
    return x1 + u * (x2 - x1), y1 + u * (y2 - y1)


def apply(r, t_scan, ox, oy, ang, events, cast_rays, box_walls):
    """The true ranges r (S, B) with the events: a closed door shortens the beams it meets
    before its t_open; a walker shortens those it meets where it is at each scan. cast_rays
    and box_walls are odosim's. Returns (ranges, {(kind, index): mask of the beams changed})."""
    changed = {}
    for i, d in enumerate((events or {}).get("door", [])):
        r_d = cast_rays(ox, oy, ang, np.array([d[:4]], dtype=float))
        hit = (t_scan < d[4])[:, None] & (r_d < r)
        r = np.where(hit, r_d, r)
        changed[("door", i)] = hit
    for i, w in enumerate((events or {}).get("walker", [])):
        cx, cy = walker_position(w, t_scan)
        hit = np.zeros(r.shape, dtype=bool)
        out = r.copy()
        for k in range(len(t_scan)):
            box = np.array(box_walls(cx[k], cy[k], WALKER_SIZE, WALKER_SIZE), dtype=float)
            r_w = cast_rays(ox[k:k + 1], oy[k:k + 1], ang[k:k + 1], box)[0]
            m = r_w < out[k]
            out[k] = np.where(m, r_w, out[k])
            hit[k] = m
        r = out
        changed[("walker", i)] = hit
    return r, changed
