"""carmen_convert.py: the conversion of a CARMEN log's lines (carmen_log.read_log) into the
records of an odolog, by the rules carmen_to_odolog.py's docstring states: the time of each
line used, the pairing of each FLASER with its odometry and anchor, the scan records. The
ticks are carmen_ticks.py's; the header, carmen_header.py's."""

from import_common import InputError
from carmen_laser import laser_setup, pile_up
from carmen_ticks import TickWriter, wrap

INIT_SIGMA = (0.01, 0.01, 0.01)
FIX_SIGMA = (0.03, 0.03, 0.02)
TIME_STEP_MIN = 0.001      # s, the synthetic clock's smallest step
ORDER_STEP = 0.1           # s between lines used, with --time order
ANCHOR_TOL = 1e-4          # m / rad: an anchor ODOM must repeat the FLASER pose
RANGE_SIGMA_DEFAULT_M = 0.03


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
        self.odo = TickWriter(self.body)   # the enc records and their statistics
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
        self.fills = 0
        self.prefix_odom = 0
        self.after_last = 0
        self.fixes = 0
        self.init = None
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

    # ---------------------------------------------------------------- headings
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
            self.odo.start(t)
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
            self.odo.substep(pose, o.pose, t, self.t_prev)
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
            pose = self.odo.dead = None if pair is None else pair.pose
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
            self.odo.substep(pose, fl.odom, t, self.t_prev)
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
                    self.odo.dead = pose
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
