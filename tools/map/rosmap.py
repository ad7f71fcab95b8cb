"""rosmap.py: read and write a ROS map_server occupancy grid (a YAML file plus a PGM image).

The YAML reader is deliberately small: it understands exactly the flat `key: value` files
map_server and map_saver write, and rejects anything else (nested blocks, unknown keys,
duplicate keys) with an error naming the file and line, instead of guessing.

Keys (ROS map_server, http://wiki.ros.org/map_server#YAML_format):
  image            path of the image, relative to the YAML file's folder (PGM P5 or P2 only)
  resolution       metres per pixel (> 0)
  origin           [x, y, yaw]: the pose of the LOWER-LEFT pixel's lower-left corner in the
                   world frame (m, m, rad); the image's row 0 is the TOP of the map
  negate           0 or 1: with 0, occupancy p = (255 - v) / 255 (black = occupied)
  occupied_thresh  p above this is occupied
  free_thresh      p below this is free (between the two: unknown)
  mode             optional: trinary (default) | scale | raw
                   - trinary, scale: cells classified by the thresholds (scale only changes
                     what map_server publishes for the in-between cells; occupancy is the same)
                   - raw: the pixel value v is the occupancy in percent (0..100), v > 100 is
                     unknown; negate is ignored, as map_server does
The PGM: magic P5 (binary) or P2 (ASCII), `#` comments anywhere in the header, width,
height, maxval <= 255 (maxval > 255 means 16-bit samples: refused), then width*height
samples, row 0 at the top.
"""

import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "import"))
import import_common  # noqa: E402  (tools/import: the importers' shared file helpers)

KNOWN_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
REQUIRED_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")
MODES = ("trinary", "scale", "raw")
FLOAT_RE = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")


class MapError(Exception):
    """A malformed or unsupported map file; the message names the file and the problem."""


class Grid:
    """An occupancy grid with row 0 at the BOTTOM (y up), in cell states.

    occ, free, unknown: boolean arrays (rows x cols); resolution (m); origin (x, y, yaw) of
    cell (0, 0)'s lower-left corner. source: where it came from (for provenance lines)."""

    def __init__(self, occ, free, resolution, origin, source=""):
        self.occ = np.asarray(occ, dtype=bool)
        self.free = np.asarray(free, dtype=bool) & ~self.occ
        self.unknown = ~(self.occ | self.free)
        self.resolution = float(resolution)
        self.origin = tuple(float(v) for v in origin)
        self.source = source

    @property
    def shape(self):
        return self.occ.shape

    def to_world(self, col, row):
        """Grid coordinates (in cells, continuous; cell (c, r)'s centre is (c + 0.5, r + 0.5))
        to world coordinates (m)."""
        x0, y0, yaw = self.origin
        gx = np.asarray(col, dtype=float) * self.resolution
        gy = np.asarray(row, dtype=float) * self.resolution
        c, s = np.cos(yaw), np.sin(yaw)
        return x0 + c * gx - s * gy, y0 + s * gx + c * gy

    def occupied_centres(self):
        """World coordinates (N x 2) of the occupied cells' centres."""
        r, c = np.nonzero(self.occ)
        x, y = self.to_world(c + 0.5, r + 0.5)
        return np.column_stack([x, y])


def _scalar(text, where, key):
    t = text.strip()
    if len(t) >= 2 and t[0] == t[-1] and t[0] in "'\"":
        return t[1:-1]
    if t == "" or t[0] in "[{|>&*!-" and not FLOAT_RE.match(t):
        raise MapError(f"{where}: '{key}': a value this reader does not understand: '{t}'")
    return t


def read_yaml(path):
    """The flat key: value mapping of a map YAML file (values as strings, origin as a list)."""
    try:
        lines = import_common.read_lines(path)
    except import_common.InputError as e:
        raise MapError(str(e)) from None
    out = {}
    for no, raw in enumerate(lines, start=1):
        where = f"{path}:{no}"
        line = raw.split(" #")[0].rstrip() if not raw.lstrip().startswith("#") else ""
        if not line.strip() or line.strip() == "---":
            continue
        if line[0] in " \t":
            raise MapError(f"{where}: indented line: nested YAML is not a map_server map file")
        if ":" not in line:
            raise MapError(f"{where}: expected 'key: value', got '{line.strip()}'")
        key, value = line.split(":", 1)
        key = key.strip()
        if key not in KNOWN_KEYS:
            raise MapError(f"{where}: unknown key '{key}' (a map_server map has {', '.join(KNOWN_KEYS)})")
        if key in out:
            raise MapError(f"{where}: key '{key}' given twice")
        value = value.strip()
        if key == "origin":
            if not (value.startswith("[") and value.endswith("]")):
                raise MapError(f"{where}: 'origin' must be a list [x, y, yaw], got '{value}'")
            out[key] = ([v.strip() for v in value[1:-1].split(",")], where)
        else:
            out[key] = (_scalar(value, where, key), where)
    for k in REQUIRED_KEYS:
        if k not in out:
            raise MapError(f"{path}: missing key '{k}'")
    return out


def _number(value, where, key, lo=None, hi=None, lo_open=False):
    if not FLOAT_RE.match(value):
        raise MapError(f"{where}: '{key}': '{value}' is not a number")
    v = float(value)
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise MapError(f"{where}: '{key}' = {value} is out of range")
    if hi is not None and v > hi:
        raise MapError(f"{where}: '{key}' = {value} is out of range")
    return v


def _header_tokens(data, path, count):
    """The first `count` whitespace-separated header tokens after skipping # comments, and
    the offset just after the single whitespace byte that ends the last one."""
    toks, i, n = [], 0, len(data)
    while len(toks) < count:
        while i < n and data[i:i + 1].isspace():
            i += 1
        if i < n and data[i:i + 1] == b"#":
            while i < n and data[i:i + 1] not in (b"\n", b"\r"):
                i += 1
            continue
        if i >= n:
            raise MapError(f"{path}: truncated PGM header ({len(toks)} of {count} fields)")
        j = i
        while j < n and not data[j:j + 1].isspace() and data[j:j + 1] != b"#":
            j += 1
        toks.append(data[i:j])
        i = j
    if i >= n:
        if toks[0] == b"P2":
            return toks, i
        raise MapError(f"{path}: truncated PGM: the header ends without pixel data")
    return toks, i + 1  # exactly one whitespace byte after maxval


def read_pgm(path):
    """The PGM's pixels (uint8, rows x cols, row 0 = top of the image)."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise MapError(f"{path}: cannot read the map image: {e.strerror or e}") from None
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        raise MapError(f"{path}: not a PGM image (magic '{magic.decode('latin-1')}'; "
                       f"only binary P5 and ASCII P2 PGM are supported)")
    toks, off = _header_tokens(data, path, 4)
    try:
        w, h, maxval = (int(t) for t in toks[1:4])
    except ValueError:
        raise MapError(f"{path}: PGM header: width, height, maxval must be integers, "
                       f"got {b' '.join(toks[1:4]).decode('latin-1')}") from None
    if w <= 0 or h <= 0:
        raise MapError(f"{path}: PGM size {w} x {h}: empty image")
    if maxval > 255:
        raise MapError(f"{path}: 16-bit PGM (maxval {maxval}) is not supported: save the map with 8 bits")
    if maxval <= 0:
        raise MapError(f"{path}: PGM maxval {maxval} is not in 1..255")
    if magic == b"P5":
        body = data[off:]
        if len(body) < w * h:
            raise MapError(f"{path}: truncated PGM: {w} x {h} needs {w * h} bytes of pixels, got {len(body)}")
        if len(body) > w * h:
            raise MapError(f"{path}: PGM of the wrong size: {w} x {h} needs {w * h} bytes of pixels, "
                           f"got {len(body)} ({len(body) - w * h} extra)")
        px = np.frombuffer(body, dtype=np.uint8).reshape(h, w)
    else:
        text = re.sub(rb"#[^\n\r]*", b" ", data[off:])
        vals = text.split()
        if len(vals) < w * h:
            raise MapError(f"{path}: truncated PGM: {w} x {h} needs {w * h} samples, got {len(vals)}")
        if len(vals) > w * h:
            raise MapError(f"{path}: PGM of the wrong size: {w} x {h} needs {w * h} samples, got {len(vals)}")
        try:
            arr = np.array([int(v) for v in vals], dtype=np.int64)
        except ValueError:
            raise MapError(f"{path}: P2 PGM: a sample is not an integer") from None
        px = arr.reshape(h, w)
    if int(px.max()) > maxval:
        raise MapError(f"{path}: a sample ({int(px.max())}) exceeds maxval {maxval}")
    if maxval != 255:  # rescale to 0..255 as an 8-bit image would hold it
        px = np.rint(px.astype(float) * 255.0 / maxval)
    return px.astype(np.uint8)


def load(yaml_path):
    """The Grid of a map_server map (YAML + PGM)."""
    y = read_yaml(yaml_path)
    res = _number(y["resolution"][0], y["resolution"][1], "resolution", lo=0.0, lo_open=True)
    ovals, owhere = y["origin"]
    if len(ovals) != 3:
        raise MapError(f"{owhere}: 'origin' must have 3 values [x, y, yaw], got {len(ovals)}")
    origin = [_number(v, owhere, "origin") for v in ovals]
    negate = y["negate"][0]
    if negate not in ("0", "1"):
        raise MapError(f"{y['negate'][1]}: 'negate' must be 0 or 1, got '{negate}'")
    occ_t = _number(y["occupied_thresh"][0], y["occupied_thresh"][1], "occupied_thresh", 0.0, 1.0)
    free_t = _number(y["free_thresh"][0], y["free_thresh"][1], "free_thresh", 0.0, 1.0)
    if free_t > occ_t:
        raise MapError(f"{yaml_path}: free_thresh {free_t} is above occupied_thresh {occ_t}")
    mode = y["mode"][0] if "mode" in y else "trinary"
    if mode not in MODES:
        raise MapError(f"{y['mode'][1]}: unsupported mode '{mode}' (trinary, scale or raw)")
    image = y["image"][0]
    img_path = image if os.path.isabs(image) else os.path.join(os.path.dirname(os.path.abspath(yaml_path)), image)
    if not os.path.exists(img_path):
        raise MapError(f"{y['image'][1]}: the image '{image}' does not exist ({img_path})")
    px = read_pgm(img_path).astype(float)
    if mode == "raw":
        known = px <= 100
        p = np.where(known, px / 100.0, -1.0)
        occ = known & (p > occ_t)
        free = known & (p < free_t)
    else:
        p = (255.0 - px) / 255.0 if negate == "0" else px / 255.0
        occ = p > occ_t
        free = p < free_t
    # image row 0 is the top: flip so that row 0 is the bottom (y up)
    return Grid(occ[::-1], free[::-1], res, origin, source=os.path.abspath(yaml_path))


def save(grid, prefix, comment="odoerr"):
    """Writes PREFIX.pgm (P5; 0 occupied, 254 free, 205 unknown, as map_saver does) and
    PREFIX.yaml (trinary, occupied_thresh 0.65, free_thresh 0.196). Returns the two paths."""
    img = np.full(grid.shape, 205, dtype=np.uint8)
    img[grid.free] = 254
    img[grid.occ] = 0
    img = img[::-1]
    h, w = img.shape
    pgm, yml = prefix + ".pgm", prefix + ".yaml"
    with open(pgm, "wb") as f:
        f.write(b"P5\n# " + comment.encode("ascii", "replace") + b"\n" + f"{w} {h}\n255\n".encode() + img.tobytes())
    x, y, yaw = grid.origin
    with open(yml, "w", encoding="utf-8") as f:
        f.write(f"image: {os.path.basename(pgm)}\nmode: trinary\nresolution: {grid.resolution:.6f}\n"
                f"origin: [{x:.6f}, {y:.6f}, {yaw:.6f}]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return pgm, yml
