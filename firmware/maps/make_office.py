#!/usr/bin/env python3
"""make_office.py: writes the synthetic office used to measure the firmware's cycle against
the map's size (docs/performance.md, "Cost against the map"): a 30 x 20 m floor with a
central corridor, ten rooms with door gaps, desks, a cabinet and a shelf (rectangles) in
each room, pillars in the corridor, and a path that drives the corridor and visits five
rooms.

Usage: make_office.py MAP.odomap PATH.txt     (deterministic: no randomness)

The map is an .odomap file (docs/map-format.md); the path is 'X Y' lines.
"""
import sys


def rect(x0, y0, x1, y1):
    return [(x0, y0, x1, y0), (x1, y0, x1, y1), (x1, y1, x0, y1), (x0, y1, x0, y0)]


def wall_with_doors(x0, y0, x1, y1, doors, width=1.0):
    """A straight wall with door gaps centred at the given positions along it (m)."""
    import math
    length = math.hypot(x1 - x0, y1 - y0)
    ux, uy = (x1 - x0) / length, (y1 - y0) / length
    cuts = [0.0]
    for d in sorted(doors):
        cuts += [d - width / 2, d + width / 2]
    cuts.append(length)
    segs = []
    for a, b in zip(cuts[0::2], cuts[1::2]):
        if b - a > 1e-6:
            segs.append((x0 + a * ux, y0 + a * uy, x0 + b * ux, y0 + b * uy))
    return segs


def office():
    W, H = 30.0, 20.0
    walls = rect(0, 0, W, H)
    # Corridor between y = 8.5 and y = 11.5; rooms of 6 m along x above and below it.
    walls += wall_with_doors(0, 8.5, W, 8.5, [3 + 6 * k for k in range(5)])
    walls += wall_with_doors(0, 11.5, W, 11.5, [3 + 6 * k for k in range(5)])
    for k in range(1, 5):
        walls.append((6.0 * k, 0, 6.0 * k, 8.5))
        walls.append((6.0 * k, 11.5, 6.0 * k, H))
    # Pillars in the corridor (0.4 m square), every 6 m offset by 1.5 m.
    for k in range(5):
        walls += rect(1.3 + 6 * k, 9.8, 1.7 + 6 * k, 10.2)
    # Furniture: two desks and a cabinet per room.
    for k in range(5):
        x = 6.0 * k
        for (y_lo, y_hi, flip) in ((0.0, 8.5, False), (11.5, H, True)):
            def Y(v):
                return y_hi - v if flip else y_lo + v
            walls += rect(x + 1.0, min(Y(1.0), Y(2.0)), x + 2.6, max(Y(1.0), Y(2.0)))   # desk
            walls += rect(x + 3.4, min(Y(1.0), Y(2.0)), x + 5.0, max(Y(1.0), Y(2.0)))   # desk
            walls += rect(x + 4.8, min(Y(5.5), Y(7.6)), x + 5.6, max(Y(5.5), Y(7.6)))   # cabinet
            walls += rect(x + 0.4, min(Y(5.0), Y(6.2)), x + 1.4, max(Y(5.0), Y(6.2)))   # shelf
    return walls


def path():
    pts = [(1.0, 10.8)]
    for k in (0, 2, 4):        # corridor, visiting the rooms below at x = 3, 15, 27
        xd = 3.0 + 6 * k
        pts += [(xd, 10.8), (xd, 9.0), (xd, 4.0), (xd - 1.6, 4.0), (xd - 1.6, 3.0), (xd + 1.6, 3.0),
                (xd + 1.6, 4.0), (xd, 4.0), (xd, 9.0), (xd, 10.6)]
    pts += [(29.0, 10.6), (29.0, 10.2)]
    for k in (3, 1):           # back along the corridor, visiting the rooms above
        xd = 3.0 + 6 * k
        pts += [(xd, 10.2), (xd, 12.5), (xd, 16.0), (xd - 1.6, 16.0), (xd + 1.6, 16.0), (xd, 16.0),
                (xd, 12.5), (xd, 10.2)]
    pts += [(1.0, 10.2)]
    return pts


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    walls = office()
    with open(sys.argv[1], "w") as f:
        f.write("odomap 1\nmeta source odoerr firmware/maps/make_office.py (synthetic office)\n")
        for w in walls:
            f.write("segment %.4f %.4f %.4f %.4f\n" % w)
    with open(sys.argv[2], "w") as f:
        f.write("# path through the synthetic office (make_office.py)\n")
        for p in path():
            f.write("%.3f %.3f\n" % p)
    print(f"make_office: {len(walls)} walls, {len(path())} path points", file=sys.stderr)


if __name__ == "__main__":
    main()
