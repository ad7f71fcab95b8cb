"""odomap.py: write and read the odomap v1 line-map format (docs/map-format.md).

    odomap 1
    # comments anywhere (a `#` starts a comment that runs to the end of the line)
    meta KEY VALUE...                      provenance, free text after KEY
    grid RES X0 Y0 YAW COLS ROWS PATH      optional: the occupancy grid the map came from
    segment X1 Y1 X2 Y2                    one wall (m, world frame); any number

A reader rejects a file whose first record is not `odomap 1`, a `segment` without exactly
four finite numbers, or a zero-length segment, naming FILE:LINE; other record types are
skipped and counted (so that newer writers stay readable). read_walls() also accepts an
odolog v1 file and returns its `wall` records, as the C++ reader (sim_host map_io) does.
"""

import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "import"))
import import_common  # noqa: E402  (tools/import: the importers' shared file helpers)


class OdomapError(Exception):
    """A malformed map file; the message names FILE:LINE."""


def write(path, segs, meta=(), grid_line=None, comments=()):
    """Writes the segments (M x 4, metres) with meta lines [(key, value)] through a temporary
    file (a failed write leaves no half file)."""
    lines = ["odomap 1"]
    lines += [f"# {c}" for c in comments]
    for k, v in meta:
        if not k or any(ch.isspace() for ch in k):
            raise ValueError(f"meta key '{k}' must be one word")
        lines.append(f"meta {k} {' '.join(str(v).split())}")
    if grid_line is not None:
        lines.append("grid " + grid_line)
    for s in np.asarray(segs, dtype=float).reshape(-1, 4):
        if not np.all(np.isfinite(s)):
            raise ValueError(f"segment {s} is not finite")
        lines.append("segment %.4f %.4f %.4f %.4f" % tuple(s))
    text = "\n".join(lines) + "\n"
    try:
        import_common.write_atomic(path, text)
    except import_common.InputError as e:
        raise OdomapError(str(e)) from None


def grid_line(grid):
    """The `grid` provenance record's fields for a rosmap.Grid."""
    rows, cols = grid.shape
    x, y, yaw = grid.origin
    return f"{grid.resolution:.6f} {x:.6f} {y:.6f} {yaw:.6f} {cols} {rows} {grid.source or '-'}"


def _numbers(toks, where, what):
    out = []
    for t in toks:
        try:
            v = float(t)
        except ValueError:
            raise OdomapError(f"{where}: '{what}': '{t}' is not a number") from None
        if not math.isfinite(v):
            raise OdomapError(f"{where}: '{what}': '{t}' is not finite")
        out.append(v)
    return out


def read(path):
    """(segments M x 4, meta dict, skipped record count) of an odomap file."""
    try:
        lines = import_common.read_lines(path)
    except import_common.InputError as e:
        raise OdomapError(str(e)) from None
    segs, meta, skipped, header = [], {}, 0, False
    for no, raw in enumerate(lines, start=1):
        where = f"{path}:{no}"
        toks = raw.split("#", 1)[0].split()
        if not toks:
            continue
        if not header:
            if toks != ["odomap", "1"]:
                raise OdomapError(f"{where}: the first record must be 'odomap 1', got '{' '.join(toks)}'")
            header = True
            continue
        kind = toks[0]
        if kind == "segment":
            if len(toks) != 5:
                raise OdomapError(f"{where}: 'segment' takes 4 numbers (X1 Y1 X2 Y2), got {len(toks) - 1}")
            s = _numbers(toks[1:], where, "segment")
            if s[0] == s[2] and s[1] == s[3]:
                raise OdomapError(f"{where}: zero-length segment")
            segs.append(s)
        elif kind == "meta":
            if len(toks) < 2:
                raise OdomapError(f"{where}: 'meta' takes a KEY")
            meta[toks[1]] = " ".join(toks[2:])
        elif kind == "grid":
            if len(toks) < 7:
                raise OdomapError(f"{where}: 'grid' takes RES X0 Y0 YAW COLS ROWS [PATH]")
            _numbers(toks[1:7], where, "grid")
            meta["grid"] = " ".join(toks[1:])
        else:
            skipped += 1
    if not header:
        raise OdomapError(f"{path}: empty file: no 'odomap 1' record")
    return np.array(segs, dtype=float).reshape(-1, 4), meta, skipped


def read_walls(path):
    """Segments of an odomap file, or the `wall` records of an odolog file (M x 4)."""
    try:
        with open(path, "r", encoding="utf-8") as f:
            head = ""
            for line in f:
                head = line.split("#", 1)[0].strip()
                if head:
                    break
    except (OSError, UnicodeDecodeError) as e:
        raise OdomapError(f"{path}: cannot read: {e}") from None
    if head.startswith("odomap"):
        return read(path)[0]
    if head.split() == ["odolog", "1"]:
        walls = []
        with open(path, "r", encoding="utf-8") as f:
            for no, raw in enumerate(f, start=1):
                toks = raw.split("#", 1)[0].split()
                if toks and toks[0] == "wall":
                    if len(toks) != 5:
                        raise OdomapError(f"{path}:{no}: 'wall' takes 4 numbers")
                    walls.append(_numbers(toks[1:], f"{path}:{no}", "wall"))
        return np.array(walls, dtype=float).reshape(-1, 4)
    raise OdomapError(f"{path}: neither an odomap nor an odolog file (first record '{head}')")
