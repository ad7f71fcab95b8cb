#!/usr/bin/env python3
"""test_carmen_grid.py: `odoerr map grid-from-carmen` and `odoerr map import` on small
CARMEN logs written here (no real data; no line of the real logs is used).

Usage: test_carmen_grid.py [ODOERR] [--work DIR]

The room (metres): an 8 x 6 m outer wall with a 1.5 m window in its top side, an interior
wall with a door, a diagonal wall. A robot looks round from 12 places, 4 headings each; each
scan is ray-cast against the walls from the FLASER pose (CARMEN writes the laser's pose
there), ranges to 1 cm as the CARMEN logger writes them, no return through the window.
- the beam geometry: logs of 180, 181, 360 and 361 beams (the beam-count rule; PARAM
  laser_front_laser_fov in radians and _resolution for 361) give the walls within 1.5
  cells, and a 360-beam log the same walls as a 180-beam one; the importer
  (carmen_to_odolog.py --scans) writes the laser record with the same directions as the
  grid states (the rules are shared: tools/import/carmen_laser.py);
- PARAM robot_frontlaser_offset is reported and not added to the FLASER pose (the same grid
  as without it); PARAM robot_front_laser_max sets the no-return limit;
- no return: readings >= 80 m are not used (the grid stays in the room); a no-return code
  no PARAM states (50 m) is noted on stderr naming --no-return 50, which gives the grid of
  the log written with 81.91; a log with no return at all is refused;
- a 360-beam log read 1 deg apart (--beam-step 1, the old reading): the grid says its
  returns disagree and `map import` refuses it (mostly specks);
- `map import` refuses, exit 2, naming why and writing nothing: a grid without an occupied
  cell, a grid of specks, a grid of two short walls; the synthetic room of synth_grid.py
  is accepted;
- malformed logs: FLASERs of two beam counts, 270 beams with no PARAM, are refused with
  FILE:LINE.
ODOERR (the odoerr binary), when given, runs the 360-beam case through `odoerr map`;
otherwise tools/map/odoerr_map.py is run directly (the binary only hands over to it).
Exit status 0 when everything holds, 1 otherwise (each failure printed).
"""
import argparse
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tools", "map"))
import extract  # noqa: E402
import rosmap  # noqa: E402
import scan_check  # noqa: E402
import synth_grid  # noqa: E402

SCRIPT = os.path.join(ROOT, "tools", "map", "odoerr_map.py")
IMPORTER = os.path.join(ROOT, "tools", "import", "carmen_to_odolog.py")
PY = sys.executable or "python3"
RES = 0.05

WALLS = np.array([
    [0.0, 0.0, 8.0, 0.0],
    [8.0, 0.0, 8.0, 6.0],
    [8.0, 6.0, 7.0, 6.0],      # the window: 5.5 .. 7.0 m of the top side is open
    [5.5, 6.0, 0.0, 6.0],
    [0.0, 6.0, 0.0, 0.0],
    [3.0, 0.0, 3.0, 2.2],      # interior wall, door 2.2 .. 3.2 m
    [3.0, 3.2, 3.0, 6.0],
    [4.5, 1.0, 7.0, 3.5],      # diagonal
])
PLACES = [(1.0, 1.0), (1.5, 3.0), (2.0, 5.0), (1.0, 4.2), (2.4, 2.0), (3.6, 2.7),
          (4.0, 4.5), (4.2, 5.4), (6.0, 5.0), (7.3, 4.5), (6.0, 1.0), (7.4, 1.5)]


class Checks:
    def __init__(self):
        self.fails = 0

    def __call__(self, cond, what):
        print(("ok   " if cond else "FAIL ") + what)
        if not cond:
            self.fails += 1
        return cond


check = Checks()


def rule_angles(n):
    """The directions (rad, laser frame) of the beam-count rule: -90 deg, 1 or 0.5 deg apart."""
    step = 1.0 if n in (180, 181) else 0.5
    return np.radians(-90.0 + step * np.arange(n))


def poses():
    out = []
    for k, (x, y) in enumerate(PLACES):
        for h in range(4):
            out.append((x, y, math.pi / 2 * h + 0.1 * (k % 3)))
    return out


def log_text(beams, angles, params=(), no_return="81.91", ranges_of=None):
    """A corrected CARMEN log: per scan the raw ODOM line of its stamp, the FLASER, the
    anchor (stamps 0), NEFF."""
    out = ["# CARMEN Logfile (synthetic, written by tests/map/test_carmen_grid.py)",
           "# message formats defined: PARAM SYNC ODOM FLASER"]
    out += [f"PARAM {k} {v} nohost 0" for k, v in params]
    for k, (x, y, th) in enumerate(poses()):
        t = f"{100.0 + k:.6f}"
        if ranges_of is not None:
            rs = ranges_of(k, x, y, th)
        else:
            r = scan_check.ray_cast(x, y, th + angles, WALLS)
            rs = [no_return if not np.isfinite(v) else f"{v:.2f}" for v in r]
        pose = f"{x:.6f} {y:.6f} {th:.6f}"
        out.append(f"ODOM {pose} 0 0 0 {t} nohost {t}")
        out.append(f"FLASER {beams} {' '.join(rs)} {pose} {pose} {t} nohost {t}")
        out.append(f"ODOM {pose} 0 0 0 0 nohost 0")
        out.append("NEFF 30")
    return "\n".join(out) + "\n"


def run(args, odoerr=None):
    cmd = [odoerr, "map"] + args if odoerr else [PY, SCRIPT] + args
    p = subprocess.run(cmd, capture_output=True, text=True)
    return p.returncode, p.stderr


def write(path, text):
    with open(path, "w", encoding="ascii", newline="") as f:
        f.write(text)
    return path


def sample(seg, step):
    x1, y1, x2, y2 = seg
    n = max(int(np.ceil(np.hypot(x2 - x1, y2 - y1) / step)), 1)
    t = np.linspace(0, 1, n + 1)
    return np.column_stack([x1 + t * (x2 - x1), y1 + t * (y2 - y1)])


def read_segments(path):
    with open(path) as f:
        return np.array([[float(v) for v in ln.split()[1:5]] for ln in f if ln.startswith("segment ")]).reshape(-1, 4)


def long_segments(segs, cells=5):
    return segs[np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]) > cells * RES]


def worst_off(a, b):
    """The largest distance (cells) from a point of a segment of a to the segments of b."""
    if len(a) == 0:
        return 0.0
    if len(b) == 0:
        return math.inf
    return max(float(extract.point_segment_distance(sample(s, RES / 2), b).max()) for s in a) / RES


def recovered(segs, walls):
    """The worst wall: the largest distance (cells) from a point of a true wall to the
    extracted segments running along it (within 10 deg), leaving out 2 cells at each end (a
    corner's cells are shared)."""
    worst = 0.0
    for w in walls:
        d = np.array([w[2] - w[0], w[3] - w[1]])
        L = np.hypot(*d)
        u = d / L
        par = [s for s in segs if np.hypot(s[2] - s[0], s[3] - s[1]) > 0 and
               abs((s[2:4] - s[0:2]) @ u) / np.hypot(s[2] - s[0], s[3] - s[1]) > math.cos(math.radians(10))]
        pts = sample(w, RES / 2)
        t = (pts - w[0:2]) @ u
        pts = pts[(t >= 2 * RES) & (t <= L - 2 * RES)]
        dist = extract.point_segment_distance(pts, np.array(par).reshape(-1, 4)) if par else np.full(len(pts), np.inf)
        worst = max(worst, float(dist.max()) / RES)
    return worst


def stated_beams(err):
    """(n, first deg, step deg) from grid-from-carmen's stderr."""
    m = re.search(r"(\d+) scans of (\d+) beams from ([-0-9.e]+) deg, ([0-9.e]+) deg apart", err)
    return (int(m.group(2)), float(m.group(3)), float(m.group(4))) if m else None


def returns_near(err):
    m = re.search(r"([0-9.]+) % within one cell of one", err)
    return float(m.group(1)) / 100 if m else None


def pixels(prefix):
    g = rosmap.load(prefix + ".yaml")
    return g.occ, g.free, g.origin


def geometry_cases(work, odoerr):
    """Each beam count's log gives the room's walls; 360 beams the same walls as 180."""
    fov = ("laser_front_laser_fov", "3.14159")
    res = ("laser_front_laser_resolution", "0.5")
    cases = [("b180", 180, rule_angles(180), ()),
             ("b181", 181, rule_angles(181), ()),
             ("b360", 360, rule_angles(360), ()),
             ("b361", 361, np.radians(-90.0 + 0.5 * np.arange(361)), (fov, res))]
    segs_of, occ_of = {}, {}
    for name, n, ang, params in cases:
        log = write(os.path.join(work, name + ".log"), log_text(n, ang, params))
        prefix = os.path.join(work, name)
        via = odoerr if name == "b360" else None
        rc, err = run(["grid-from-carmen", log, "--out", prefix], via)
        if not check(rc == 0, f"{name}: grid-from-carmen{' (odoerr map)' if via else ''} exit {rc}: {err.strip()}"):
            continue
        sb = stated_beams(err)
        want = (n, math.degrees(ang[0]), math.degrees(ang[1] - ang[0]))
        check(sb is not None and sb[0] == n and abs(sb[1] - want[1]) < 1e-3 and abs(sb[2] - want[2]) < 1e-6,
              f"{name}: the grid reads {sb} (N, first deg, step deg), the log was written with {want}")
        near = returns_near(err)
        check(near is not None and near >= 0.97, f"{name}: {near and near * 100:.1f} % of the returns within one "
              f"cell of an occupied cell (>= 97 %)")
        # the importer reads the same directions (shared rules)
        odo = os.path.join(work, name + ".odolog")
        p = subprocess.run([PY, IMPORTER, log, "--out", odo, "--scans"], capture_output=True, text=True)
        las = None
        if p.returncode == 0:
            with open(odo) as f:
                las = next((ln.split() for ln in f if ln.startswith("laser ")), None)
        check(las is not None and sb is not None and int(las[1]) == sb[0] and
              abs(math.degrees(float(las[2])) - sb[1]) < 1e-4 and abs(math.degrees(float(las[3])) - sb[2]) < 1e-6,
              f"{name}: the importer's laser record {las[1:4] if las else p.stderr.strip()} has the grid's directions")
        rc, err = run(["import", prefix + ".yaml", "--out", prefix + ".odomap"], via)
        if not check(rc == 0, f"{name}: map import exit {rc}: {err.strip()}"):
            continue
        segs = read_segments(prefix + ".odomap")
        w = recovered(segs, WALLS)
        check(w <= 1.5, f"{name}: every wall recovered within 1.5 cells (worst point {w:.2f} cells), "
              f"{len(segs)} segments")
        off = worst_off(long_segments(segs), WALLS)
        check(off <= 2.0, f"{name}: no segment longer than 5 cells off the walls (worst point {off:.2f} cells)")
        segs_of[name] = segs
        occ_of[name] = pixels(prefix)
    if "b180" in segs_of and "b360" in segs_of:
        a, b = long_segments(segs_of["b180"]), long_segments(segs_of["b360"])
        d1, d2 = worst_off(b, segs_of["b180"]), worst_off(a, segs_of["b360"])
        check(max(d1, d2) <= 1.5, f"360 beams give the walls of 180 beams: every segment longer than 5 cells of "
              f"each within 1.5 cells of the other's (worst {d1:.2f} and {d2:.2f} cells)")
        (o1, _, g1), (o2, _, g2) = occ_of["b180"], occ_of["b360"]
        if o1.shape == o2.shape and g1 == g2:
            iou = (o1 & o2).sum() / max((o1 | o2).sum(), 1)
            check(iou >= 0.6, f"360 and 180 beams: the same extent, occupied cells overlap {iou * 100:.0f} % "
                  f"(intersection over union, >= 60 %)")
        else:
            check(False, f"360 and 180 beams: grids of different extent {o1.shape} {g1} / {o2.shape} {g2}")
    return occ_of


def wrong_step_case(work):
    """A 360-beam log read 1 deg apart, as the grid builder did before it read the log's
    geometry: its returns disagree and import refuses the grid."""
    log = os.path.join(work, "b360.log")
    prefix = os.path.join(work, "b360-step1")
    rc, err = run(["grid-from-carmen", log, "--out", prefix, "--beam-step", "1"])
    near = returns_near(err)
    check(rc == 0 and "overrides the log's 0.5 deg" in err and near is not None and near < 0.5,
          f"360 beams read 1 deg apart: --beam-step noted, {near and near * 100:.1f} % of the returns within one cell "
          f"of an occupied cell (< 50 %)")
    out = prefix + ".odomap"
    rc, err = run(["import", prefix + ".yaml", "--out", out, "--png", prefix + ".png"])
    check(rc == 2 and "no map in this grid" in err and "specks" in err and not os.path.exists(out)
          and os.path.exists(prefix + ".png"),
          f"360 beams read 1 deg apart: import refused (exit {rc}), why named, nothing written, the PNG drawn: "
          f"{err.strip()}")


def mount_and_range_cases(work, occ_of):
    """PARAM offset reported and not added; PARAM max range as the no-return limit."""
    ang = rule_angles(360)
    log = write(os.path.join(work, "off.log"),
                log_text(360, ang, (("robot_frontlaser_offset", "-0.04"), ("robot_front_laser_max", "50")),
                         no_return="81.91"))
    prefix = os.path.join(work, "off")
    rc, err = run(["grid-from-carmen", log, "--out", prefix])
    ok = rc == 0 and "x -0.04, not added again" in err and "no return at or above 50 m (from PARAM " \
        "robot_front_laser_max 50" in err
    if check(ok, f"PARAM offset -0.04 reported and not added, PARAM max range 50 the no-return limit: {err.strip()}") \
            and "b360" in occ_of:
        o, f, g = pixels(prefix)
        o2, f2, g2 = occ_of["b360"]
        check(np.array_equal(o, o2) and np.array_equal(f, f2) and g == g2,
              "the offset log's grid is the 360-beam grid, cell for cell")


def no_return_cases(work):
    ang = rule_angles(180)
    base = os.path.join(work, "b180")
    o0, f0, g0 = pixels(base)
    # the window: room 8 x 6 m + the grid's 1 m margin; a beam cleared through it would reach 20 m
    rows, cols = o0.shape
    check(cols * RES <= 10.5 and rows * RES <= 8.5, f"no return (81.91) not used: the grid covers "
          f"{cols * RES:.2f} x {rows * RES:.2f} m, the room and its margin")
    log = write(os.path.join(work, "code50.log"), log_text(180, ang, no_return="50.00"))
    prefix = os.path.join(work, "code50")
    rc, err = run(["grid-from-carmen", log, "--out", prefix])
    o1, _, _ = pixels(prefix) if rc == 0 else (o0, None, None)
    check(rc == 0 and "--no-return 50 leaves them out" in err and o1.shape[0] * RES > 15,
          f"a no-return code no PARAM states (50 m): noted naming --no-return 50; used as returns, it clears "
          f"{o1.shape[0] * RES:.1f} m past the window: {err.strip().splitlines()[0] if err.strip() else ''}")
    rc, err = run(["grid-from-carmen", log, "--out", prefix + "-nr", "--no-return", "50"])
    if check(rc == 0 and "(from --no-return)" in err, f"--no-return 50: {err.strip()}"):
        o2, f2, g2 = pixels(prefix + "-nr")
        check(np.array_equal(o2, o0) and np.array_equal(f2, f0) and g2 == g0,
              "--no-return 50 on the 50 m code gives the grid of the log written with 81.91")
    # nothing but no returns
    log = write(os.path.join(work, "none.log"),
                log_text(180, ang, ranges_of=lambda k, x, y, th: ["81.91"] * 180))
    prefix = os.path.join(work, "none")
    rc, err = run(["grid-from-carmen", log, "--out", prefix])
    check(rc == 2 and "nothing to map" in err and "none.log" in err and not os.path.exists(prefix + ".pgm"),
          f"a log with no return at all refused (exit {rc}), nothing written: {err.strip()}")


def import_refusals(work):
    def refused(label, prefix, *expect):
        out = prefix + ".odomap"
        rc, err = run(["import", prefix + ".yaml", "--out", out])
        check(rc == 2 and all(e in err for e in expect) and "Traceback" not in err and not os.path.exists(out),
              f"{label}: import refused (exit {rc}), nothing written, names {expect}: {err.strip()}")

    # no occupied cell
    g = rosmap.Grid(np.zeros((40, 60), dtype=bool), np.ones((40, 60), dtype=bool), RES, (0.0, 0.0, 0.0))
    p = os.path.join(work, "blank")
    rosmap.save(g, p, "no occupied cell")
    refused("a grid without an occupied cell", p, "blank.yaml", "no occupied cell")
    # specks only: the synthetic room's free space with 400 lone occupied cells
    p = os.path.join(work, "specks")
    synth_grid.write(p, walls=np.zeros((0, 4)), specks=400, holes=0.0)
    refused("a grid of specks", p, "specks.yaml", "400 of its 400 occupied cells (100 %, more than 50 %) are specks")
    # two short walls (8 cells): fewer than 4 segments of 10 cells
    p = os.path.join(work, "short")
    synth_grid.write(p, walls=np.array([[1.0, 1.0, 1.4, 1.0], [4.0, 3.0, 4.0, 3.4]]), specks=0, holes=0.0)
    refused("a grid of two short walls", p, "short.yaml", "of its 2 segments are 10 cells (0.5 m) or longer, "
            "fewer than 4")
    # the synthetic room is a map
    p = os.path.join(work, "room")
    synth_grid.write(p)
    rc, err = run(["import", p + ".yaml", "--out", p + ".odomap"])
    check(rc == 0, f"the synthetic room (8 walls, 30 specks) is accepted: {err.strip()}")


def malformed_cases(work):
    ang = rule_angles(180)
    text = log_text(180, ang).splitlines()
    i = next(k for k, ln in enumerate(text) if ln.startswith("FLASER"))
    j = next(k for k, ln in enumerate(text) if k > i and ln.startswith("FLASER"))
    f = text[j].split()
    text[j] = " ".join(["FLASER", "179"] + f[2:181] + f[182:])     # one range fewer, counted
    log = write(os.path.join(work, "mixed.log"), "\n".join(text) + "\n")
    rc, err = run(["grid-from-carmen", log, "--out", os.path.join(work, "mixed")])
    check(rc == 2 and f"mixed.log:{j + 1}: FLASER with 179 beams" in err and f"mixed.log:{i + 1}" in err,
          f"FLASERs of two beam counts refused naming both lines: {err.strip()}")
    log = write(os.path.join(work, "b270.log"), log_text(270, np.radians(-135 + np.arange(270))))
    rc, err = run(["grid-from-carmen", log, "--out", os.path.join(work, "b270")])
    check(rc == 2 and "b270.log:" in err and "no beam-count rule for 270 beams" in err,
          f"270 beams with no PARAM refused with the importer's rule: {err.strip()}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("odoerr", nargs="?", default=None)
    ap.add_argument("--work", default=None)
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix="carmen-grid-")
    os.makedirs(work, exist_ok=True)
    try:
        occ_of = geometry_cases(work, a.odoerr)
        wrong_step_case(work)
        mount_and_range_cases(work, occ_of)
        no_return_cases(work)
        import_refusals(work)
        malformed_cases(work)
    finally:
        if a.work is None:
            shutil.rmtree(work, ignore_errors=True)
    if check.fails:
        print(f"{check.fails} check(s) failed")
        return 1
    print("all carmen grid checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
