"""carmen_laser.py: the front laser of a CARMEN log, as the importer (carmen_to_odolog.py)
and the grid builder (tools/map/carmen_grid.py, `odoerr map grid-from-carmen`) both read it.
Standard library only. The rules (docs/real-data.md, "CARMEN logs: what the importer reads"):

- beam directions: a FLASER states none. The beam-count rule, as CARMEN reads a FLASER: the
  first beam at -90 deg (the robot's right), counter-clockwise, 180 and 181 beams 1 deg
  apart, 360 and 361 beams 0.5 deg apart. PARAM laser_front_laser_resolution (degrees) and
  / or laser_front_laser_fov (degrees; or radians when only that reading fits the beam
  count) win: the step is the resolution, the fov runs from the first beam to the last (or
  one step past it) and the first beam is at -fov/2. Another beam count without those
  PARAMs, PARAMs that do not fit the beam count, and a flipped laser are refused;
- the mount: PARAM robot_frontlaser_offset (m ahead of the robot's origin),
  robot_frontlaser_side_offset and robot_frontlaser_angular_offset, else 0 (the importer
  puts it in its laser record; the grid builder reports it and casts the beams from the
  FLASER pose, which CARMEN writes as the laser's own: docs/map-format.md has the measure);
- the range: RANGE_MAX from the caller's option, else PARAM robot_front_laser_max, else a
  default; a reading at or above the no-return limit is no return: the caller's option
  (--no-return), else PARAM robot_front_laser_max, else 80 m (CARMEN's maximum range of a
  FLASER);
- a no-return code no PARAM states: when the readings below the limit pile up at their top
  (the same few values, each repeated, in more than 0.1 % of all readings), `pile_up`
  says so and gives the --no-return that would take them; the caller does not decide it.
"""

import math

from import_common import InputError, parse_number

CARMEN_MAX_RANGE_M = 80.0  # CARMEN's maximum range of a FLASER without configuration
RANGE_MAX_DEFAULT_M = 30.0
# The beam-count rule: degrees between beams, first beam at -90 deg (CARMEN's reading of a
# FLASER, carmen_laser_guess_angle_increment; its 180 and 360 beam logs dropped the last beam).
BEAM_RULE_DEG = {180: 1.0, 181: 1.0, 360: 0.5, 361: 0.5}
ANGLE_TOL_DEG = 0.01
PILE_UP_BAND = 0.01        # reading values within 1 % of the largest one below the limit...
PILE_UP_REPEAT = 5         # ...each repeated at least 5 times...
PILE_UP_SHARE = 0.001      # ...in more than 0.1 % of all readings: a no-return code?
LASER_PARAMS = ("laser_front_laser_fov", "laser_front_laser_resolution", "laser_front_laser_flipped",
                "robot_frontlaser_offset", "robot_frontlaser_side_offset",
                "robot_frontlaser_angular_offset", "robot_front_laser_max")


class Param:
    __slots__ = ("name", "text", "value", "where", "no")


def parse_param(f, where, no, params):
    """Keeps the PARAMs the laser rules read (LASER_PARAMS) in params {name: Param}; the
    others are counted only by the caller. f: the line's fields."""
    if len(f) < 3:
        raise InputError(f"{where}: PARAM takes a name and a value, got {len(f) - 1} fields")
    name = f[1]
    if name not in LASER_PARAMS:
        return
    # PARAM name value [ipc_timestamp] host logger_timestamp
    if len(f) not in (5, 6):
        raise InputError(f"{where}: PARAM {name} takes 4 or 5 fields (name value [ts] host lts), got {len(f) - 1}")
    p = Param()
    p.name, p.text, p.where, p.no = name, f[2], where, no
    if name == "laser_front_laser_flipped" and f[2] in ("on", "off"):
        p.value = 1.0 if f[2] == "on" else 0.0
    else:
        p.value = parse_number(f[2], where, f"PARAM {name}")
    old = params.get(name)
    if old is not None and old.value != p.value:
        raise InputError(f"{where}: PARAM {name} changes from {old.text} (line {old.no}) to {p.text}: "
                         f"one odolog laser record cannot describe both")
    if old is None:
        params[name] = p


def laser_geometry(n, params, where):
    """(start_rad, step_rad, [notes]) for n beams: PARAM, else the beam-count rule."""
    if not 1 <= n <= 4096:
        raise InputError(f"{where}: FLASER with {n} beams: an odolog laser has 1 to 4096")
    flipped = params.get("laser_front_laser_flipped")
    if flipped is not None and flipped.value != 0:
        raise InputError(f"{flipped.where}: PARAM laser_front_laser_flipped {flipped.text}: the beam order "
                         f"of a flipped laser is not known to this importer")
    rule = BEAM_RULE_DEG.get(n)
    res = params.get("laser_front_laser_resolution")
    fov = params.get("laser_front_laser_fov")
    notes = []
    if res is not None:
        if not 0 < res.value <= 180:
            raise InputError(f"{res.where}: PARAM laser_front_laser_resolution {res.text}: not a beam step in "
                             f"degrees (0 to 180)")
        step, step_src = res.value, f"PARAM laser_front_laser_resolution {res.text} (line {res.no}, degrees)"
    elif rule is not None:
        step, step_src = rule, f"the beam-count rule ({n} beams: {rule:g} deg apart, as CARMEN reads a FLASER)"
    else:
        step, step_src = None, None

    def fits(fov_deg, s):
        return abs((n - 1) * s - fov_deg) <= ANGLE_TOL_DEG or abs(n * s - fov_deg) <= ANGLE_TOL_DEG

    if fov is not None:
        if not fov.value > 0:
            raise InputError(f"{fov.where}: PARAM laser_front_laser_fov {fov.text}: not a field of view")
        cands = [("degrees", fov.value)]
        if fov.value <= 2 * math.pi + 1e-3:
            cands.append(("radians", math.degrees(fov.value)))
        if res is not None:
            # two PARAMs: they must agree
            ok = [c for c in cands if fits(c[1], step)]
            if not ok:
                raise InputError(f"{fov.where}: PARAM laser_front_laser_fov {fov.text} does not fit {n} beams "
                                 f"{step:g} deg apart ({step_src}): that makes {(n - 1) * step:g} deg from the "
                                 f"first beam to the last, {n * step:g} deg with one more step")
        else:
            # the fov wins over the beam-count rule; the rule's step is kept where it fits, and it
            # tells degrees from radians
            if n < 2:
                raise InputError(f"{fov.where}: PARAM laser_front_laser_fov with a 1-beam laser: no step")
            ok = [c for c in cands if step is not None and fits(c[1], step)]
            if not ok and len(cands) > 1:
                raise InputError(f"{fov.where}: PARAM laser_front_laser_fov {fov.text}: with no resolution, and "
                                 f"no beam-count rule that fits it, its unit (degrees or radians) cannot be told")
            if not ok:
                ok = cands
                step = cands[0][1] / (n - 1)
                step_src = f"the PARAM fov spread over the {n - 1} steps between {n} beams"
        if len(ok) > 1:
            raise InputError(f"{fov.where}: PARAM laser_front_laser_fov {fov.text} fits {n} beams read in "
                             f"degrees and in radians: the unit cannot be told")
        unit, fov_deg = ok[0]
        why = ("" if len(cands) == 1 or unit == "degrees" else
               f"; in degrees it would not fit {n} beams {step:g} deg apart")
        start = -fov_deg / 2
        start_src = "-fov/2 (the sector centred ahead)"
        notes.append(f"fov {fov_deg:.6g} deg from PARAM laser_front_laser_fov {fov.text} (line {fov.no}, read in "
                     f"{unit}{why})")
        if abs((n - 1) * step - fov_deg) > ANGLE_TOL_DEG:
            notes.append(f"the fov is {n} steps: the sector's last beam is not in the log")
    else:
        if step is None:
            raise InputError(f"{where}: FLASER with {n} beams: no PARAM laser_front_laser_fov or "
                             f"laser_front_laser_resolution and no beam-count rule for {n} beams (it knows "
                             f"{', '.join(str(k) for k in sorted(BEAM_RULE_DEG))}): the beams' directions "
                             f"are not known")
        start, start_src = -90.0, "CARMEN's first FLASER beam (the robot's right)"
    if (n - 1) * step > 360 + ANGLE_TOL_DEG:
        raise InputError(f"{where}: {n} beams {step:g} deg apart span more than a turn")
    if rule is not None and (res is not None or fov is not None):
        if abs(step - rule) <= 1e-9 and abs(start + 90) <= ANGLE_TOL_DEG:
            notes.append("the beam-count rule agrees")
        else:
            notes.append(f"PARAM overrides the beam-count rule (-90 deg, {rule:g} deg apart)")
    head = (f"{n} beams counter-clockwise: the first at {start:.6g} deg from {start_src}; "
            f"{step:.6g} deg apart from {step_src}")
    return math.radians(start), math.radians(step), [head] + notes


class Laser:
    """The front laser of a log: n beams, the first at `start` rad, `step` rad apart (in the
    laser's frame); range_max (m); readings >= no_return (m) are no return; mount (x m ahead,
    y m to the left, yaw rad) from the robot's (corrected) pose; and where each came from:
    beam_notes, range_src, no_return_src, mount_src."""
    __slots__ = ("n", "start", "step", "beam_notes", "range_max", "range_src", "no_return", "no_return_src",
                 "mount", "mount_src")

    def angles(self):
        """The beams' directions in the robot frame (rad): start + i step + the mount's yaw."""
        return [self.start + i * self.step + self.mount[2] for i in range(self.n)]


def laser_setup(n, params, where, range_max=None, no_return=None, range_max_default=RANGE_MAX_DEFAULT_M):
    """The Laser of a log whose FLASER lines have n beams, from its PARAMs {name: Param} and
    the caller's options range_max (--range-max) and no_return (--no-return), None when not
    given; InputError (naming `where`, the first FLASER, or the PARAM's line) otherwise."""
    la = Laser()
    la.n = n
    la.start, la.step, la.beam_notes = laser_geometry(n, params, where)
    q = params.get("robot_front_laser_max")
    if q is not None and (range_max is None or no_return is None) and not q.value > 0:
        raise InputError(f"{q.where}: PARAM robot_front_laser_max {q.text}: not a range")
    def choose(given, option, default, default_src):
        """The option when given, else PARAM robot_front_laser_max, else the default; with its source."""
        if given is not None:
            return given, option
        if q is not None:
            return q.value, f"PARAM robot_front_laser_max {q.text} (line {q.no})"
        return default, default_src

    la.range_max, la.range_src = choose(range_max, "--range-max", range_max_default,
                                        "the default (no PARAM robot_front_laser_max, no --range-max)")
    la.no_return, la.no_return_src = choose(no_return, "--no-return", CARMEN_MAX_RANGE_M,
                                            "CARMEN's maximum range of a FLASER (no PARAM states one)")
    mount, msrc = [], []
    for name, what in (("robot_frontlaser_offset", "x"), ("robot_frontlaser_side_offset", "y"),
                       ("robot_frontlaser_angular_offset", "yaw")):
        p = params.get(name)
        mount.append(0.0 if p is None else p.value)
        msrc.append(f"{what} {p.value:g} from PARAM {name} {p.text} (line {p.no})" if p is not None
                    else f"{what} 0 (no PARAM {name})")
    la.mount, la.mount_src = tuple(mount), msrc
    return la


ISOLATED_RATIO = 10        # a pile taken as a code (--auto) holds >= 10x the readings of the band below it
ISOLATED_WIDTH = 10        # that band: 10 pile widths (a width at least 0.2 % of the top reading)


def isolated(top, low, hi):
    """(is the pile [low, hi] of the histogram top {reading: count} isolated, why): a
    no-return code stands alone above the ranges the laser measures; a pile that merely
    tops a continuum of readings (a room's far wall seen often) is not one."""
    width = max(hi - low, 0.002 * hi)
    pile = sum(c for v, c in top.items() if low <= v <= hi)
    below = sum(c for v, c in top.items() if low - ISOLATED_WIDTH * width <= v < low)
    why = (f"{pile} readings at {low:g}..{hi:g} m against {below} in the {ISOLATED_WIDTH * width:.3g} m below "
           f"them (a code needs {ISOLATED_RATIO}x)")
    return pile >= ISOLATED_RATIO * max(below, 1), why


def pile_up(top, total):
    """top: {reading (m): count} of the readings below the no-return limit; total: all
    readings (returns and no returns). When the readings pile up at their top (a no-return
    code the log does not state): (the lowest reading of the pile, which --no-return would
    take, and what piles up: 'N readings (S % of all) repeat the value V m'); else None."""
    if not top or total == 0:
        return None
    hi = max(top)
    pile = [v for v, c in top.items() if v >= hi * (1 - PILE_UP_BAND) and c >= PILE_UP_REPEAT]
    near = sum(top[v] for v in pile)
    if not pile or near <= PILE_UP_SHARE * total:
        return None
    low = min(pile)
    share = 100 * near / total
    vals = f"the value {hi:g} m" if len(pile) == 1 else f"{len(pile)} values from {low:g} to {hi:g} m"
    return low, f"{near} readings ({share:.2f} % of all) repeat {vals}"
