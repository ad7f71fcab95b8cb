#!/usr/bin/env python3
"""carmen_to_odolog.py: a SLAM-corrected CARMEN log (the Intel Research Lab's and the other
buildings of ../shared/data/carmen) -> odolog v1.

Usage:
    carmen_to_odolog.py LOG[.gz] --out FILE [--max-scans N] [--fix-every N] [--auto [--choices F.json]]
                        [--time stamps|order] [--missing-odometry refuse|flaser]
                        [--scans [--range-max M] [--range-sigma S] [--no-return M]]

The data: ../shared/data/carmen/*-corrected.log.gz (read its README.md). No separate data
licence is stated: the output carries a credit line for the five known buildings. What the
importer reads, building by building: docs/real-data.md, "CARMEN logs: what the importer
reads". The code: carmen_log.py reads the lines, carmen_convert.py pairs them into records,
carmen_ticks.py writes the odometry as ticks, carmen_laser.py holds the laser's rules and
carmen_header.py writes the header; this file is the command and its --auto choices.

What a corrected log holds (checked line by line; a file that does not follow it is
refused, because the mapping below depends on it):
- `FLASER n r1..rn x y theta odom_x odom_y odom_theta ts host lts`: x y theta is the
  SLAM-corrected pose P_k of processed scan k, and the odom_* fields repeat it (a FLASER
  whose odom fields differ is a raw, uncorrected log: refused).
- ODOM lines `ODOM x y theta tv rv accel ts host lts` are raw odometry. The first ODOM line
  after FLASER k that repeats P_k is its ANCHOR: it re-anchors the odometry at P_k (its
  time stamp is 0 or garbage and is not used). The jump into an anchor is the SLAM
  correction, not motion: it is never turned into ticks. In a log whose first scan has an
  anchor, every scan needs one (refused otherwise); a log without anchors is read as one
  continuous odometry frame.
- FLASER k is paired with the raw odometry at its time: the ODOM line of the same time
  stamp, before the FLASER (as in all five buildings) or after it (before its anchor). With --time order (stamps unusable) the pair is the last raw ODOM line before
  the FLASER. A FLASER with no raw odometry since the previous scan's anchor (orebro, 219
  of 236 intervals) is refused, unless --missing-odometry flaser: the FLASER's own odom
  fields (in a corrected log: the corrected pose) are then that interval's odometry, so
  the interval's ticks carry no odometry error; the count is written in a meta line.
- ODOM lines before the first FLASER (and the first FLASER's own pair) are dropped: no
  corrected pose relates their frame to the map frame.

Mapping (format: docs/odolog.md):
- each raw sub-step (from one ODOM line, or the anchor, to the next raw ODOM line)
  becomes the encoder ticks of an EQUIVALENT differential drive: `drive diff`, `param
  wheel_radius_m 0.0825`, `param ticks_per_rev 4096`, `param wheelbase_m 0.33` (declared
  constants, not a measurement of any of the robots; one tick = 0.1266 mm of wheel travel).
  The sub-step (dx, dy, dtheta, in the robot frame at its start; dtheta modulo 2 pi, so
  headings need not be wrapped in the log) is read with the mid-point model (motion.hpp):
  rho = dx cos(dtheta/2) + dy sin(dtheta/2), the wheels travel R = rho + dtheta*d/2,
  L = rho - dtheta*d/2, and the running sums are quantised to ticks by rounding. The
  sideways part -dx sin(dtheta/2) + dy cos(dtheta/2), which one arc cannot make, is
  dropped (its total is written in a meta line) as long as the pose the written ticks
  dead-reckon to stays within 1 cm and 0.005 rad of the logged odometry. A sub-step that
  would leave it farther (sparse odometry: a turn and a drive in one step; or dropped
  sideways parts adding up) is written as TWO enc records from the pose the ticks have
  reached: the arc to the logged end point (rotation 2*phi, phi its chord's direction)
  and then a turn in place, the first at the mid-time between its neighbours. The ticks
  thus follow the logged odometry at every ODOM line to within 1 cm (Intel: none split,
  9 mm at most; csail: 903 of 1926 split).
- the log starts at the first scan with `enc t0 0 0` and `init P_0` (sigmas 0.01 m,
  0.01 m, 0.01 rad). Sub-steps after the last scan are kept (enc only).
- one `truth T X Y THETA` per FLASER (P_k as written, headings unwrapped or not), at the
  time of the enc record of its paired ODOM line; with --fix-every N > 0 scans N, 2N, ...
  also give a `pose` fix at P_k (sigmas 0.03 m, 0.03 m, 0.02 rad).
- with --scans: the `laser` record and one `scan T r1..rn` per FLASER at its truth's time.
  Beam directions: a FLASER has none. The beam-count rule (as CARMEN reads a FLASER:
  first beam at -90 deg, counter-clockwise; 180 and 181 beams 1 deg apart, 360 and 361
  beams 0.5 deg apart) unless the log states PARAM laser_front_laser_resolution (degrees)
  and / or laser_front_laser_fov (degrees; or radians when only that reading fits the beam
  count), which win: the step is the resolution, the fov is from the first beam to the
  last (or to one step past the last: the last beam dropped, as in 180 and 360 beam logs),
  and the first beam is at -fov/2. Another beam count without those PARAMs is refused. The
  mount: PARAM robot_frontlaser_offset (m ahead of the robot's origin),
  robot_frontlaser_side_offset and robot_frontlaser_angular_offset, else 0 (the corrected
  pose is taken as the robot's, with the laser at the stated offset from it, as the SLAM
  system placed it). RANGE_MAX: --range-max, else PARAM robot_front_laser_max, else 30 m.
  A reading at or above the no-return limit is written `nan`: --no-return, else PARAM
  robot_front_laser_max, else 80 m (the maximum range CARMEN assumes for a FLASER). When
  the readings below that limit pile up at their top (a no-return code the log does not
  state, as ACES's 50 m and Orebro's 32.76 m), a meta line and a note on stderr say so
  and name the --no-return that would take them. SIGMA: --range-sigma, 0.03 m. Every
  choice and where it came from is written in `meta laser_*` lines. These laser rules live
  in carmen_laser.py, shared with the grid builder (`odoerr map grid-from-carmen`). No `wall` records:
  the map is a separate file (`odoerr map grid-from-carmen`, `odoerr map import`).
- time, --time stamps (the default): each line used (the raw ODOM sub-steps and the first
  FLASER) is stamped with its ipc_timestamp, or its logger_timestamp when that is 0 or
  not usable, and a line with neither is refused. A stamp is not usable when it is 0 or
  negative, or written in exponent form to a step above 0.1 s (csail's `1.13486e+09`, a
  step of 10000 s). The stamps go backwards in places (Intel: 622 times, up to 0.9 s) and
  repeat, so the written time is
        t_j = max(stamp_j, t_(j-1) + 0.001 s),   t_0 = the first FLASER's stamp
  which stays on the source's clock wherever it is monotonic and is strictly increasing;
  how many stamps were moved, by how much at most, is written in a meta line.
  --time order: the stamps are not used; the lines used are 0.1 s apart in file order (a
  declared step, not a measurement); the pairing is by order as said above.
  --max-scans N stops after the N-th scan.
- --auto (what `odoerr calibrate` runs): an option among --time, --missing-odometry and
  --no-return that is not given is chosen from the log instead of refusing it: --time
  order when the stamps cannot place the odometry (no usable stamp, or a FLASER whose
  odometry no stamp pairs), --missing-odometry flaser when scans have no raw odometry, and
  --no-return at the pile-up of readings at their top. Each choice and its reason (the
  refusal's message, the count) goes to stderr, to a `meta choice_*` line and, with
  --choices F.json, to a JSON file {option: {value, chosen, reason}}.
- meta lines: the source name and credit, the SHA-256 of the decompressed text, the
  message types of the log with their counts (which were read, which skipped: NEFF, SYNC,
  RLASER, RAWLASER*, ROBOTLASER*, TRUEPOS, ... are counted, never silently dropped), the
  formats its header declares, the PARAM lines read, the time and odometry statistics.
  The output depends only on the input and the options: running twice gives identical
  files.

Malformed input is refused with `FILE:LINE: what is wrong` on stderr and exit status 2
(line numbers count lines of the decompressed text), and nothing is written: an ODOM or
FLASER line with the wrong field count (a truncated line among them) or a field that is
not a decimal number, a FLASER whose pose and odom fields differ, a first word that is not
an upper-case message type, a PARAM the importer reads whose value is not a number or
changes, a FLASER whose odometry cannot be paired (see above), a used line with no usable
time stamp, bytes that are not ASCII text, no FLASER at all; with --scans, FLASERs of
different beam counts, and beam directions that no rule or PARAM gives.
"""

import hashlib
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from import_common import InputError, Parser, read_bytes, run, write_atomic  # noqa: E402
from carmen_laser import isolated  # noqa: E402  (the no-return pile-up, shared with the grid)
from carmen_log import read_log  # noqa: E402  (the log's lines)
from carmen_convert import RANGE_SIGMA_DEFAULT_M, Converter  # noqa: E402  (lines -> records)
from carmen_header import odolog_text  # noqa: E402  (the header)


def read_text(path):
    data = read_bytes(path)
    return data, hashlib.sha256(data).hexdigest()


def source_name(path):
    name = os.path.basename(path)
    for ext in (".gz", ".log", ".clf"):
        if name.endswith(ext):
            name = name[:-len(ext)]
    return name or "log"


def convert(a, lines, params, counts, declared):
    """Runs the conversion with the options as given; with --auto, an option not given is
    chosen from the log: --time order when the log's stamps cannot place its odometry (the
    refusal's message is the reason), --missing-odometry flaser when scans have no raw
    odometry (their count is the reason), --no-return at the pile-up of readings at their
    top (carmen_laser.pile_up). Returns the converter and {option: {value, chosen, reason}}."""
    opt = {"time": a.time or "stamps", "missing_odometry": a.missing_odometry or "refuse",
           "no_return": a.no_return}
    given = {"time": a.time is not None, "missing_odometry": a.missing_odometry is not None,
             "no_return": a.no_return is not None}
    why = {k: ("given" if given[k] else "the default") for k in opt}
    chosen = {k: False for k in opt}
    while True:
        conv = Converter(a.max_scans, a.fix_every, a.scans, a.range_max, a.range_sigma, opt["no_return"],
                         opt["time"], opt["missing_odometry"])
        try:
            conv.run(lines, params, counts, declared, a.log)
        except InputError as e:
            key = {"time": "time", "missing": "missing_odometry"}.get(e.fix[0]) if e.fix else None
            if not a.auto or key is None or given[key] or chosen[key]:
                raise
            opt[key], chosen[key], why[key] = e.fix[1], True, f"the log refuses the default: {e}"
            continue
        if a.auto and not given["no_return"] and not chosen["no_return"] and conv.pile_up and a.scans:
            low = float(conv.pile_up.split("--no-return ")[1].split()[0])
            alone, how = isolated(conv.top, low, max(conv.top))
            if alone:
                opt["no_return"], chosen["no_return"] = low, True
                why["no_return"] = conv.pile_up.split(" ", 1)[1].split(": a no-return")[0] + "; " + how
                continue
            why["no_return"] += f" (a pile-up at the top is not taken as a code: {how})"
        break
    if chosen["missing_odometry"]:
        why["missing_odometry"] += f" ({conv.fills} of {conv.scans} scan intervals take the FLASER's pose as their odometry)"
    res = {k: {"value": opt[k], "chosen": chosen[k], "reason": why[k]} for k in opt}
    for k, c in res.items():
        if c["chosen"]:
            conv.choice_meta.append(f"meta choice_{k} {c['value']} {c['reason']}")
    return conv, res


def main(argv=None):
    ap = Parser(prog="carmen_to_odolog.py",
                description="Convert a SLAM-corrected CARMEN log (FLASER + ODOM) to odolog v1.")
    ap.add_argument("log", metavar="LOG")
    ap.add_argument("--out", required=True, metavar="FILE")
    ap.add_argument("--max-scans", type=int, default=None, metavar="N",
                    help="stop after the N-th processed scan (default: all)")
    ap.add_argument("--fix-every", type=int, default=0, metavar="N",
                    help="a pose fix at every N-th scan (default 0: none)")
    ap.add_argument("--auto", action="store_true",
                    help="choose --time, --missing-odometry and --no-return from the log where they are not "
                         "given (each choice and its reason: stderr, meta lines, --choices)")
    ap.add_argument("--choices", metavar="FILE.json", default=None,
                    help="write the value of --time, --missing-odometry and --no-return and why (with --auto)")
    ap.add_argument("--time", choices=("stamps", "order"), default=None,
                    help="stamps (default): the log's time stamps; order: 0.1 s per line used, in file "
                         "order, for logs whose stamps are 0 or too coarse")
    ap.add_argument("--missing-odometry", choices=("refuse", "flaser"), default=None,
                    help="a scan with no raw odometry since the previous one: refuse (default), or take "
                         "the FLASER's own odom fields (in a corrected log, the corrected pose)")
    ap.add_argument("--scans", action="store_true",
                    help="also write the laser record and a scan record per FLASER")
    ap.add_argument("--range-max", type=float, default=None, metavar="M",
                    help="the laser record's range_max (m); default PARAM robot_front_laser_max, else 30")
    ap.add_argument("--range-sigma", type=float, default=RANGE_SIGMA_DEFAULT_M, metavar="S",
                    help="the laser record's range noise std (m), default 0.03 (with --scans)")
    ap.add_argument("--no-return", type=float, default=None, metavar="M",
                    help="readings >= M (m) are no return (nan); default PARAM robot_front_laser_max, else 80")
    a = ap.parse_args(argv)
    if not ((a.range_max is None or a.range_max > 0) and a.range_sigma > 0):
        ap.error("--range-max and --range-sigma must be > 0")
    if a.no_return is not None and not a.no_return > 0:
        ap.error("--no-return must be > 0")
    if a.max_scans is not None and a.max_scans < 1:
        ap.error("--max-scans must be >= 1")
    if a.fix_every < 0:
        ap.error("--fix-every must be >= 0")
    try:
        data, digest = read_text(a.log)
        lines, params, counts, declared = read_log(data, a.log)
        conv, choices = convert(a, lines, params, counts, declared)
        write_atomic(a.out, odolog_text(conv, digest, a.max_scans, source_name(a.log)))
        if a.choices:
            write_atomic(a.choices, json.dumps(choices, indent=1) + "\n")
    except InputError as e:
        sys.stderr.write(f"error: {e}\n")
        return 2
    for k, c in choices.items():
        if c["chosen"]:
            sys.stderr.write(f"chose --{k.replace('_', '-')} {c['value']:}: {c['reason']}\n")
    if conv.pile_up and not choices["no_return"]["chosen"]:
        sys.stderr.write(f"note: {conv.pile_up.split(' ', 1)[1]}\n")
    sys.stderr.write(f"{a.out}: {conv.scans} scans, {conv.odo.substeps} odometry sub-steps, "
                     f"{conv.fixes} pose fixes, {conv.odo.t_end - float(conv.body[0].split()[1]):.1f} s, "
                     f"odometry path {conv.odo.path:.2f} m\n")
    return 0


if __name__ == "__main__":
    run(main)
