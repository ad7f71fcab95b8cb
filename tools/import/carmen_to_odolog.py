#!/usr/bin/env python3
"""carmen_to_odolog.py: the SLAM-corrected Intel Research Lab CARMEN log -> odolog v1.

Usage:
    carmen_to_odolog.py LOG[.gz] --out FILE [--max-scans N] [--fix-every N]
                        [--scans [--range-max M] [--range-sigma S]]

Source: ../shared/data/carmen/intel-corrected.log.gz (read its README.md): recorded by
Dirk Haehnel in the Intel Research Lab, Seattle, distributed through Radish (the Robotics
Data Set Repository) as the log GMapping corrected; this copy from acschaefer/ple. No
separate data licence is stated: the output carries a credit line.

What the corrected log holds (checked by this importer line by line; a file that does
not follow it is refused, because the mapping below depends on it):
- `FLASER n r1..rn x y theta odom_x odom_y odom_theta ts host lts`: x y theta is the
  SLAM-corrected pose P_k of processed scan k, and the odom_* fields repeat it (so FLASER
  lines carry no raw odometry).
- the line just before FLASER k is an ODOM line with the same timestamp: the raw
  odometry at scan time, in the frame anchored at P_(k-1);
- the first ODOM line after FLASER k equals P_k (its timestamp is 0 or garbage): it
  re-anchors odometry. The ODOM lines after it, up to the one just before FLASER k+1,
  are raw odometry sub-steps in that anchored frame.
So the raw odometry increment between consecutive ODOM lines of one anchored segment is
    u = inverse(O_j) (+) O_(j+1)            (robot frame at O_j: dx, dy, dtheta)
and the jump from the ODOM before a FLASER to the anchor after it is the SLAM correction,
not motion: it is never turned into ticks.

Mapping (format: docs/odolog.md):
- odolog has no raw-pose odometry record, so each sub-step becomes the encoder ticks of
  an EQUIVALENT differential drive: `drive diff`, `param wheel_radius_m 0.0825`,
  `param ticks_per_rev 4096`, `param wheelbase_m 0.33` (declared constants, not a
  measurement of the Pioneer; one tick = 2*pi*0.0825/4096 = 0.1266 mm of wheel travel).
  The sub-step is read with the project's mid-point motion model (motion.hpp:
  x' = x + rho cos(theta + dtheta/2), ...): rho = dx cos(dtheta/2) + dy sin(dtheta/2)
  (signed, so reversing gives negative travel), dtheta wrapped to (-pi, pi]. The wheels
  travel R = rho + dtheta*d/2, L = rho - dtheta*d/2 (d = 0.33 m). The running sums of R and
  L are quantised to ticks by rounding (so the rounding remainder is carried, never
  accumulated). The sideways component -dx sin(dtheta/2) + dy cos(dtheta/2) that a
  differential drive cannot produce is dropped; its total is reported in a meta line.
- one `enc T A B` per ODOM sub-step (A = right, B = left, cumulative from 0); the log
  starts at the first processed scan with `enc t0 0 0` and `init P_0` (sigmas 0.01 m,
  0.01 m, 0.01 rad: the truth starts exactly there). The ODOM lines before the first
  FLASER (about 0.7 m and 0.46 rad of motion from the odometry origin) are dropped: no
  corrected pose relates their frame to the map frame, so no truth or prior could be
  given for them. The ODOM sub-steps after the last FLASER are kept (enc only).
- one `truth T X Y THETA` per FLASER line (the corrected pose P_k), at the time of the
  enc record of the ODOM line just before it (the same raw timestamp), written after
  that enc record. It is a SLAM result (good to a few cm and about a degree), not
  motion capture.
- with --fix-every N > 0, scans k = N, 2N, ... also give a `pose` fix at P_k with
  sigmas 0.03 m, 0.03 m, 0.02 rad (default 0: no fixes; scan 0 never, it is the init).
- without --scans: NO `laser`, `scan` or `wall` records.
- with --scans: the header gets `laser 180 -1.5707963 0.017453293 RANGE_MAX SIGMA 0 0 0`
  (first beam at -90 deg, counter-clockwise, one beam per DEGREE: the step was measured
  against the alternative reading 180/179 deg by building the occupancy grid both ways,
  see docs/map-format.md; the laser is taken at the robot's origin, as no mount offset is
  known for this log), and each FLASER gives `scan T r1..r180` at its truth record's time,
  the ranges copied as written, `nan` where the log says no return (81.83 m, or any range
  >= 81 m). RANGE_MAX defaults to 30 m (the longest return in the log is 25.4 m) and SIGMA to
  0.03 m (a declared value, not a measurement). Still no `wall` records: the map is a
  separate file (`odoerr map grid-from-carmen` then `odoerr map import`, passed to replay
  with --map). Note that such a map is built from the very corrected poses that serve as
  truth here, so a pose error against that truth is partly circular (the map and the truth
  share the SLAM system's errors).
- time: the CARMEN ipc timestamps go backwards in places (622 times over the lines used,
  by up to 0.9 s), often repeat the previous stamp, and the anchor lines carry 0 or
  garbage (1e-42). So the written time is synthetic, built in file order over the ODOM
  sub-step lines and FLASER lines used:
        t_j = max(ts_j, t_(j-1) + 0.001 s),   t_0 = ts of the first FLASER
  It stays on the source's clock wherever that is monotonic, never lags it, and is
  strictly increasing, so every enc record has its own time and a truth / pose record
  (which takes the time of the ODOM line just before its FLASER) sits on exactly one
  enc record: a reader that looks up the counts at a fix's time gets the right ones.
  How many stamps were moved, and by how much at most, is written in a meta line.
  --max-scans N stops after the N-th processed scan.
- `meta source carmen intel-corrected`, a credit line, the SHA-256 of the input (of the
  decompressed text) and the conversion statistics. The output depends only on the input
  and the options: running twice gives identical files.

Malformed input (an ODOM or FLASER line with the wrong field count or a non-numeric
value, a FLASER whose pose and odom fields differ, a FLASER not preceded by an ODOM line
of the same timestamp, an anchor ODOM that does not repeat the FLASER pose, bytes that
are not text, no FLASER at all) is refused with `FILE:LINE: what is wrong` on stderr and
exit status 2 (line numbers count lines of the decompressed text); nothing is written then.
Other message types (PARAM, NEFF, comments, and any not named above) are skipped.
"""

import hashlib
import math
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from import_common import InputError, Parser, parse_number, read_bytes, run, write_atomic  # noqa: E402

WHEEL_RADIUS_M = 0.0825
TICKS_PER_REV = 4096
WHEELBASE_M = 0.33
TICK_M = 2 * math.pi * WHEEL_RADIUS_M / TICKS_PER_REV
INIT_SIGMA = (0.01, 0.01, 0.01)
FIX_SIGMA = (0.03, 0.03, 0.02)
TIME_STEP_MIN = 0.001      # s, the synthetic clock's smallest step
NO_RETURN_M = 81.0         # FLASER ranges at or above this (81.83) mean no return
BEAM_MIN = -math.pi / 2    # first FLASER beam (rad, robot frame)
BEAM_STEP = math.pi / 180  # one degree per beam (measured: docs/map-format.md)
ANCHOR_TOL = 1e-4          # m / rad: anchor ODOM must repeat the FLASER pose

INT_RE = re.compile(r"^\d+$")


def wrap(a):
    """Angle to (-pi, pi]."""
    a = math.fmod(a + math.pi, 2 * math.pi)
    if a <= 0:
        a += 2 * math.pi
    return a - math.pi


def read_text(path):
    data = read_bytes(path)
    return data, hashlib.sha256(data).hexdigest()


def parse_odom(f, where):
    # ODOM x y theta tv rv accel ipc_timestamp ipc_hostname logger_timestamp
    if len(f) != 10:
        raise InputError(f"{where}: ODOM takes 9 fields (x y theta tv rv accel ts host lts), got {len(f) - 1}")
    x = parse_number(f[1], where, "ODOM x")
    y = parse_number(f[2], where, "ODOM y")
    th = parse_number(f[3], where, "ODOM theta")
    for i, name in ((4, "tv"), (5, "rv"), (6, "accel"), (9, "logger_timestamp")):
        parse_number(f[i], where, f"ODOM {name}")
    ts = parse_number(f[7], where, "ODOM ipc_timestamp")
    return x, y, th, ts, f[7]


def parse_flaser(f, where):
    # FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp
    if len(f) < 2 or not INT_RE.match(f[1]):
        raise InputError(f"{where}: FLASER: the beam count '{f[1] if len(f) > 1 else ''}' is not a count")
    n = int(f[1])
    if len(f) != n + 11:
        raise InputError(f"{where}: FLASER with {n} beams takes {n + 10} fields, got {len(f) - 1}")
    for i in range(2, 2 + n):
        parse_number(f[i], where, f"FLASER range {i - 1}")
    p = [parse_number(f[2 + n + i], where, name) for i, name in
         enumerate(("x", "y", "theta", "odom_x", "odom_y", "odom_theta"))]
    parse_number(f[n + 10], where, "FLASER logger_timestamp")
    ts = parse_number(f[n + 8], where, "FLASER ipc_timestamp")
    if p[0:3] != p[3:6]:
        raise InputError(f"{where}: FLASER pose and odom pose differ: not the SLAM-corrected layout "
                         f"this importer understands (see the docstring)")
    return p[0], p[1], p[2], ts, f[n + 8]


class Converter:
    def __init__(self, max_scans, fix_every, scans=False, range_max=30.0, range_sigma=0.03):
        self.max_scans = max_scans
        self.fix_every = fix_every
        self.with_scans = scans
        self.range_max = range_max
        self.range_sigma = range_sigma
        self.beams = None
        self.no_returns = 0
        self.returns = 0
        self.body = []
        self.scans = 0
        self.t = None               # last written time
        self.prev_ts = None         # last raw stamp seen (for the backwards count)
        self.backwards = 0
        self.repeats = 0
        self.moved = 0
        self.max_shift = 0.0
        self.stamps = 0
        self.cum_r = 0.0
        self.cum_l = 0.0
        self.substeps = 0
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

    def clock(self, ts):
        """The synthetic strictly increasing time for a raw stamp, in file order."""
        self.stamps += 1
        if self.prev_ts is not None and ts < self.prev_ts:
            self.backwards += 1
        elif self.prev_ts is not None and ts == self.prev_ts:
            self.repeats += 1
        self.prev_ts = ts
        t = ts if self.t is None else max(ts, self.t + TIME_STEP_MIN)
        if t != ts:
            self.moved += 1
            self.max_shift = max(self.max_shift, t - ts)
        self.t = t
        return t

    def substep(self, a, b, t):
        ax, ay, ath = a
        bx, by, bth = b
        c, s = math.cos(ath), math.sin(ath)
        wx, wy = bx - ax, by - ay
        dx = c * wx + s * wy
        dy = -s * wx + c * wy
        dth = wrap(bth - ath)
        ch, sh = math.cos(dth / 2), math.sin(dth / 2)
        rho = dx * ch + dy * sh
        side = -dx * sh + dy * ch
        self.cum_r += rho + dth * WHEELBASE_M / 2
        self.cum_l += rho - dth * WHEELBASE_M / 2
        ticks_r = math.floor(self.cum_r / TICK_M + 0.5)
        ticks_l = math.floor(self.cum_l / TICK_M + 0.5)
        self.body.append(f"enc {t:.6f} {ticks_r} {ticks_l}")
        self.substeps += 1
        self.side_sum += abs(side)
        self.side_max = max(self.side_max, abs(side))
        self.path += math.hypot(dx, dy)
        self.rot += abs(dth)
        self.max_dth = max(self.max_dth, abs(dth))
        self.t_end = t

    def scan_record(self, f, t, where):
        n = int(f[1])
        if self.beams is None:
            self.beams = n
        elif n != self.beams:
            raise InputError(f"{where}: FLASER with {n} beams, the first one had {self.beams}: "
                             f"one odolog `laser` record cannot describe both")
        out = []
        for tok in f[2:2 + n]:
            if float(tok) >= NO_RETURN_M:
                out.append("nan")
                self.no_returns += 1
            else:
                out.append(tok)
                self.returns += 1
        self.body.append(f"scan {t:.6f} " + " ".join(out))

    def run(self, data, path):
        state = "prefix"          # prefix -> (scan -> anchor -> segment)*
        last_odom = None          # (pose, ts_text, line) of the last raw ODOM line
        pose = None               # the pose sub-steps start from
        last_scan_pose = None
        for no, raw in enumerate(data.split(b"\n"), start=1):
            where = f"{path}:{no}"
            try:
                line = raw.decode("ascii")
            except UnicodeDecodeError:
                raise InputError(f"{where}: the line is not ASCII text") from None
            f = line.split()
            if not f or f[0].startswith("#"):
                continue
            kind = f[0]
            if kind == "ODOM":
                x, y, th, ts, ts_text = parse_odom(f, where)
                if state == "prefix":
                    self.prefix_odom += 1
                    last_odom = ((x, y, th), ts_text, no)
                elif state == "anchor":
                    px, py, pth = last_scan_pose
                    if abs(x - px) > ANCHOR_TOL or abs(y - py) > ANCHOR_TOL or abs(wrap(th - pth)) > ANCHOR_TOL:
                        raise InputError(f"{where}: the ODOM line after a FLASER must repeat its corrected pose "
                                         f"({px} {py} {pth}), got ({f[1]} {f[2]} {f[3]})")
                    pose = last_scan_pose   # re-anchored; its timestamp is not used
                    state = "segment"
                    last_odom = None
                else:  # segment: a raw sub-step
                    if self.max_scans is not None and self.scans >= self.max_scans:
                        break
                    t = self.clock(ts)
                    self.substep(pose, (x, y, th), t)
                    pose = (x, y, th)
                    last_odom = ((x, y, th), ts_text, no)
                    if self.scans > 0:
                        self.after_last += 1
            elif kind == "FLASER":
                x, y, th, ts, ts_text = parse_flaser(f, where)
                if state == "anchor":
                    raise InputError(f"{where}: two FLASER lines without the anchoring ODOM line between them")
                if last_odom is None or float(last_odom[1]) != ts:
                    raise InputError(f"{where}: a FLASER must follow an ODOM line with the same timestamp "
                                     f"({ts_text}); the line before it is not one")
                if self.max_scans is not None and self.scans >= self.max_scans:
                    break
                k = self.scans
                if state == "prefix":
                    t = self.clock(ts)
                    self.init = (x, y, th)
                    self.body.append(f"enc {t:.6f} 0 0")
                    self.t_end = t
                else:
                    t = self.t      # the time of the ODOM line just before
                self.body.append(f"truth {t:.6f} {x:.6f} {y:.6f} {th:.6f}")
                if self.with_scans:
                    self.scan_record(f, t, where)
                if self.fix_every > 0 and k > 0 and k % self.fix_every == 0:
                    self.body.append(f"pose {t:.6f} {x:.6f} {y:.6f} {th:.6f} "
                                     f"{FIX_SIGMA[0]:g} {FIX_SIGMA[1]:g} {FIX_SIGMA[2]:g}")
                    self.fixes += 1
                self.scans += 1
                self.after_last = 0
                last_scan_pose = (x, y, th)
                state = "anchor"
            # PARAM, NEFF and anything else: skipped
        if self.scans == 0:
            raise InputError(f"{path}: no FLASER line: nothing to convert")

    def text(self, digest, max_scans):
        h = []
        w = h.append
        x, y, th = self.init
        w("odolog 1")
        w("# Intel Research Lab (CARMEN, SLAM-corrected) converted by tools/import/carmen_to_odolog.py")
        w("# enc: raw odometry sub-steps turned into the ticks of an equivalent differential drive")
        w("#      (d = 0.33 m, r = 0.0825 m, 4096 ticks/rev; mid-point model; sideways part dropped)")
        w("# truth: SLAM-corrected FLASER poses (a SLAM result, not motion capture)")
        if self.with_scans:
            w("# scan: the FLASER ranges (nan = no return); no wall records: the map is a separate file")
            w("#       (odoerr map grid-from-carmen + odoerr map import), built from the corrected poses,")
            w("#       so scoring against the truth below is partly circular (shared SLAM errors).")
        else:
            w("# No laser/scan/wall records (use --scans for the laser; the map is a separate file).")
        w("meta source carmen intel-corrected")
        w("meta credit recorded by Dirk Haehnel (Intel Research Lab, Seattle); distributed by Radish, "
          "the Robotics Data Set Repository; SLAM-corrected copy from github.com/acschaefer/ple "
          "data/carmen/intel-corrected.log.gz; no separate data licence stated")
        w(f"meta source_sha256 {digest} (decompressed text)")
        w("meta importer tools/import/carmen_to_odolog.py")
        w(f"meta scans {self.scans}{'' if max_scans is None else f' (--max-scans {max_scans})'}; "
          f"odom sub-steps {self.substeps} ({self.after_last} after the last scan); "
          f"{self.prefix_odom} ODOM lines before the first scan dropped")
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
        w("drive diff")
        w(f"param wheel_radius_m {WHEEL_RADIUS_M:g}")
        w(f"param ticks_per_rev {TICKS_PER_REV}")
        w(f"param wheelbase_m {WHEELBASE_M:g}")
        if self.with_scans:
            w(f"laser {self.beams} {BEAM_MIN:.9f} {BEAM_STEP:.9f} {self.range_max:g} {self.range_sigma:g} 0 0 0")
        w(f"init {x:.6f} {y:.6f} {th:.6f} {INIT_SIGMA[0]:g} {INIT_SIGMA[1]:g} {INIT_SIGMA[2]:g}")
        return "\n".join(h + self.body) + "\n"


def main(argv=None):
    ap = Parser(prog="carmen_to_odolog.py",
                description="Convert the SLAM-corrected Intel Research Lab CARMEN log to odolog v1.")
    ap.add_argument("log", metavar="LOG")
    ap.add_argument("--out", required=True, metavar="FILE")
    ap.add_argument("--max-scans", type=int, default=None, metavar="N",
                    help="stop after the N-th processed scan (default: all)")
    ap.add_argument("--fix-every", type=int, default=0, metavar="N",
                    help="a pose fix at every N-th scan (default 0: none)")
    ap.add_argument("--scans", action="store_true",
                    help="also write the laser record and a scan record per FLASER")
    ap.add_argument("--range-max", type=float, default=30.0, metavar="M",
                    help="the laser record's range_max (m), default 30 (with --scans)")
    ap.add_argument("--range-sigma", type=float, default=0.03, metavar="S",
                    help="the laser record's range noise std (m), default 0.03 (with --scans)")
    a = ap.parse_args(argv)
    if not (a.range_max > 0 and a.range_sigma > 0):
        ap.error("--range-max and --range-sigma must be > 0")
    if a.max_scans is not None and a.max_scans < 1:
        ap.error("--max-scans must be >= 1")
    if a.fix_every < 0:
        ap.error("--fix-every must be >= 0")
    try:
        data, digest = read_text(a.log)
        conv = Converter(a.max_scans, a.fix_every, a.scans, a.range_max, a.range_sigma)
        conv.run(data, a.log)
        write_atomic(a.out, conv.text(digest, a.max_scans))
    except InputError as e:
        sys.stderr.write(f"error: {e}\n")
        return 2
    sys.stderr.write(f"{a.out}: {conv.scans} scans, {conv.substeps} odometry sub-steps, "
                     f"{conv.fixes} pose fixes, {conv.t_end - float(conv.body[0].split()[1]):.1f} s, "
                     f"odometry path {conv.path:.2f} m\n")
    return 0


if __name__ == "__main__":
    run(main)
