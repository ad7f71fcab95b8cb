#!/usr/bin/env python3
"""odoerr_map.py: the map tool chain behind `odoerr map import|render|grid-from-carmen`.

    odoerr_map.py import MAP.yaml --out MAP.odomap [--png P] [--method skeleton|ransac] [--faces]
    odoerr_map.py render MAP.odomap [--grid MAP.yaml] --out P.png
    odoerr_map.py grid-from-carmen LOG --out PREFIX [--resolution R] [--max-range M]
                  [--max-scans N] [--no-return M] [--beam-step DEG]
    odoerr_map.py compare MAP.yaml [MAP.yaml...]   (the extraction methods side by side)
    odoerr_map.py scan-residuals MAP.odomap LOG [--every K] [--no-return M] [--beam-step DEG]
                  (the scans of a corrected CARMEN log against the map, at the corrected poses)

Exit status: 0 done, 2 bad input (the message names the file and the problem), 1 other.
docs/map-format.md documents the format and the methods.
"""

import argparse
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import carmen_grid  # noqa: E402
import extract  # noqa: E402
import odomap  # noqa: E402
import rosmap  # noqa: E402

PROG = "odoerr map"


class Parser(argparse.ArgumentParser):
    def error(self, message):
        sys.stderr.write(f"{self.prog}: {message}\n")
        sys.exit(2)


def fit_line(segs, fm):
    s = (f"{len(segs)} segments; fit to {fm['cells']} occupied cells: RMS {fm['rms_m'] * 100:.2f} cm, "
         f"{fm['within_one_cell'] * 100:.1f} % within one cell")
    if "cells_kept" in fm:
        s += (f" (the {fm['cells_kept']} outside specks: RMS {fm['rms_m_kept'] * 100:.2f} cm, "
              f"{fm['within_one_cell_kept'] * 100:.1f} %)")
    return s


def cmd_import(a):
    g = rosmap.load(a.map)
    params = {"faces": True} if a.faces else {}
    if a.faces and a.method != "skeleton":
        raise rosmap.MapError("--faces applies to the skeleton method only")
    segs, st = extract.extract(g, a.method, **params)
    why = extract.map_problems(g, segs, st)
    if why:
        drawn = ""
        if a.png and st["occupied_cells"]:
            import render
            render.render(a.png, segs, g, title=f"{os.path.basename(a.map)}: refused, {len(segs)} segments")
            drawn = f" (drawn in {a.png})"
        raise rosmap.MapError(f"{a.map}: no map in this grid: " + "; ".join(why) + f"{drawn}. Nothing written to "
                              f"{a.out}. A grid built from a laser log gives this when its scans disagree: a "
                              f"wrong beam geometry, poses that are not corrected, or cells too small for the "
                              f"scans (docs/map-format.md)")
    fm = extract.fit_metrics(g, segs, st["params"]["min_cells"])
    p = st["params"]
    meta = [("source", f"odoerr map import {os.path.abspath(a.map)}"),
            ("extraction", f"{a.method} " + " ".join(f"{k}={v}" for k, v in sorted(p.items()))),
            ("fit", f"rms_m={fm['rms_m']:.4f} within_one_cell={fm['within_one_cell']:.4f} "
                    f"occupied_cells={fm['cells']} dropped_speck_cells={st['dropped_cells']} "
                    f"rms_m_outside_specks={fm.get('rms_m_kept', float('nan')):.4f} "
                    f"within_one_cell_outside_specks={fm.get('within_one_cell_kept', float('nan')):.4f}"),
            ("segments", str(len(segs)))]
    odomap.write(a.out, segs, meta, odomap.grid_line(g),
                 comments=["line map extracted from a ROS map_server occupancy grid (docs/map-format.md)"])
    msg = f"{PROG} import: {a.map}: {fit_line(segs, fm)} ({st['dropped_cells']} cells in specks dropped); " \
          f"{st['seconds']:.2f} s; wrote {a.out}"
    if a.png:
        import render
        render.render(a.png, segs, g, title=f"{os.path.basename(a.map)}: {len(segs)} segments ({a.method})")
        msg += f" and {a.png}"
    print(msg, file=sys.stderr)
    return 0


def cmd_render(a):
    segs = odomap.read_walls(a.map)
    g = rosmap.load(a.grid) if a.grid else None
    import render
    render.render(a.out, segs, g, title=f"{os.path.basename(a.map)}: {len(segs)} segments")
    line = f"{PROG} render: {len(segs)} segments"
    if g is not None and g.occ.any():
        line += "; " + fit_line(segs, extract.fit_metrics(g, segs)).split("; ", 1)[1]
    print(f"{line}; wrote {a.out}", file=sys.stderr)
    return 0


def cmd_grid(a):
    if a.resolution <= 0 or a.max_range <= 0:
        raise rosmap.MapError("--resolution and --max-range must be > 0")
    if a.max_scans is not None and a.max_scans < 1:
        raise rosmap.MapError("--max-scans must be >= 1")
    if a.no_return is not None and not a.no_return > 0:
        raise rosmap.MapError("--no-return must be > 0")
    if a.beam_step is not None and not 0 < a.beam_step <= 10:
        raise rosmap.MapError("--beam-step must be in (0, 10] degrees")
    d = os.path.dirname(os.path.abspath(a.out))
    if not os.path.isdir(d):
        raise rosmap.MapError(f"{a.out}: the folder {d} does not exist")
    g, st = carmen_grid.grid_from_log(a.log, a.out, a.resolution, a.max_range, a.max_scans, a.no_return,
                                      a.beam_step)
    la = st["laser"]
    if st["step_override"] is not None and abs(math.radians(st["step_override"]) - la.step) > 1e-12:
        print(f"{PROG} grid-from-carmen: note: --beam-step {st['step_override']:g} overrides the log's "
              f"{math.degrees(la.step):.6g} deg ({la.beam_notes[0].split(' from ')[-1]})", file=sys.stderr)
    if st["pile_up"] is not None and a.no_return is None:
        low, what = st["pile_up"]
        print(f"{PROG} grid-from-carmen: note: {what}, the top of the readings below the no-return limit: a "
              f"no-return code the log does not state? They are used as returns (beyond --max-range they clear "
              f"up to it); --no-return {low:g} leaves them out", file=sys.stderr)
    print(f"{PROG} grid-from-carmen: {st['scans']} scans of {st['beams']}; {st['mount']}; no return at or above "
          f"{la.no_return:g} m (from {la.no_return_src}): {st['no_returns']} of {st['readings']} readings; "
          f"{st['read_seconds']:.1f} s to read; of the {st['returns']} returns within {a.max_range:g} m, "
          f"{st['returns_on'] * 100:.1f} % land on an occupied cell, {st['returns_near'] * 100:.1f} % within one "
          f"cell of one", file=sys.stderr)
    print(f"{PROG} grid-from-carmen: {st['scans']} scans -> {st['cols']} x {st['rows']} cells of "
          f"{a.resolution:g} m: {st['occupied']} occupied, {st['free']} free, {st['unknown']} unknown; "
          f"{st['seconds']:.1f} s; wrote {st['pgm']} and {st['yaml']}", file=sys.stderr)
    return 0


def cmd_compare(a):
    print("| map | method | segments | RMS (cm): all (outside specks) | within one cell: all (outside specks) | time (s) |")
    print("|---|---|---|---|---|---|")
    for path in a.maps:
        g = rosmap.load(path)
        for m in extract.METHODS:
            segs, st = extract.extract(g, m)
            fm = extract.fit_metrics(g, segs, st["params"]["min_cells"])
            print(f"| {a.label or path} | {m} | {len(segs)} | {fm['rms_m'] * 100:.2f} "
                  f"({fm.get('rms_m_kept', float('nan')) * 100:.2f}) | {fm['within_one_cell'] * 100:.1f} % "
                  f"({fm.get('within_one_cell_kept', float('nan')) * 100:.1f} %) | {st['seconds']:.2f} |")
    return 0


def cmd_residuals(a):
    import scan_check
    segs = odomap.read_walls(a.map)
    log = carmen_grid.read_log(a.log, a.max_scans, a.no_return)
    geo = log.geometry
    if a.beam_step is not None:
        geo = carmen_grid.Geometry(geo.start, math.radians(a.beam_step), geo.mount)
    scans = log.scans
    res, missed = scan_check.residuals(scans, segs, geo, a.max_range, a.every)
    s = scan_check.summary(res, missed)
    print(f"{PROG} scan-residuals: {a.map} against {len(scans[::a.every])} scans of {a.log}: {s['returns']} returns "
          f"hit a segment ({s['no_segment']} hit none); measured - predicted: median {s['median_m'] * 100:.2f} cm, "
          f"MAD {s['mad_m'] * 100:.2f} cm, {s['within_10cm'] * 100:.1f} % within 10 cm, "
          f"{s['within_30cm'] * 100:.1f} % within 30 cm")
    return 0


def main(argv=None):
    ap = Parser(prog=PROG, description="maps: import a ROS occupancy grid, render, build a grid from a CARMEN log")
    sub = ap.add_subparsers(dest="cmd", required=True, parser_class=Parser)
    p = sub.add_parser("import", help="ROS map_server map (YAML + PGM) -> odomap line map")
    p.add_argument("map", metavar="MAP.yaml")
    p.add_argument("--out", required=True, metavar="MAP.odomap")
    p.add_argument("--png", metavar="P.png", help="also draw the segments over the grid")
    p.add_argument("--method", choices=sorted(extract.METHODS), default="skeleton")
    p.add_argument("--faces", action="store_true",
                   help="put each segment on its band's free-facing side (where a laser's returns are) "
                        "instead of the band's middle")
    p.set_defaults(fn=cmd_import)
    p = sub.add_parser("render", help="draw a map's segments (over its grid) as a PNG")
    p.add_argument("map", metavar="MAP.odomap", help="an odomap, or an odolog with wall records")
    p.add_argument("--grid", metavar="MAP.yaml")
    p.add_argument("--out", required=True, metavar="P.png")
    p.set_defaults(fn=cmd_render)
    p = sub.add_parser("grid-from-carmen", help="occupancy grid (PGM + YAML) from a corrected CARMEN log")
    p.add_argument("log", metavar="LOG")
    p.add_argument("--out", required=True, metavar="PREFIX", help="writes PREFIX.pgm and PREFIX.yaml")
    p.add_argument("--resolution", type=float, default=0.05, metavar="R", help="cell size (m), default 0.05")
    p.add_argument("--max-range", type=float, default=20.0, metavar="M", help="usable range (m), default 20")
    p.add_argument("--max-scans", type=int, default=None, metavar="N", help="only the first N scans")
    p.add_argument("--no-return", type=float, default=None, metavar="M",
                   help="readings >= M (m) are no return and not used; default PARAM robot_front_laser_max, "
                        "else 80 (as the importer)")
    p.add_argument("--beam-step", type=float, default=None, metavar="DEG",
                   help="override the angle between beams (deg); default the log's (beam count, PARAM)")
    p.set_defaults(fn=cmd_grid)
    p = sub.add_parser("compare", help="the extraction methods side by side (a Markdown table)")
    p.add_argument("maps", nargs="+", metavar="MAP.yaml")
    p.add_argument("--label", default=None)
    p.set_defaults(fn=cmd_compare)
    p = sub.add_parser("scan-residuals", help="a map against a corrected CARMEN log's scans at its poses")
    p.add_argument("map", metavar="MAP.odomap")
    p.add_argument("log", metavar="LOG")
    p.add_argument("--every", type=int, default=1, metavar="K", help="every K-th scan (default 1)")
    p.add_argument("--max-scans", type=int, default=None, metavar="N")
    p.add_argument("--max-range", type=float, default=20.0, metavar="M")
    p.add_argument("--no-return", type=float, default=None, metavar="M")
    p.add_argument("--beam-step", type=float, default=None, metavar="DEG")
    p.set_defaults(fn=cmd_residuals)
    a = ap.parse_args(argv)
    if getattr(a, "every", 1) < 1:
        ap.error("--every must be >= 1")
    try:
        return a.fn(a)
    except (rosmap.MapError, odomap.OdomapError, carmen_grid.LogError) as e:
        print(f"{PROG} {a.cmd}: error: {e}", file=sys.stderr)
        return 2
    except ValueError as e:
        print(f"{PROG} {a.cmd}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    try:
        sys.exit(main())
    except KeyboardInterrupt:
        sys.exit(130)
