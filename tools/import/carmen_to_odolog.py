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
reads".

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
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from import_common import InputError, Parser, read_bytes, run, write_atomic  # noqa: E402
from carmen_laser import LASER_PARAMS, isolated, laser_setup, pile_up  # noqa: E402  (shared with the grid)
from carmen_log import READ_TYPES, read_log  # noqa: E402  (the log's lines)

WHEEL_RADIUS_M = 0.0825
TICKS_PER_REV = 4096
WHEELBASE_M = 0.33
TICK_M = 2 * math.pi * WHEEL_RADIUS_M / TICKS_PER_REV
INIT_SIGMA = (0.01, 0.01, 0.01)
FIX_SIGMA = (0.03, 0.03, 0.02)
TIME_STEP_MIN = 0.001      # s, the synthetic clock's smallest step
ORDER_STEP = 0.1           # s between lines used, with --time order
ANCHOR_TOL = 1e-4          # m / rad: an anchor ODOM must repeat the FLASER pose
TRACK_POS_M = 0.01         # m, rad: when one arc would leave the ticks' pose farther than this
TRACK_HEADING_RAD = 0.005  # from the logged odometry, the sub-step becomes arc + turn
RANGE_SIGMA_DEFAULT_M = 0.03


# The five buildings of ../shared/data/carmen (README.md there): the comment line's title and
# the credit. All five are GMapping-corrected logs distributed by Radish, copied from
# github.com/acschaefer/ple (data/carmen/).
RADISH = "distributed by Radish, the Robotics Data Set Repository"
BUILDINGS = {
    "intel-corrected": ("Intel Research Lab",
                        "recorded by Dirk Haehnel (Intel Research Lab, Seattle); " + RADISH),
    "aces-corrected": ("ACES building, University of Texas at Austin", RADISH),
    "freiburg-079-corrected": ("Building 079, University of Freiburg", RADISH),
    "csail-corrected": ("CSAIL building, MIT", RADISH),
    "orebro-corrected": ("Orebro University", RADISH),
}


def wrap(a):
    """Angle to (-pi, pi]."""
    a = math.fmod(a + math.pi, 2 * math.pi)
    if a <= 0:
        a += 2 * math.pi
    return a - math.pi


def increment(a, b):
    """(rho, dtheta, side, dx, dy) of the motion from pose a to pose b, read with the
    mid-point model: dx, dy in the frame of a, dtheta modulo 2 pi, rho the arc's signed
    travel, side the part one arc cannot make."""
    ax, ay, ath = a
    bx, by, bth = b
    c, s = math.cos(ath), math.sin(ath)
    wx, wy = bx - ax, by - ay
    dx = c * wx + s * wy
    dy = -s * wx + c * wy
    dth = wrap(bth - ath)
    ch, sh = math.cos(dth / 2), math.sin(dth / 2)
    return dx * ch + dy * sh, dth, -dx * sh + dy * ch, dx, dy


def read_text(path):
    data = read_bytes(path)
    return data, hashlib.sha256(data).hexdigest()


def source_name(path):
    name = os.path.basename(path)
    for ext in (".gz", ".log", ".clf"):
        if name.endswith(ext):
            name = name[:-len(ext)]
    return name or "log"


class Converter:
    def __init__(self, max_scans, fix_every, scans=False, range_max=None, range_sigma=RANGE_SIGMA_DEFAULT_M,
                 no_return=None, time_mode="stamps", missing="refuse"):
        self.max_scans = max_scans
        self.fix_every = fix_every
        self.with_scans = scans
        self.range_max_opt = range_max
        self.range_sigma = range_sigma
        self.no_return_opt = no_return
        self.order = time_mode == "order"
        self.missing = missing
        self.choice_meta = []       # meta lines of carmen_to_odolog.convert's --auto choices
        self.laser = None           # (start, step, range_max, mount) with --scans
        self.laser_meta = []
        self.no_return = None
        self.pile_up = None
        self.beams = None
        self.no_returns = 0
        self.returns = 0
        self.body = []
        self.scans = 0
        self.t = None               # last written time
        self.t_prev = None          # the one before it
        self.prev_ts = None         # last raw stamp seen (for the backwards count)
        self.backwards = 0
        self.repeats = 0
        self.moved = 0
        self.max_shift = 0.0
        self.stamps = 0
        self.from_logger = 0
        self.cum_r = 0.0
        self.cum_l = 0.0
        self.ticks = (0, 0)         # the last written counts
        self.dead = None            # the pose they dead-reckon to, in the current odometry frame
        self.substeps = 0
        self.splits = 0
        self.split_side = 0.0
        self.split_turn = 0.0
        self.fills = 0
        self.prefix_odom = 0
        self.after_last = 0
        self.side_sum = 0.0
        self.side_max = 0.0
        self.path = 0.0
        self.rot = 0.0
        self.max_dth = 0.0
        self.fixes = 0
        self.init = None
        self.t_end = None
        self.heading_range = None
        self.counts = {}
        self.declared = None
        self.params = {}

    # ---------------------------------------------------------------- time
    def stamp_of(self, line, required=True):
        """The stamp of a line used (--time stamps); InputError when it has none."""
        v, src = line.stamp()
        if v is None and required:
            raise InputError(f"{line.where}: {line.kind}: no usable time stamp: {src}; --time order writes a "
                             f"synthetic time in file order instead", fix=("time", "order"))
        return v

    def clock(self, line):
        """The written time of a line used: strictly increasing, in file order."""
        self.stamps += 1
        prev = self.t
        if self.order:
            t = (self.stamps - 1) * ORDER_STEP
        else:
            ts, src = line.stamp()
            if ts is None:
                self.stamp_of(line)
            if src == "logger":
                self.from_logger += 1
            if self.prev_ts is not None and ts < self.prev_ts:
                self.backwards += 1
            elif self.prev_ts is not None and ts == self.prev_ts:
                self.repeats += 1
            self.prev_ts = ts
            t = ts if prev is None else max(ts, prev + TIME_STEP_MIN)
            if t != ts:
                self.moved += 1
                self.max_shift = max(self.max_shift, t - ts)
        self.t_prev = prev
        self.t = t
        return t

    # ---------------------------------------------------------------- odometry
    def ticks_after(self, rho, dth):
        """(cum_r, cum_l, ticks_r, ticks_l, dead-reckoned pose) after a motion (rho, dth)."""
        cum_r = self.cum_r + rho + dth * WHEELBASE_M / 2
        cum_l = self.cum_l + rho - dth * WHEELBASE_M / 2
        ticks_r = math.floor(cum_r / TICK_M + 0.5)
        ticks_l = math.floor(cum_l / TICK_M + 0.5)
        # the pose the written ticks dead-reckon to (the mid-point model, as a reader does)
        dr = (ticks_r - self.ticks[0]) * TICK_M
        dl = (ticks_l - self.ticks[1]) * TICK_M
        r, dt = (dr + dl) / 2, (dr - dl) / WHEELBASE_M
        x, y, th = self.dead
        return cum_r, cum_l, ticks_r, ticks_l, (x + r * math.cos(th + dt / 2), y + r * math.sin(th + dt / 2), th + dt)

    def advance(self, rho, dth, t, after=None):
        self.cum_r, self.cum_l, ticks_r, ticks_l, self.dead = after or self.ticks_after(rho, dth)
        self.ticks = (ticks_r, ticks_l)
        self.body.append(f"enc {t:.6f} {ticks_r} {ticks_l}")
        self.t_end = t

    def substep(self, a, b, t):
        """The motion from odometry pose a to b as ticks, at time t."""
        rho, dth, side, dx, dy = increment(a, b)
        after = self.ticks_after(rho, dth)
        gap = math.hypot(after[4][0] - b[0], after[4][1] - b[1])
        if gap <= TRACK_POS_M and abs(wrap(after[4][2] - b[2])) <= TRACK_HEADING_RAD:
            # one arc; its sideways part is dropped
            self.advance(rho, dth, t, after)
            self.side_sum += abs(side)
            self.side_max = max(self.side_max, abs(side))
        else:
            # sparse odometry (a turn and a drive in one step) or dropped sideways parts adding up:
            # from the pose the ticks have reached, the arc to the logged end point (its chord's
            # direction phi, rotation 2 phi; backwards when the end point is behind) and then the
            # rest of the rotation in place
            _, _, _, ddx, ddy = increment(self.dead, b)
            chord = math.hypot(ddx, ddy)
            phi = math.atan2(ddy, ddx)
            if abs(phi) > math.pi / 2:
                phi, chord = wrap(phi + math.pi), -chord
            turn = wrap(b[2] - self.dead[2] - 2 * phi)
            self.advance(chord, 2 * phi, self.t_prev + (t - self.t_prev) / 2)
            self.advance(0.0, turn, t)
            self.splits += 1
            self.split_side += abs(side)
            self.split_turn = max(self.split_turn, abs(turn))
        self.substeps += 1
        self.path += math.hypot(dx, dy)
        self.rot += abs(dth)
        self.max_dth = max(self.max_dth, abs(dth))

    def heading(self, th):
        lo, hi = self.heading_range or (th, th)
        self.heading_range = (min(lo, th), max(hi, th))

    # ---------------------------------------------------------------- scans
    def setup_laser(self, first):
        la = laser_setup(first.n, self.params, first.where, self.range_max_opt, self.no_return_opt)
        self.no_return = la.no_return
        self.laser = (la.start, la.step, la.range_max, list(la.mount))
        self.laser_meta = [
            "laser_beams " + "; ".join(la.beam_notes),
            f"laser_range RANGE_MAX {la.range_max:g} m from {la.range_src}; no return: readings >= "
            f"{la.no_return:g} m written as nan, from {la.no_return_src}; SIGMA {self.range_sigma:g} m "
            f"({'--range-sigma' if self.range_sigma != RANGE_SIGMA_DEFAULT_M else 'the default, a declared value'})",
            "laser_mount " + "; ".join(la.mount_src) + " (the corrected pose is taken as the robot's)",
        ]
        self.top = {}               # reading -> count, the readings below the no-return limit

    def scan_record(self, fl, t):
        n = fl.n
        if self.beams is None:
            self.beams = n
            self.setup_laser(fl)
        elif n != self.beams:
            raise InputError(f"{fl.where}: FLASER with {n} beams, the first one had {self.beams}: "
                             f"one odolog `laser` record cannot describe both")
        out = []
        lim = self.no_return
        for tok in fl.ranges:
            v = float(tok)
            if v >= lim:
                out.append("nan")
                self.no_returns += 1
            else:
                out.append(tok)
                self.returns += 1
                self.top[v] = self.top.get(v, 0) + 1
        self.body.append(f"scan {t:.6f} " + " ".join(out))

    def check_pile_up(self):
        if self.returns == 0:
            return
        p = pile_up(self.top, self.returns + self.no_returns)
        if p is not None:
            low, what = p
            self.pile_up = (f"laser_no_return_suspect {what}, the top of the readings below the no-return limit: "
                            f"a no-return code the log does not state? They are written as ranges; --no-return "
                            f"{low:g} writes them as nan")

    # ---------------------------------------------------------------- the log
    def emit(self, fl, t):
        """Writes scan k's records at time t (the time of its paired odometry)."""
        k = self.scans
        x, y, th = fl.pose
        if k == 0:
            self.init = (x, y, th)
            self.body.append(f"enc {t:.6f} 0 0")
            self.t_end = t
        self.heading(th)
        self.body.append(f"truth {t:.6f} {x:.6f} {y:.6f} {th:.6f}")
        if self.with_scans:
            self.scan_record(fl, t)
        if self.fix_every > 0 and k > 0 and k % self.fix_every == 0:
            self.body.append(f"pose {t:.6f} {x:.6f} {y:.6f} {th:.6f} "
                             f"{FIX_SIGMA[0]:g} {FIX_SIGMA[1]:g} {FIX_SIGMA[2]:g}")
            self.fixes += 1
        self.scans += 1
        self.after_last = 0

    def run(self, lines, params, counts, declared, path):
        self.params, self.counts, self.declared = params, counts, declared
        pose = None          # the pose the next sub-step starts from (None before the first scan)
        n_raw = 0            # raw ODOM lines used since the last scan (or its anchor)
        last_raw = None      # (Line, stamp) the last raw ODOM line (prefix lines too)
        anchor_for = None    # the scan emitted last, while its anchor may still come
        anchor_line = None   # line number of the last anchor
        anchored = False     # the current frame is anchored at a corrected pose
        pending = None       # a FLASER waiting for its paired ODOM line after it (--time stamps)
        started = False
        last_fl = None       # the scan emitted last, and whether its anchor came
        last_fl_anchored = False
        with_anchors = None  # the layout, set by the first scan: anchored (True) or one frame (False)

        def close(a, b):
            return abs(a[0] - b[0]) <= ANCHOR_TOL and abs(a[1] - b[1]) <= ANCHOR_TOL and \
                abs(wrap(a[2] - b[2])) <= ANCHOR_TOL

        def stop():
            return self.max_scans is not None and self.scans >= self.max_scans

        def use_raw(o):
            nonlocal pose, n_raw, last_raw
            if pose is None:
                raise InputError(f"{o.where}: a raw ODOM line after the first scan (line {last_fl.no}), which has "
                                 f"neither a paired ODOM line nor an anchor: its odometry frame is not related "
                                 f"to the scan")
            t = self.clock(o)
            self.heading(o.pose[2])
            self.substep(pose, o.pose, t)
            pose = o.pose
            n_raw += 1
            last_raw = (o, None if self.order else self.stamp_of(o))
            if self.scans > 0:
                self.after_last += 1

        def emitted(fl):
            nonlocal anchor_for, n_raw, last_raw, anchored, started, last_fl, last_fl_anchored
            anchor_for, n_raw, last_raw, anchored, started = fl, 0, None, False, True
            last_fl, last_fl_anchored = fl, False

        def first_scan(fl, pair):
            """The first scan, at its own stamp; pair: its ODOM line (in the frame before it) or None."""
            nonlocal pose
            self.emit(fl, self.clock(fl))
            pose = self.dead = None if pair is None else pair.pose
            emitted(fl)

        def unpaired(fl, after):
            """fl has no paired odometry: the first scan needs none; otherwise fill or refuse."""
            nonlocal pose
            if not started:
                first_scan(fl, None)
                return
            since = f"line {anchor_line}, the previous scan's anchor" if anchored else "the previous scan"
            if n_raw > 0:
                o, st = last_raw
                raise InputError(f"{fl.where}: no ODOM line carries the FLASER's time stamp {fl.ts_text}: the "
                                 f"last one before it (line {o.no}) is stamped {o.ts_text}{after}; the odometry "
                                 f"at the scan's time is not in the file", fix=("time", "order"))
            if self.missing != "flaser":
                raise InputError(f"{fl.where}: the FLASER has no odometry: no raw ODOM line since {since}"
                                 f"{after}, and its own odom fields repeat the corrected pose; "
                                 f"--missing-odometry flaser takes them as the odometry",
                                 fix=("missing", "flaser"))
            if not anchored:
                raise InputError(f"{fl.where}: the FLASER has no odometry since the previous scan and the "
                                 f"odometry frame is not anchored at a corrected pose: its odom fields "
                                 f"cannot stand in for it")
            t = self.clock(fl)
            self.substep(pose, fl.odom, t)
            pose = fl.odom
            self.fills += 1
            self.emit(fl, t)
            emitted(fl)

        for o in lines:
            if o.kind == "ODOM":
                if pending is not None:
                    st = self.stamp_of(o, required=False)
                    pst = self.stamp_of(pending)
                    if close(o.pose, pending.pose):
                        unpaired(pending, f" (the next ODOM, line {o.no}, is its anchor)")
                        pending = None
                    elif st is not None and st == pst:
                        if not started:
                            self.prefix_odom += 1   # the first scan's pair: in the frame before it
                            first_scan(pending, o)
                        else:
                            if stop():
                                break
                            use_raw(o)
                            self.emit(pending, self.t)
                            emitted(pending)
                        pending = None
                        continue
                    elif st is not None and st < pst:
                        if not started:
                            self.prefix_odom += 1
                            last_raw = (o, st)
                        else:
                            if stop():
                                break
                            use_raw(o)
                        continue
                    else:
                        unpaired(pending, f" nor after it before line {o.no} (stamped {o.ts_text})")
                        pending = None
                if anchor_for is not None and close(o.pose, anchor_for.pose):
                    if with_anchors is None:
                        with_anchors = True
                    pose = anchor_for.pose      # re-anchored; the line's stamp is not used
                    self.dead = pose
                    anchor_for, anchored, anchor_line = None, True, o.no
                    n_raw, last_raw, last_fl_anchored = 0, None, True
                    continue
                if last_fl is not None and not last_fl_anchored and anchor_for is None and \
                        close(o.pose, last_fl.pose):
                    raise InputError(f"{o.where}: this ODOM line repeats the corrected pose of the FLASER on line "
                                     f"{last_fl.no} (an anchor) after raw odometry lines: an anchor must follow "
                                     f"its FLASER (and the FLASER's paired ODOM line)")
                if anchor_for is not None:      # no anchor after the scan: the odometry frame goes on
                    if with_anchors:
                        raise InputError(f"{o.where}: the FLASER on line {anchor_for.no} has no anchor (an ODOM line "
                                         f"repeating its corrected pose, right after it or its paired ODOM "
                                         f"line), as the scans before it have: the frame of the odometry after "
                                         f"it is not known")
                    with_anchors = False
                anchor_for = None
                if not started:
                    self.prefix_odom += 1
                    last_raw = (o, None if self.order else self.stamp_of(o, required=False))
                    continue
                if stop():
                    break
                use_raw(o)
            else:  # FLASER
                if pending is not None:
                    unpaired(pending, f" nor after it before the next FLASER (line {o.no})")
                    pending = None
                if stop():
                    break
                if anchor_for is not None:
                    raise InputError(f"{o.where}: two FLASER lines with no ODOM line between them (line "
                                     f"{anchor_for.no} and this one): neither the anchor that repeats the "
                                     f"first one's corrected pose nor any odometry")
                if self.order:
                    if not started:
                        first_scan(o, last_raw[0] if last_raw else None)
                    elif n_raw > 0:
                        self.emit(o, self.t)
                        emitted(o)
                    else:
                        unpaired(o, "")
                    continue
                st = self.stamp_of(o)
                if last_raw is not None and last_raw[1] is not None and last_raw[1] == st:
                    if not started:
                        first_scan(o, last_raw[0])
                    else:
                        self.emit(o, self.t)
                        emitted(o)
                elif started and n_raw > 0 and last_raw[1] > st:
                    raise InputError(f"{o.where}: the FLASER (stamped {o.ts_text}) comes after odometry stamped "
                                     f"later ({last_raw[0].ts_text}, line {last_raw[0].no}) and no ODOM line "
                                     f"carries its stamp: its odometry cannot be placed", fix=("time", "order"))
                else:
                    pending = o
        else:
            if pending is not None:
                unpaired(pending, " nor after it (the file ends)")
        if self.scans == 0:
            raise InputError(f"{path}: no FLASER line: nothing to convert")
        if self.with_scans:
            self.check_pile_up()

    # ---------------------------------------------------------------- output
    def text(self, digest, max_scans, name):
        h = []
        w = h.append
        x, y, th = self.init
        title, credit = BUILDINGS.get(name, (None, None))
        w("odolog 1")
        if title:
            w(f"# {title} (CARMEN, SLAM-corrected) converted by tools/import/carmen_to_odolog.py")
        else:
            w(f"# CARMEN log {name} (SLAM-corrected) converted by tools/import/carmen_to_odolog.py")
        w("# enc: raw odometry sub-steps turned into the ticks of an equivalent differential drive")
        w("#      (d = 0.33 m, r = 0.0825 m, 4096 ticks/rev; mid-point model; sideways part dropped)")
        if self.splits:
            w("#      where one arc would leave the ticks off the logged odometry: an arc, then a turn in place")
        if self.fills:
            w("# (intervals without raw odometry: the corrected pose stands in for it; meta odometry_gaps)")
        w("# truth: SLAM-corrected FLASER poses (a SLAM result, not motion capture)")
        if self.with_scans:
            w("# scan: the FLASER ranges (nan = no return); no wall records: the map is a separate file")
            w("#       (odoerr map grid-from-carmen + odoerr map import), built from the corrected poses,")
            w("#       so scoring against the truth below is partly circular (shared SLAM errors).")
        else:
            w("# No laser/scan/wall records (use --scans for the laser; the map is a separate file).")
        w(f"meta source carmen {name}")
        if credit:
            w(f"meta credit {credit}; SLAM-corrected copy from github.com/acschaefer/ple "
              f"data/carmen/{name}.log.gz; no separate data licence stated")
        w(f"meta source_sha256 {digest} (decompressed text)")
        w("meta importer tools/import/carmen_to_odolog.py")
        w(f"meta scans {self.scans}{'' if max_scans is None else f' (--max-scans {max_scans})'}; "
          f"odom sub-steps {self.substeps} ({self.after_last} after the last scan); "
          f"{self.prefix_odom} ODOM lines before the first scan dropped")
        if self.order:
            # docs/odolog.md, meta time_base: the stamps order the records, they do not measure
            # time (the reader's plausibility rule then uses the log's own increments)
            w("meta time_base order")
            w(f"meta time synthetic t = {ORDER_STEP:g} s per line used, in file order (--time order: the log's "
              f"time stamps are not used); {self.stamps} lines")
        else:
            w(f"meta time synthetic t = max(ipc_timestamp, previous t + {TIME_STEP_MIN:g} s) in file order; "
              f"{self.backwards} stamps went backwards and {self.repeats} repeated the previous one; "
              f"{self.moved} of {self.stamps} written times differ from their stamp, by at most {self.max_shift:.3f} s")
        w(f"meta odometry path {self.path:.3f} m, rotation {self.rot:.3f} rad, "
          f"largest sub-step rotation {self.max_dth:.4f} rad, "
          f"dropped sideways motion {self.side_sum:.4f} m in all (at most {self.side_max:.4f} m per sub-step)")
        if self.fix_every > 0:
            w(f"meta pose_fixes corrected pose every {self.fix_every} scans, "
              f"sigma {FIX_SIGMA[0]:g} m {FIX_SIGMA[2]:g} rad")
        else:
            w("meta pose_fixes none")
        if self.with_scans:
            w(f"meta scans_written {self.scans} scans of {self.beams} beams: {self.returns} returns, "
              f"{self.no_returns} no-return beams written as nan")
        # what was read, what was chosen and from where
        kinds = [k for k in self.counts if k != "#"]
        read = [k for k in kinds if k in READ_TYPES]
        skipped = [k for k in kinds if k not in READ_TYPES]
        w("meta carmen_messages " + ", ".join(f"{k} {self.counts[k]}" for k in kinds) +
          f"; read: {' '.join(read) or 'none'}; skipped (counted only): {' '.join(skipped) or 'none'}"
          + (f"; {self.counts['#']} comment lines" if "#" in self.counts else ""))
        if self.declared is not None:
            w("meta carmen_formats_declared " + (" ".join(self.declared) or "(none)") +
              " (the log's '# message formats defined' line)")
        pr = sorted(self.params.values(), key=lambda q: q.no)
        w("meta carmen_params_read " + ("; ".join(f"{q.name} {q.text} (line {q.no})" for q in pr)
                                        if pr else "none of " + " ".join(LASER_PARAMS)))
        if not self.order:
            w(f"meta time_stamps ipc_timestamp, or logger_timestamp where that is 0 or not usable: "
              f"{self.from_logger} of {self.stamps} lines used took the logger's")
        w("meta pairing each FLASER with the raw ODOM line of its time " +
          ("(--time order: the last one before it since the previous scan's anchor)" if self.order else
           "stamp (before it, or after it before its anchor)"))
        w(f"meta odometry_gaps {self.fills} intervals without raw odometry" +
          (" filled from the FLASER's own odom fields, i.e. the corrected pose (--missing-odometry flaser): "
           "their ticks carry no odometry error" if self.fills else ""))
        w(f"meta odometry_split {self.splits} of {self.substeps} sub-steps would have left the ticks more than "
          f"{TRACK_POS_M:g} m or {TRACK_HEADING_RAD:g} rad from the logged odometry as one arc (their sideways "
          f"parts: {self.split_side:.4f} m in all) and were written as an arc to the logged end point and a turn "
          f"in place (at most {self.split_turn:.4f} rad)")
        lo, hi = self.heading_range
        w(f"meta headings differenced modulo 2 pi; the log's headings used run from {lo:g} to {hi:g} rad "
          f"({'not ' if lo <= -math.pi or hi > math.pi else ''}all within (-pi, pi]), written as they are")
        if self.with_scans:
            for m in self.laser_meta:
                w("meta " + m)
            if self.pile_up:
                w("meta " + self.pile_up)
        for m in self.choice_meta:
            w(m)
        w("drive diff")
        w(f"param wheel_radius_m {WHEEL_RADIUS_M:g}")
        w(f"param ticks_per_rev {TICKS_PER_REV}")
        w(f"param wheelbase_m {WHEELBASE_M:g}")
        if self.with_scans:
            start, step, rmax, mount = self.laser
            w(f"laser {self.beams} {start:.9f} {step:.9f} {rmax:g} {self.range_sigma:g} "
              f"{mount[0]:g} {mount[1]:g} {mount[2]:g}")
        w(f"init {x:.6f} {y:.6f} {th:.6f} {INIT_SIGMA[0]:g} {INIT_SIGMA[1]:g} {INIT_SIGMA[2]:g}")
        return "\n".join(h + self.body) + "\n"


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
        write_atomic(a.out, conv.text(digest, a.max_scans, source_name(a.log)))
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
    sys.stderr.write(f"{a.out}: {conv.scans} scans, {conv.substeps} odometry sub-steps, "
                     f"{conv.fixes} pose fixes, {conv.t_end - float(conv.body[0].split()[1]):.1f} s, "
                     f"odometry path {conv.path:.2f} m\n")
    return 0


if __name__ == "__main__":
    run(main)
