#!/usr/bin/python3
"""odosim.py: an independent Python simulator of recorded drives (odolog v1).

Purpose
-------
odoerr's diagnostics must work on drives made by *other* simulators of the same physics,
not only on the drives of its own C++ simulator. This command is such a simulator, written
from the physics definitions alone (the Martinelli & Siegwart error models, the odolog v1
spec and docs/effect-catalogue.md); it shares no code with odoerr. It needs only Python 3
and numpy. Its modules beside it: world.py (the room, the controller's gains, the map
errors), effect_table.py (the effects' names and parameter counts), motion.py (the path,
the speed schedule, the wheels and the truth), laser.py (the scans), world_events.py (doors
and walkers).

Usage
-----
    python3 tools/pysim/odosim.py --out FILE [--drive diff|sync] [--seed N]
                                  [--minutes M] [--accel A] [--effect NAME=V1[,V2...]]...
                                  [--noisy-rates] [--map-error KIND=V1,...]...
    python3 tools/pysim/odosim.py --list-effects
    python3 tools/pysim/odosim.py --list-map-errors

``--effect`` may be repeated (catalogue effects, per-wheel effects and out-of-catalogue
``ooc_`` forms below, in any combination); the values are the effect's parameters in the
order of the catalogue, e.g. ``--effect turn_slip=0.03``, ``--effect laser_mount_xy=0.02,-0.01``,
``--effect wall_offset=0.05,0,0,0`` (wall_offset takes 1..W values, W = number of walls;
missing trailing walls get 0). Unknown names, repeated names or wrong value counts are
an error (exit status 2). Effects that are not named keep their nominal value 0.

The same seed gives the same schedule and the same noise draws whatever effects are
injected (each random stream has its own generator), so a clean drive and an effect
drive with the same seed differ by the effect only (plus the controller's response to it).

World
-----
A 10 m x 10 m room, walls (0,0)-(10,0)-(10,10)-(0,10), and two interior boxes (one
1.2 m x 1.2 m on the right, one 0.8 m x 0.8 m near the top-left corner) so that the map
is not symmetric. All walls are written as ``wall`` records, each polygon counter-
clockwise, so the left normal of a room wall points into the room and the left normal
of a box wall points into the box.

Robot and its systematic / non-systematic odometry errors (paper, Section 2)
---------------------------------------------------------------------------
diff (default): nominal wheel radius 0.05 m, 4096 ticks/rev, wheelbase 0.5 m.
    Encoder travel of a wheel in a cycle: rho_e = dticks * 2 pi r / ticks_per_rev.
    True wheel travel: R = delta_R rho_eR + nu_R, L = delta_L rho_eL + nu_L,
    nu ~ N(0, K_w |rho_e|) per wheel; rho = (R + L)/2, dtheta = (R - L)/(d delta_d),
    side = 0. delta_R = 1.01, delta_L = 0.99, delta_d = 1.02, K_w = 2.5e-4 m.
sync: ticks_per_m = 20000 (translation), ticks_per_rad = 20000 (steering).
    rho = delta_rho rho_e + nu_rho, dtheta = dtheta_e + E_theta rho_e + nu_theta,
    nu_rho ~ N(0, K_rho |rho_e|), nu_theta ~ N(0, K_theta |rho_e|);
    delta_rho = 1.02, E_theta = 0.5 deg/m, K_rho = 1e-4 m, K_theta = 3e-5 rad^2/m.
    The drift term is E_theta * rho_e with the *signed* encoder travel, as in the
    paper's eq. (1) and in odoerr's model (docs/paper-notes.md): the drift reverses when
    the robot drives backwards.
These "truth parameters" are written as ``meta truth_param NAME VALUE``.

Encoders count cumulative integer ticks (floor of the continuous cumulative count, so
the fractional remainder is carried, never lost); the truth of a cycle is drawn from the
quantised increment the log contains, which is exactly the model the estimator assumes.

Motion effects (docs/effect-catalogue.md), applied in the catalogue's order to the
drive model's increment (rho, dtheta, side) before the pose moves:
    turn_slip k          side   += k v w rho
    rotation_slip k      dtheta *= 1 - k |w|
    speed_scale k        rho    *= 1 + k |v|
    wheel_eccentricity a,b  rho *= 1 + a cos(phi) + b sin(phi), phi = s_enc / r_wheel
                            (s_enc: the encoders' cumulative signed travel, nominal constants)
    backlash b           rho    *= 1 - (b / 0.05) * min(1, (0.05 - s_rev) / |rho|)   while s_rev < 0.05 m
    region_scale c0..c8  rho    *= 1 + c_j (3x3 grid over the map's bounding box)
    radius_drift g       rho    *= 1 + g s_abs / 100
    turn_noise q         dtheta += N(0, q |dtheta|)
with v = rho/dt, w = dtheta/dt (dt = 0.01 s). Where the catalogue leaves a choice, this
simulator takes the following readings (the parent project may want to pin them down):
  * The rates and magnitudes an effect depends on (v, w, rho in turn_slip, |dtheta| in
    turn_noise) and the path statistics s_abs, s_signed, s_rev are those of the drive
    model's NOISE-FREE increment (the encoder travel through the true delta parameters,
    the mean of eq. 1-4), carried through the earlier effects. Each effect's factor or
    term is then applied to the truth's increment, which includes the sampled noise.
    Reason: the per-cycle noise of the paper's model is large at 100 Hz (about 0.3 rad/s
    of "turn rate" per cycle at 0.5 m/s), so evaluating |w| on the noisy draw would bias
    rotation_slip by tens of percent and change the heading noise on straights, and
    accumulating the noisy rho would random-walk the eccentricity phase by radians over
    100 m; an estimator can only ever use the mean. ``--noisy-rates`` selects the literal
    reading instead (everything evaluated on the noisy increment); the choice is written
    as ``meta effect_rates mean|noisy``.
  * s_abs, s_signed and s_rev are the values at the start of the cycle (previous cycles
    only). A reversal is a cycle whose rho has the opposite sign of the last non-zero rho;
    s_rev is 0 for that cycle and infinite before the first reversal.
  * region_scale uses the true position at the start of the cycle; the map's bounding box
    is that of the walls as written (the nominal map).
  * With the catalogue's order, v and w are the same before and after the earlier effects
    (turn_slip changes only side, rotation_slip only dtheta).
The pose then moves by the mid-point rule:
    x += rho cos(theta + dtheta/2) - side sin(theta + dtheta/2)
    y += rho sin(theta + dtheta/2) + side cos(theta + dtheta/2),  theta += dtheta.

Measurement effects change the ranges:
    range_bias b         r = r_true + b
    range_scale s        r = r_true (1 + s)          (applied after range_bias)
    laser_mount_xy dx,dy the laser sits at (mount_x + dx, mount_y + dy)
    laser_mount_yaw dpsi the laser's yaw is mount_yaw + dpsi
    scan_latency tau     the scan stamped t is cast from the true pose at t - tau
                         (linear interpolation of the 100 Hz truth, clamped to the drive)
    wall_offset o_1..o_W wall w lies o_w along its left unit normal
Ray casting is exact against the true (possibly offset) segments; Gaussian range noise
sigma = 0.03 m is added last; no return (or a true range beyond range_max) gives nan.

Map errors (``--map-error``, independent of ``--effect``)
-------------------------------------------------------
A building's map is never the building. ``--map-error KIND=V1,...`` (repeatable, kinds
in any combination, each kind more than once) makes the map written as ``wall`` records
differ from the world the laser sees; the robot, its odometry and its laser are those of
the drive without map errors (the same seed gives the same motion, encoders, truth and
range-noise draws with or without them: the ranges differ only where a beam meets the
error). Each is also written as ``meta truth_map_error KIND V1 ...`` (after the
``truth_effect`` records), so the log carries its own truth.
    object=x,y,w,h    an axis-aligned box, centre (x, y), size w x h m (w along x), that
                      stands in the world (the laser sees it and it occludes what is
                      behind it) but is NOT in the wall records: a cabinet moved in, a
                      pallet, a pillar left out of the drawing. Beams that meet it come
                      back SHORTER than the map predicts. It must lie inside the room and
                      keep OBJECT_CLEARANCE = 0.5 m from the reference path (the robot
                      would drive through it otherwise): refused with exit status 2.
    phantom=x1,y1,x2,y2
                      a wall written into the map (a ``wall`` record after the real ones)
                      that does not exist in the world: a door drawn closed, a partition
                      taken down. Beams the map says stop at it go further: LONGER than
                      predicted. It must have a length > 0 and lie inside the room.
    shift=i,d         map wall i (0-based index of the written ``wall`` records; the real
                      walls come first, in the order of the World section, so 0..W-1)
                      written d metres along its left unit normal from where it really is:
                      a wall drawn in the wrong place. The polygons are counter-clockwise,
                      so d > 0 moves a room wall INTO the room (nearer to the robot: the
                      ranges are LONGER than predicted) and a box wall INTO its box (further
                      from the robot: SHORTER). Only the written end points move (the
                      corners of the neighbouring walls stay where they are). |d| <= 1 m,
                      i an integer in 0..W-1, each wall shifted at most once.
    door=x1,y1,x2,y2,t_open, walker=x1,y1,x2,y2,speed
                      the world changing during the drive: a door closed until t_open s
                      and open after; a 0.4 m person walking to and fro along a segment
                      (tools/pysim/world_events.py has their rules).
Refused with exit status 2: an unknown kind, a wrong value count, values that are not
finite numbers, w or h <= 0, a zero-length phantom, an index out of range. An object or
a phantom may overlap a real wall (a cabinet against a wall). The map errors change
neither the robot's path nor region_scale's grid (the bounding box of the true walls).
``wall_offset`` (an effect: the WORLD's wall moved) and ``shift`` (the MAP's wall moved)
compose: a wall with o_w = d and shift d is written where it really is.
Suggested test placements (``--list-map-errors``; each met by more than a thousand beams
in more than a thousand scans of a 4-minute drive of seeds 21 and 22, from many poses,
and at least 1.25 m from the path):
    cabinet     object=5.0,0.2,0.6,0.4    a 0.6 x 0.4 cabinet against the bottom wall
                                          (x 4.7..5.3, y 0..0.4): 2794 / 2545 beams
    pillar      object=4.3,3.2,0.3,0.3    a 0.3 x 0.3 pillar in the open, at the centre
                                          of the lower lobe (1.25 m from the path):
                                          2791 / 2610 beams
    pallet      object=7.5,3.0,1.0,0.5    a 1.0 x 0.5 pallet in the open right of the
                                          lower lobe (x 7..8, y 2.75..3.25): 3614 / 3559
    phantom     phantom=1.5,3.0,1.5,4.5   a 1.5 m partition drawn at x = 1.5 (1.4 m left
                                          of the path, 1.5 m in front of the left wall):
                                          the map's first wall for 5131 / 5246 beams
    shift_room  shift=0,0.10              the bottom room wall drawn 0.10 m into the room
                                          (at y = 0.10; ranges longer): 24790 / 23595
    shift_box   shift=4,0.10              the bottom wall of the 1.2 m box drawn 0.10 m
                                          into the box (at y = 6.10; ranges shorter):
                                          1663 / 1380 beams
(beams met on seeds 21 / 22; odosim prints the count of every map error it injects.)

Per-wheel catalogue effects (diff drive only; refused for sync with exit status 2)
---------------------------------------------------------------------------------
They act on the drive model's noise-free wheel travels of the cycle,
R = rho + dtheta d/2, L = rho - dtheta d/2 with d = wheelbase * delta_d (the truth's
wheelbase, so R and L are the wheels' mean travels delta_R rho_eR, delta_L rho_eL exactly);
then rho = (R + L)/2, dtheta = (R - L)/d. As for the robot-level effects, each wheel's
factor is evaluated on the noise-free travel and applied to it and to the noisy wheel
travel alike (with --noisy-rates, evaluated on the noisy travels). They act before the
robot-level effects (the catalogue's list); with one effect active the order does not
matter. v_X = X / dt.
    wheel_backlash b_R,b_L     per wheel X, with s_rev_X its |travel| since ITS OWN last
                               reversal (sign of X opposite to the last non-zero sign of X;
                               infinite before the first): while s_rev_X < 0.05 m,
                               X *= 1 - (b_X / 0.05) min(1, (0.05 - s_rev_X) / |X|):
                               exactly b_X is lost per reversal of that wheel, whatever
                               the cycle length (the robot-level backlash, per wheel).
                               Test size 0.01, 0.006 m.
    wheel_speed_scale k_R,k_L  X *= 1 + k_X |v_X|.  Test size 0.05, 0.02 s/m.
The wheel statistics use the travel before any effect; the robot's s_abs, s_rev, ... are
still those of the drive model's increment before the effects.

Out-of-catalogue forms (``ooc_`` prefix)
----------------------------------------
Physically plausible effects that are NOT in the catalogue's exact form: drives for
testing what diagnose reports when the model lacks something the catalogue cannot express
(residual discovery, tests/diagnose/check_discovery.py). Each is listed with its formula,
parameters, test size (physically plausible and clearly visible on a 4-minute drive; for
comparison, on seed 21 the catalogue's test sizes change the per-0.5 s increments by an
RMS of 2.3 mm cross-track (turn_slip 0.05), 6.1 mm along-track (speed_scale 0.05),
and the ranges by 20 mm (range_bias 0.02)) and where the residuals of a model without it
should show it: frame (robot: along/cross/heading of each 0.5 s segment's motion; world:
x/y; wheel_R, wheel_L: a wheel's travel; beam: the range) and feature (the names of the
residual-discovery feature library, docs/diagnostics.md). Rates, travel and wheel travels
are the drive model's noise-free values, as for the catalogue's effects. They act after
the catalogue's robot-level effects (the wheel forms with the per-wheel effects).

Motion forms:
    ooc_world_drift cx,cy        after the pose update, x += cx |travel|, y += cy |travel|
                                 (travel: the drive model's rho before any effect): the
                                 robot is pushed in the WORLD frame by (cx, cy) per metre
                                 driven, whatever its heading or direction (a tilted floor:
                                 the robot creeps downhill). Test size 0.012, -0.008 (1.4 cm
                                 per metre; RMS 2.3 mm along, 2.1 mm cross per segment).
                                 Shows in: world x/y, abs_ds (or dt at near-constant speed).
    ooc_heading_scale k,theta0   rho *= 1 + k cos(theta - theta0), theta the true heading at
                                 the start of the cycle (a carpet's pile direction: the
                                 tyres travel further with the pile than against it).
                                 Test size 0.03, 0.5 rad (4.4 mm RMS along).
                                 Shows in: robot along, cos_heading_ds / sin_heading_ds.
    ooc_abrupt_scale t_c,kR      (diff) from the first cycle with t >= t_c (s, from the log's
                                 start) on, R *= 1 + kR: the right tyre loses pressure at
                                 t_c, its rolling radius falls by -kR. Test size 120 s,
                                 -0.02 (1 mm of a 50 mm radius; 1.1 deg of heading per
                                 metre; 6.4 mrad RMS heading per segment after t_c).
                                 Shows as: a change point at t_c; wheel_R ds_R (robot
                                 heading, ds_R).
    ooc_one_wheel_drag k         (diff) L *= 1 - k v_L^2: the left wheel alone slips
                                 backwards more the faster it turns, quadratically (a
                                 dragging brake or bearing); the catalogue's speed forms are
                                 linear in |v| and act on both wheels. Test size 0.1 s^2/m^2
                                 (2.5 % at 0.5 m/s, 6.4 % at 0.8 m/s; the drive model's
                                 delta_L absorbs the mean, so what is left is weak: today's
                                 diagnose calls the drive consistent, even at 0.1).
                                 Shows in: wheel_L ds_L_speed.
    ooc_turn_slip_cubic k        side += k (v w)^3 rho: the tyres' slip angle grows with the
                                 CUBE of the centripetal acceleration a = v w (the next odd
                                 term of a tyre's lateral force curve as it starts to
                                 saturate), where the catalogue's turn_slip is linear in a
                                 (side += k v w rho). Test size 0.2 s^6/m^3: slip angle 3 deg
                                 at a = 0.64 m/s^2 (0.8 m/s on the 1 m lobe), 0.2 deg at
                                 0.25 m/s^2 (1.6 mm RMS cross, up to 19 mm).
                                 Shows in: robot cross, v_w (or w2, v2, dth).
    ooc_accel_slip k,a0          while the motors' acceleration a (the commanded speed's change
                                 per cycle over dt; the encoders follow it) exceeds a0 in
                                 size, rho *= 1 - k (|a| - a0) when the robot speeds up
                                 (a v > 0: the wheels spin, the robot travels less than they
                                 turn) and rho *= 1 + k (|a| - a0) when it brakes (the wheels
                                 skid, it travels further), in either direction of travel.
                                 Acts after the catalogue's robot-level effects, before
                                 ooc_turn_slip_cubic. Test size 0.2 s^2/m, 1.0 m/s^2 on a
                                 drive with --accel 2 (speed ramps at 2 m/s^2: 20 % of the
                                 travel of every ramp, 12 mm on a ramp from 0 to 0.5 m/s;
                                 the default 0.6 m/s^2 ramp never reaches a0). At 0.05 the
                                 drives were called consistent: the per-cycle noise of the
                                 paper's model hides 3 mm per ramp.
                                 Shows in: robot along, acc_pos_ds / acc_neg_ds (acc_ds).
    ooc_reversal_drag c,span     (diff) L *= 1 - c while the robot's travel since its last
                                 reversal (s_rev, this cycle's reversal included) is below
                                 span m: one wheel drags just after the gear reverses (a
                                 brake shoe that binds). Test size 0.09, 0.3 m (27 mm of
                                 the left wheel, 54 mrad of heading, per reversal; at 0.03
                                 nothing was found: docs/diagnostics.md has the power by
                                 size).
                                 Shows in: wheel_L or robot heading, a reversal term
                                 (rev_near_ds, the per-wheel reversal loss).
Measurement forms (the truth's motion, encoders and range noise are those of the clean
drive with the same seed, so the ranges differ by the form alone; applied to the true range
before range_bias and range_scale):
    ooc_incidence_bias c         r += c (1/cos(inc) - 1), inc the angle between the beam and
                                 the hit wall's normal, held at its 80 deg value beyond 80
                                 deg (the spot smears along an oblique wall and the return
                                 comes late; zero at normal incidence). Test size 0.015 m
                                 (1.5 cm at 60 deg, at most 7 cm).
                                 Shows in: beam, inv_cos_inc (or inc2, abs_inc).
    ooc_beam_angle_scale s       the beam with angle alpha in the laser frame (alpha in
                                 [-pi, pi), 0 straight ahead) is really cast at
                                 alpha (1 + s), before the mount yaw is added (the mirror
                                 turns faster than nominal, angles referenced to the forward
                                 index mark). Test size 0.002 (6 mrad at the rear beams,
                                 3 mrad sideways; 0.003 gave a mean NIS of 1.5 on seed 21).
                                 Shows in: beam, alpha_angle_sens (= alpha dr/dalpha).
    ooc_range_time_drift c       r += c t, t the scan's time stamp in s from the log's start
                                 (the laser warms up). Test size 1e-4 m/s (2.4 cm after
                                 4 minutes). Shows in: beam, t.
None of them draws random numbers: the same seed gives the same noise whatever is
injected.

Sensors and records
-------------------
Encoders and truth at 100 Hz, a 36-beam laser at 10 Hz (angle_min -pi, step 2 pi/36,
range_max 20 m, sigma 0.03 m, mount (0.1, 0, 0)). Records at equal times are written enc,
scan, truth. ``init`` is the true start pose with sigmas 0.01.

Trajectory
----------
The reference path is a closed figure-eight with two lobes of different radii (1.4 m
turning right, 1.0 m turning left) joined by two 3.2 m straights that cross between them
(the internal tangents of the two circles). A seeded schedule alternates forward
stretches (6-12 s, 0.2-0.8 m/s, sometimes a change of speed) with backward stretches
(1.5-3.5 s, 0.2-0.5 m/s) along the same path, the speed ramped at 0.6 m/s^2 (--accel), so there are
several reversals per minute and turns of both signs in both directions of travel. The
path keeps more than 1.5 m from every wall and box.

Steering: the wheels follow the path curvature at the commanded (open-loop) progress; a
weak correction of the curvature, u = -k1 e_y - sign(v) k2 e_theta (k1 = 0.25 1/m^2,
k2 = 1 1/m), is recomputed only once per second from the TRUE pose (projection onto the
path). There is no high-rate feedback on a noisy pose, so the encoder inputs do not
correlate with the process noise the laser has not yet seen.
"""

from __future__ import annotations

import argparse
import math
import sys
import os
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
# The simulator's rooms, one responsibility each: the room and the map errors (world), the
# effects' table (effect_table), the path and the wheels (motion), the laser (laser).
from world import (ACCEL, ANGLE_INC, ANGLE_MIN, DIFF_TRUTH, DT, MAP_ERRORS,  # noqa: E402
                   MAP_ERROR_CASES, MOUNT, N_BEAMS, RANGE_MAX, RANGE_SIGMA, SYNC_TRUTH,
                   TICKS_PER_M, TICKS_PER_RAD, TICKS_PER_REV, WALLS, WHEELBASE, WHEEL_RADIUS,
                   map_walls, parse_map_errors)
from effect_table import DIFF_ONLY, EFFECTS, TEST_SIZES, parse_effects  # noqa: E402
from motion import Path, simulate_motion  # noqa: E402
from laser import min_clearance, simulate_scans  # noqa: E402

# ---------------------------------------------------------------------------
# Output
# ---------------------------------------------------------------------------

def write_log(fname, drive, seed, minutes, effects, enc, truth, k_scan, ranges,
              noisy_rates, map_errors=None, accel=ACCEL):
    out = ["odolog 1",
           f"meta source odosim.py seed={seed}",
           f"meta drive_minutes {minutes!r}",
           "meta note figure-eight with reversals; 1 Hz steering correction on the truth",
           "meta effect_rates " + ("noisy" if noisy_rates else "mean")]
    if accel != ACCEL:
        out.append(f"meta speed_ramp_m_s2 {accel!r}")
    out.append(f"drive {drive}")
    if drive == "diff":
        out += [f"param wheel_radius_m {WHEEL_RADIUS!r}",
                f"param ticks_per_rev {TICKS_PER_REV}",
                f"param wheelbase_m {WHEELBASE!r}"]
        tp = DIFF_TRUTH
    else:
        out += [f"param ticks_per_m {TICKS_PER_M}", f"param ticks_per_rad {TICKS_PER_RAD}"]
        tp = SYNC_TRUTH
    out += [f"meta truth_param {k} {v!r}" for k, v in tp.items()]
    for name, vals in effects.items():
        out.append(f"meta truth_effect {name} " + " ".join(repr(float(v)) for v in vals))
    out.append(f"laser {N_BEAMS} {ANGLE_MIN!r} {ANGLE_INC!r} {RANGE_MAX!r} "
               f"{RANGE_SIGMA!r} {MOUNT[0]!r} {MOUNT[1]!r} {MOUNT[2]!r}")
    for kind, items in (map_errors or {}).items():
        for vals in items:
            out.append(f"meta truth_map_error {kind} "
                       + " ".join(repr(v) if isinstance(v, int) else repr(float(v))
                                  for v in vals))
    out += ["wall " + " ".join(repr(float(c)) for c in w) for w in map_walls(map_errors)]
    x0, y0, th0 = truth[0]
    out.append(f"init {x0!r} {y0!r} {th0!r} 0.01 0.01 0.01")

    # data: per cycle enc, (scan), truth
    theta = (truth[:, 2] + math.pi) % (2.0 * math.pi) - math.pi
    scan_lines = {}
    for k, row in zip(k_scan, ranges):
        scan_lines[int(k)] = f"scan {k * DT:.2f} " + " ".join(
            "nan" if not math.isfinite(r) else f"{r:.6f}" for r in row)
    for k in range(len(enc)):
        t = f"{k * DT:.2f}"
        out.append(f"enc {t} {enc[k, 0]} {enc[k, 1]}")
        if k in scan_lines:
            out.append(scan_lines[k])
        out.append(f"truth {t} {truth[k, 0]:.9f} {truth[k, 1]:.9f} {theta[k]:.9f}")
    with open(fname, "w", encoding="utf-8") as f:
        f.write("\n".join(out) + "\n")


# ---------------------------------------------------------------------------
# Main
# ---------------------------------------------------------------------------

def main(argv=None):
    ap = argparse.ArgumentParser(
        description="Independent odolog v1 drive simulator with injectable effects "
                    "(see the module docstring for the physics).")
    ap.add_argument("--out", help="output odolog file")
    ap.add_argument("--drive", choices=["diff", "sync"], default="diff")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--minutes", type=float, default=4.0)
    ap.add_argument("--effect", action="append", default=[], metavar="NAME=V1[,V2...]",
                    help="inject an effect (repeatable); see --list-effects")
    ap.add_argument("--accel", type=float, default=ACCEL, metavar="A",
                    help="limit of the commanded speed's change, m/s^2 (default %(default)g; "
                         "ooc_accel_slip's test drives use 2)")
    ap.add_argument("--noisy-rates", action="store_true",
                    help="evaluate the effects' v, w, |dtheta| and path statistics on the "
                         "noisy truth increment (literal reading) instead of the drive "
                         "model's noise-free increment")
    ap.add_argument("--list-effects", action="store_true",
                    help="list the effects and their parameters, then exit")
    ap.add_argument("--map-error", action="append", default=[], metavar="KIND=V1,...",
                    help="make the map differ from the world (repeatable): object=x,y,w,h "
                         "(in the world, not in the map), phantom=x1,y1,x2,y2 (in the map, "
                         "not in the world), shift=i,d (map wall i written d m along its "
                         "left normal); see --list-map-errors")
    ap.add_argument("--list-map-errors", action="store_true",
                    help="list the map-error kinds and the suggested test placements, "
                         "then exit")
    args = ap.parse_args(argv)

    if args.list_effects:
        for name, (n, kind, desc) in EFFECTS.items():
            count = f"1..{len(WALLS)}" if n is None else str(n)
            extra = []
            if name in DIFF_ONLY:
                extra.append("diff only")
            if name in TEST_SIZES:
                extra.append("test size " + ",".join(repr(v) for v in TEST_SIZES[name]))
            extra = f" [{'; '.join(extra)}]" if extra else ""
            print(f"{name:22s} {kind:12s} {count:6s} {desc}{extra}")
        return 0
    if args.list_map_errors:
        for kind, (n, desc) in MAP_ERRORS.items():
            print(f"{kind:22s} {'map':12s} {n!s:6s} {desc}")
        for name, (kind, vals, note) in MAP_ERROR_CASES.items():
            spec = f"{kind}=" + ",".join(f"{v:g}" for v in vals)
            print(f"  case {name:15s} --map-error {spec:24s} {note}")
        return 0
    if not args.out:
        ap.error("--out FILE is required")
    if not (args.minutes > 0.0 and math.isfinite(args.minutes)):
        ap.error("--minutes must be positive")
    if args.seed < 0:
        ap.error("--seed must be >= 0")
    if not (0.0 < args.accel <= 20.0):
        ap.error("--accel must be in (0, 20] m/s^2")
    effects = parse_effects(args.effect, ap)
    if args.drive != "diff" and DIFF_ONLY & set(effects):
        ap.error("--effect " + ", ".join(sorted(DIFF_ONLY & set(effects)))
                 + ": acts on the two wheels separately, diff drive only")

    t0 = time.perf_counter()
    n_steps = int(round(args.minutes * 60.0 / DT))
    path = Path()
    map_errors = parse_map_errors(args.map_error, ap, path)
    rng_sched, rng_noise, rng_turn, rng_scan = (
        np.random.default_rng([args.seed, i]) for i in range(4))
    enc, truth = simulate_motion(args.drive, n_steps, effects, path,
                                 rng_sched, rng_noise, rng_turn, args.noisy_rates,
                                 accel=args.accel)
    seen = []
    k_scan, ranges = simulate_scans(truth, n_steps, effects, rng_scan, map_errors, seen)
    write_log(args.out, args.drive, args.seed, args.minutes, effects, enc, truth,
              k_scan, ranges, args.noisy_rates, map_errors, args.accel)
    for kind, vals, beams, scans in seen:
        print(f"odosim: map error {kind}=" + ",".join(f"{v:g}" for v in vals)
              + f": met by {beams} beams in {scans} scans", file=sys.stderr)
    clear = min_clearance(truth, map_errors)
    if clear <= 1.0:
        print(f"odosim: warning: the robot came within {clear:.2f} m of a wall",
              file=sys.stderr)
    print(f"odosim: wrote {args.out}: {args.drive}, {n_steps * DT:.0f} s, "
          f"{len(k_scan)} scans, min wall clearance {clear:.2f} m, "
          f"{time.perf_counter() - t0:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
