#!/usr/bin/env python3
"""The map tools (tools/map) without any real data: extraction on synthetic grids with
known walls, the ROS map reader's conventions and its refusals, the odomap format.
Exit 0 when every check passes, 1 otherwise (each failure printed)."""

import os
import subprocess
import sys
import tempfile

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, here)
sys.path.insert(0, os.path.join(here, "..", "..", "tools", "map"))
import extract  # noqa: E402
import odomap  # noqa: E402
import rosmap  # noqa: E402
import synth_grid  # noqa: E402

SCRIPT = os.path.join(here, "..", "..", "tools", "map", "odoerr_map.py")
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def seg_dist(pts, segs):
    return extract.point_segment_distance(np.asarray(pts, dtype=float), np.asarray(segs, dtype=float))


def sample(seg, step):
    x1, y1, x2, y2 = seg
    n = max(int(np.ceil(np.hypot(x2 - x1, y2 - y1) / step)), 1)
    t = np.linspace(0, 1, n + 1)
    return np.column_stack([x1 + t * (x2 - x1), y1 + t * (y2 - y1)])


def synthetic_case(tmp, thick, holes, specks, seed, res=0.05):
    name = f"thick {thick} cells, {holes * 100:g} % holes, {specks} specks, seed {seed}"
    prefix = os.path.join(tmp, f"syn-{thick}-{seed}")
    synth_grid.write(prefix, res=res, thick=thick, holes=holes, specks=specks, seed=seed)
    g = rosmap.load(prefix + ".yaml")  # through the PGM, as a user's map
    segs, st = extract.extract(g)
    fm = extract.fit_metrics(g, segs, st["params"]["min_cells"])
    # every true wall recovered within one cell: all its points, end points included, lie
    # within one cell of an extracted segment running along it (within 10 deg)
    for i, w in enumerate(synth_grid.WALLS):
        pts = sample(w, res / 2)
        wd = np.array([w[2] - w[0], w[3] - w[1]]) / np.hypot(w[2] - w[0], w[3] - w[1])
        par = []
        for s in segs:
            sd = np.array([s[2] - s[0], s[3] - s[1]])
            ln = np.hypot(*sd)
            if ln > 0 and abs(sd @ wd) / ln > np.cos(np.radians(10)):
                par.append(s)
        d = seg_dist(pts, np.array(par).reshape(-1, 4)) if par else np.full(len(pts), np.inf)
        check(d.max() <= res + 1e-9, f"{name}: wall {i} {tuple(w)} recovered within one cell "
              f"(worst point {d.max() / res:.2f} cells)")
    # no spurious segment: every extracted segment longer than 3 cells lies within 1.5 cells
    # of a true wall along its whole length (specks may only give shorter ones)
    long_segs = [s for s in segs if np.hypot(s[2] - s[0], s[3] - s[1]) > 3 * res]
    worst = max((seg_dist(sample(s, res / 2), synth_grid.WALLS).max() for s in long_segs), default=0.0)
    check(worst <= 1.5 * res, f"{name}: no spurious segment longer than 3 cells (worst {worst / res:.2f} cells off a wall)")
    check(len(segs) <= 3 * len(synth_grid.WALLS), f"{name}: {len(segs)} segments for {len(synth_grid.WALLS)} walls (<= 3x)")
    if thick <= 2:  # walls up to 3 cells wide (a wall on a cell boundary covers one more)
        check(fm["within_one_cell_kept"] >= 0.95, f"{name}: {fm['within_one_cell_kept'] * 100:.1f} % of the cells "
              f"outside specks within one cell (RMS {fm['rms_m_kept'] * 100:.2f} cm)")
    else:  # a 4-cell band has half its cells 1.5 cells off its centre line: RMS 1.12 cells
        check(fm["rms_m_kept"] <= 1.25 * res, f"{name}: RMS {fm['rms_m_kept'] * 100:.2f} cm of the cells outside "
              f"specks (<= 1.25 cells; {fm['within_one_cell_kept'] * 100:.1f} % within one cell)")
    return len(segs), fm


def doorway_case(tmp, res=0.05):
    """A 0.3 m doorway (6 cells, less than the 8-cell bridge reach) between two collinear
    walls stays open: the bridge only joins across occupied cells."""
    walls = np.array([[0.5, 1.0, 2.5, 1.0], [2.8, 1.0, 5.0, 1.0], [0.5, 1.0, 0.5, 4.0]])
    g = synth_grid.render_grid(res=res, thick=2, holes=0.05, specks=0, seed=5, walls=walls)
    segs, _ = extract.extract(g)
    # the walls are drawn one cell past their ends (thickness 2): free cells from 2.55 to 2.75 m
    d = seg_dist(np.array([[2.65, 1.0]]), segs)[0]
    check(d > 1.5 * res, f"a 0.3 m doorway stays open (its middle is {d / res:.1f} cells from any segment, > 1.5)")
    ok = all(seg_dist(sample(w, res / 2), segs).max() <= res + 1e-9 for w in walls)
    check(ok, "the doorway's walls are recovered within one cell")


def faces_case(res=0.05):
    """A room as a laser sees it: each wall a band of occupied cells from its surface to two
    cells behind it (returns scatter past the surface), free cells in front. With faces=True
    the segments lie on the surfaces (within 0.6 cell); the default centre
    lines lie about one cell behind them."""
    cols, rows = int(6 / res), int(5 / res)
    c, r = np.meshgrid(np.arange(cols), np.arange(rows))
    x, y = (c + 0.5) * res, (r + 0.5) * res
    inside = (x > 1) & (x < 5) & (y > 1) & (y < 4)
    outer = (x > 1 - 3 * res) & (x < 5 + 3 * res) & (y > 1 - 3 * res) & (y < 4 + 3 * res)
    g = rosmap.Grid(outer & ~inside, inside, res, (0.0, 0.0, 0.0), source="faces")
    surfaces = np.array([[1.2, 1, 4.8, 1], [5, 1.2, 5, 3.8], [4.8, 4, 1.2, 4], [1, 3.8, 1, 1.2]])
    worst = {}
    for faces in (False, True):
        segs, _ = extract.extract(g, faces=faces)
        worst[faces] = max(seg_dist(sample(w, res / 2), segs).max() for w in surfaces)
    # the surface is the cells' edge here, half a cell from the free-facing cells' centres
    check(worst[True] <= 0.6 * res and worst[True] < worst[False],
          f"faces=True puts the segments on the surfaces: worst {worst[True] / res:.2f} cells "
          f"(centre lines: {worst[False] / res:.2f} cells)")


def write_yaml(path, image="m.pgm", drop=None, extra=""):
    keys = dict(image=image, resolution="0.1", origin="[-1.0, -2.0, 0.0]", negate="0",
                occupied_thresh="0.65", free_thresh="0.196")
    if drop:
        del keys[drop]
    with open(path, "w") as f:
        f.write("".join(f"{k}: {v}\n" for k, v in keys.items()) + extra)


def run_import(yaml_path, out):
    p = subprocess.run([sys.executable, SCRIPT, "import", yaml_path, "--out", out],
                       capture_output=True, text=True)
    return p.returncode, p.stderr


def reader_cases(tmp):
    # orientation: the image's top row is the map's top; origin = the lower-left pixel
    img = np.full((4, 3), 254, dtype=np.uint8)
    img[0, 2] = 0            # top row, right column
    with open(os.path.join(tmp, "m.pgm"), "wb") as f:
        f.write(b"P5\n# a comment\n3 4\n# another\n255\n" + img.tobytes())
    y = os.path.join(tmp, "m.yaml")
    write_yaml(y, extra="mode: trinary\n")
    g = rosmap.load(y)
    c = g.occupied_centres()
    check(len(c) == 1 and np.allclose(c[0], [-1.0 + 2.5 * 0.1, -2.0 + 3.5 * 0.1]),
          f"P5 with comments: top-right pixel at world {c.tolist()} (expected [-0.75, -1.65])")
    # the same image as ASCII P2
    with open(os.path.join(tmp, "a.pgm"), "w") as f:
        f.write("P2\n# ascii\n3 4\n255\n" + "\n".join(" ".join(str(v) for v in row) for row in img) + "\n")
    ya = os.path.join(tmp, "a.yaml")
    write_yaml(ya, image="a.pgm")
    ga = rosmap.load(ya)
    check(np.array_equal(ga.occ, g.occ) and np.array_equal(ga.free, g.free), "P2 reads as the same grid as P5")
    # negate 1 turns it round
    yn = os.path.join(tmp, "n.yaml")
    with open(yn, "w") as f:
        f.write(open(y).read().replace("negate: 0", "negate: 1"))
    check(int(rosmap.load(yn).occ.sum()) == 11, "negate 1: the 11 white pixels are occupied")

    def refused(label, yaml_path, *expect):
        rc, err = run_import(yaml_path, os.path.join(tmp, "out.odomap"))
        ok = rc == 2 and all(e in err for e in expect) and "Traceback" not in err
        check(ok, f"{label}: exit {rc}, message names {expect}: {err.strip()}")

    for key in ("resolution", "origin", "image"):
        p = os.path.join(tmp, f"no-{key}.yaml")
        write_yaml(p, drop=key)
        refused(f"missing key '{key}'", p, p, f"missing key '{key}'")
    p = os.path.join(tmp, "mode.yaml")
    write_yaml(p, extra="mode: fancy\n")
    refused("unsupported mode", p, p, "unsupported mode 'fancy'")
    p = os.path.join(tmp, "unknown.yaml")
    write_yaml(p, extra="colour: red\n")
    refused("unknown key", p, p, "unknown key 'colour'")
    body = img.tobytes()
    for label, data, expect in (
            ("wrong size (extra bytes)", b"P5\n3 4\n255\n" + body + b"\0\0\0", "wrong size"),
            ("truncated", b"P5\n3 4\n255\n" + body[:7], "truncated"),
            ("16-bit", b"P5\n3 4\n65535\n" + body * 2, "16-bit"),
            ("not a PGM (PNG magic)", b"\x89PNG\r\n\x1a\n", "not a PGM"),
            ("truncated header", b"P5\n3", "truncated PGM header")):
        name = "-".join(label.split()[:2]).strip("(-)") + ".pgm"
        with open(os.path.join(tmp, name), "wb") as f:
            f.write(data)
        p = os.path.join(tmp, name + ".yaml")
        write_yaml(p, image=name)
        refused(f"PGM {label}", p, os.path.join(tmp, name), expect)


def odomap_cases(tmp):
    segs = np.array([[0, 0, 1, 0], [1, 0, 1, 2.5]], dtype=float)
    p = os.path.join(tmp, "rt.odomap")
    odomap.write(p, segs, [("source", "test")], "0.05 0 0 0 10 10 -")
    back, meta, skipped = odomap.read(p)
    check(np.allclose(back, segs) and meta.get("source") == "test" and skipped == 0, "odomap round trip")
    with open(p, "a") as f:
        f.write("segment 1 2 3\n")
    try:
        odomap.read(p)
        check(False, "odomap: a 3-number segment refused")
    except odomap.OdomapError as e:
        check(f"{p}:" in str(e) and "4 numbers" in str(e), f"odomap: a 3-number segment refused: {e}")
    lg = os.path.join(tmp, "w.odolog")
    with open(lg, "w") as f:
        f.write("odolog 1\ndrive diff\nwall 0 0 4 0\nwall 4 0 4 3  # a comment\n")
    w = odomap.read_walls(lg)
    check(w.shape == (2, 4) and np.allclose(w[1], [4, 0, 4, 3]), "an odolog's wall records read as a map")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        rows = []
        for thick, holes, specks, seed in ((1, 0.0, 0, 1), (2, 0.05, 30, 2), (3, 0.05, 30, 3), (2, 0.10, 60, 4)):
            n, fm = synthetic_case(tmp, thick, holes, specks, seed)
            rows.append((thick, holes, specks, n, fm))
        for thick, holes, specks, n, fm in rows:
            print(f"  synthetic thick={thick} holes={holes:g} specks={specks}: {n} segments, RMS "
                  f"{fm['rms_m'] * 100:.2f} cm (outside specks {fm['rms_m_kept'] * 100:.2f} cm), within one cell "
                  f"{fm['within_one_cell'] * 100:.1f} % ({fm['within_one_cell_kept'] * 100:.1f} %)")
        doorway_case(tmp)
        faces_case()
        reader_cases(tmp)
        odomap_cases(tmp)
    if failures:
        print(f"{len(failures)} check(s) failed")
        return 1
    print("all map tool checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
