"""carmen_log.py: reading a CARMEN log's lines (ODOM, FLASER, PARAM; the other message
types counted) with the rules carmen_to_odolog.py states, each broken rule an InputError
naming FILE:LINE. The conversion to odolog is carmen_to_odolog.py's; the laser's rules are
carmen_laser.py's."""

import re

from import_common import InputError, decoded_lines, parse_number
from carmen_laser import parse_param

STAMP_STEP_MAX = 0.1       # s, the coarsest step a stamp in exponent form may have
INT_RE = re.compile(r"^\d+$")
TYPE_RE = re.compile(r"^[A-Z][A-Z0-9_]*$")
READ_TYPES = ("ODOM", "FLASER", "PARAM")


def stamp_problem(text, value):
    """Why a time stamp is not usable, or None when it is."""
    if value == 0:
        return "is 0"
    if value < 0:
        return "is negative"
    m = re.match(r"^[+-]?(\d*)\.?(\d*)[eE]([+-]?\d+)$", text)
    if m:
        step = 10.0 ** (int(m.group(3)) - len(m.group(2)))
        if step > STAMP_STEP_MAX:
            digits = len((m.group(1) + m.group(2)).lstrip("0"))
            return f"is written to {digits} significant digits, a step of {step:g} s"
    return None


class Line:
    """One ODOM or FLASER line, checked."""
    __slots__ = ("kind", "no", "where", "pose", "odom", "ts_text", "ts", "lts_text", "lts", "n", "ranges")

    def stamp(self):
        """(value, 'ipc' | 'logger') of the first usable stamp, or (None, why not)."""
        p = stamp_problem(self.ts_text, self.ts)
        if p is None:
            return self.ts, "ipc"
        q = stamp_problem(self.lts_text, self.lts)
        if q is None:
            return self.lts, "logger"
        return None, (f"ipc_timestamp '{self.ts_text}' {p} and logger_timestamp '{self.lts_text}' {q}")


def parse_odom(f, where, last_line):
    # ODOM x y theta tv rv accel ipc_timestamp ipc_hostname logger_timestamp
    if len(f) != 10:
        raise InputError(f"{where}: ODOM takes 9 fields (x y theta tv rv accel ts host lts), got {len(f) - 1}"
                         + truncated_note(last_line))
    o = Line()
    o.kind, o.where = "ODOM", where
    o.pose = tuple(parse_number(f[i], where, f"ODOM {name}") for i, name in ((1, "x"), (2, "y"), (3, "theta")))
    for i, name in ((4, "tv"), (5, "rv"), (6, "accel")):
        parse_number(f[i], where, f"ODOM {name}")
    o.ts_text, o.ts = f[7], parse_number(f[7], where, "ODOM ipc_timestamp")
    o.lts_text, o.lts = f[9], parse_number(f[9], where, "ODOM logger_timestamp")
    return o


def parse_flaser(f, where, last_line):
    # FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp
    if len(f) < 2 or not INT_RE.match(f[1]):
        raise InputError(f"{where}: FLASER: the beam count '{f[1] if len(f) > 1 else ''}' is not a count"
                         + truncated_note(last_line))
    n = int(f[1])
    if n < 1:
        raise InputError(f"{where}: FLASER with 0 beams")
    if len(f) != n + 11:
        raise InputError(f"{where}: FLASER with {n} beams takes {n + 10} fields, got {len(f) - 1}"
                         + truncated_note(last_line))
    for i in range(2, 2 + n):
        parse_number(f[i], where, f"FLASER range {i - 1}")
    p = [parse_number(f[2 + n + i], where, f"FLASER {name}") for i, name in
         enumerate(("x", "y", "theta", "odom_x", "odom_y", "odom_theta"))]
    o = Line()
    o.kind, o.where, o.n = "FLASER", where, n
    o.ts_text, o.ts = f[n + 8], parse_number(f[n + 8], where, "FLASER ipc_timestamp")
    o.lts_text, o.lts = f[n + 10], parse_number(f[n + 10], where, "FLASER logger_timestamp")
    if p[0:3] != p[3:6]:
        raise InputError(f"{where}: FLASER pose ({' '.join(f[n + 2:n + 5])}) and odom pose "
                         f"({' '.join(f[n + 5:n + 8])}) differ: a raw (uncorrected) log, not the "
                         f"SLAM-corrected layout this importer reads (see the docstring)")
    o.pose = o.odom = tuple(p[0:3])
    o.ranges = f[2:2 + n]
    return o


def truncated_note(last_line):
    return " (the file ends inside this line: truncated?)" if last_line else ""


def read_log(data, path):
    """(lines: [Line], params: {name: Param}, counts: {type: n} in order of appearance,
    declared: [types] or None)."""
    lines = []
    params = {}
    counts = {}
    declared = None
    raw_lines = data.split(b"\n")
    last_no = len(raw_lines) - 1 if raw_lines and raw_lines[-1] == b"" else len(raw_lines)
    ends_open = not data.endswith(b"\n")
    for no, where, line in decoded_lines(raw_lines, path, "ascii", "ASCII text"):
        f = line.split()
        if not f:
            continue
        last = ends_open and no == last_no
        if f[0].startswith("#"):
            counts["#"] = counts.get("#", 0) + 1
            m = re.match(r"^#\s*message formats defined:\s*(.*)$", line.strip())
            if m and declared is None:
                declared = m.group(1).split()
            continue
        kind = f[0]
        if not TYPE_RE.match(kind):
            raise InputError(f"{where}: '{kind[:40]}' is not a CARMEN message type (an upper-case word)"
                             + truncated_note(last))
        if last and kind not in READ_TYPES:
            raise InputError(f"{where}: the file ends inside this line (no line end after '{kind[:40]}'): "
                             f"a truncated line")
        counts[kind] = counts.get(kind, 0) + 1
        if kind == "ODOM":
            o = parse_odom(f, where, last)
            o.no = no
            lines.append(o)
        elif kind == "FLASER":
            o = parse_flaser(f, where, last)
            o.no = no
            lines.append(o)
        elif kind == "PARAM":
            parse_param(f, where, no, params)
    return lines, params, counts, declared
