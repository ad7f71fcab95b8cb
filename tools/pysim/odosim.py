#!/usr/bin/python3
"""odosim.py: an independent Python simulator of recorded drives (odolog v1).

Purpose
-------
odoerr's diagnostics must work on drives made by *other* simulators of the same physics,
not only on the drives of its own C++ simulator. This file is such a simulator, written
from the physics definitions alone (the Martinelli & Siegwart error models, the odolog v1
spec and docs/effect-catalogue.md); it shares no code with odoerr. It needs only Python 3
and numpy.

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
import bisect
import math
import sys
import os
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import world_events  # noqa: E402  (doors and walkers: the world changing during the drive)

# ---------------------------------------------------------------------------
# Fixed set-up
# ---------------------------------------------------------------------------

DT = 0.01                 # encoder / truth period (s)
SCAN_EVERY = 10           # one scan every 10 encoder cycles (10 Hz)

# diff drive: nominal constants and the truth's systematic / non-systematic errors
WHEEL_RADIUS = 0.05
TICKS_PER_REV = 4096
WHEELBASE = 0.5
DIFF_TRUTH = {"delta_R": 1.01, "delta_L": 0.99, "delta_d": 1.02, "K_w": 2.5e-4}

# sync drive
TICKS_PER_M = 20000
TICKS_PER_RAD = 20000
SYNC_TRUTH = {"delta_rho": 1.02, "E_theta": math.radians(0.5), "K_rho": 1e-4,
              "K_theta": 3e-5}

# laser
N_BEAMS = 36
ANGLE_MIN = -math.pi
ANGLE_INC = 2.0 * math.pi / N_BEAMS
RANGE_MAX = 20.0
RANGE_SIGMA = 0.03
MOUNT = (0.1, 0.0, 0.0)   # x, y, yaw in the robot frame
INCIDENCE_COS_MIN = math.cos(math.radians(80.0))   # ooc_incidence_bias saturates at 80 deg
OBJECT_CLEARANCE = 0.5    # m, least distance of a --map-error object from the reference path
SHIFT_MAX = 1.0           # m, largest |d| of a --map-error shift

# Map: each polygon counter-clockwise; walls are consecutive vertex pairs.
ROOM = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]
BOX_A = [(7.0, 6.0), (8.2, 6.0), (8.2, 7.2), (7.0, 7.2)]
BOX_B = [(1.0, 8.0), (1.8, 8.0), (1.8, 8.8), (1.0, 8.8)]


def polygon_walls(poly):
    """Closed polygon -> list of segments (x1, y1, x2, y2)."""
    return [(*poly[i], *poly[(i + 1) % len(poly)]) for i in range(len(poly))]


WALLS = polygon_walls(ROOM) + polygon_walls(BOX_A) + polygon_walls(BOX_B)

# Controller
K1 = 0.25                 # 1/m^2, lateral error gain
K2 = 1.0                  # 1/m, heading error gain
U_MAX = 0.5               # 1/m, limit of the curvature correction
CONTROL_EVERY = 100       # cycles between corrections (1 Hz)
ACCEL = 0.6               # m/s^2, limit of the commanded speed change

# ---------------------------------------------------------------------------
# Effects: name -> (number of parameters or None for 1..len(WALLS), kind, summary)
# ---------------------------------------------------------------------------

EFFECTS = {
    "turn_slip": (1, "motion", "k (s^2/m): side += k v w rho"),
    "rotation_slip": (1, "motion", "k (s): dtheta *= 1 - k |w|"),
    "speed_scale": (1, "motion", "k (s/m): rho *= 1 + k |v|"),
    "wheel_eccentricity": (2, "motion", "a, b: rho *= 1 + a cos(phi) + b sin(phi)"),
    "backlash": (1, "motion", "b (m): the travel inside 0.05 m after a reversal is scaled by 1 - b/0.05"),
    "region_scale": (9, "motion", "c0..c8: rho *= 1 + c_j on a 3x3 grid"),
    "radius_drift": (1, "motion", "g (per 100 m): rho *= 1 + g s_abs / 100"),
    "turn_noise": (1, "motion", "q (rad^2/rad): dtheta += N(0, q |dtheta|)"),
    "range_bias": (1, "measurement", "b (m): r = r_true + b"),
    "range_scale": (1, "measurement", "s: r = r_true (1 + s)"),
    "laser_mount_xy": (2, "measurement", "dx, dy (m): laser mount offset"),
    "laser_mount_yaw": (1, "measurement", "dpsi (rad): laser mount yaw offset"),
    "scan_latency": (1, "measurement", "tau (s): scan stamped t taken at t - tau"),
    "wall_offset": (None, "measurement",
                    "o_1..o_W (m): wall w moved o_w along its left normal"),
    # per-wheel catalogue effects (diff drive only)
    "wheel_backlash": (2, "motion", "b_R, b_L (m): the travel inside 0.05 m after the "
                       "wheel's own reversal is scaled by 1 - b_X/0.05"),
    "wheel_speed_scale": (2, "motion", "k_R, k_L (s/m): X *= 1 + k_X |v_X| per wheel"),
    # out-of-catalogue forms (see the docstring: "Out-of-catalogue forms")
    "ooc_world_drift": (2, "motion", "cx, cy (1): pose += (cx, cy) |travel| in the WORLD "
                        "frame (tilted floor)"),
    "ooc_heading_scale": (2, "motion", "k (1), theta0 (rad): rho *= 1 + k cos(theta - "
                          "theta0) (carpet pile)"),
    "ooc_abrupt_scale": (2, "motion", "t_c (s), kR (1): R *= 1 + kR from t >= t_c on "
                         "(a tyre loses pressure)"),
    "ooc_one_wheel_drag": (1, "motion", "k (s^2/m^2): L *= 1 - k v_L^2 (left wheel drag)"),
    "ooc_turn_slip_cubic": (1, "motion", "k (s^6/m^3): side += k (v w)^3 rho (tyre "
                            "slip angle cubic in lateral acceleration)"),
    "ooc_incidence_bias": (1, "measurement", "c (m): r += c (1/cos(inc) - 1) (spot "
                           "smear on oblique walls)"),
    "ooc_beam_angle_scale": (1, "measurement", "s (1): the true beam angle is alpha (1 + s) "
                             "(mirror speed error)"),
    "ooc_range_time_drift": (1, "measurement", "c (m/s): r += c t (laser warming up)"),
    "ooc_accel_slip": (2, "motion", "k (s^2/m), a0 (m/s^2): rho *= 1 -+ k (|a| - a0) while "
                       "|a| > a0, lost speeding up, gained braking (wheels spin and skid)"),
    "ooc_reversal_drag": (2, "motion", "c (1), span (m): L *= 1 - c for the first span m "
                          "after each reversal (one wheel drags after the gear reverses)"),
}

# Effects that act on the two wheels separately: the differential drive only.
DIFF_ONLY = {"wheel_backlash", "wheel_speed_scale", "ooc_abrupt_scale", "ooc_one_wheel_drag",
             "ooc_reversal_drag"}

# Suggested test sizes of the effects added for per-wheel and residual-discovery tests:
# physically plausible and clearly visible on a 4-minute drive (see the docstring).
TEST_SIZES = {
    "wheel_backlash": [0.01, 0.006],
    "wheel_speed_scale": [0.05, 0.02],
    "ooc_world_drift": [0.012, -0.008],
    "ooc_heading_scale": [0.03, 0.5],
    "ooc_abrupt_scale": [120.0, -0.02],
    "ooc_one_wheel_drag": [0.1],
    "ooc_turn_slip_cubic": [0.2],
    "ooc_incidence_bias": [0.015],
    "ooc_beam_angle_scale": [0.002],
    "ooc_range_time_drift": [1e-4],
    "ooc_accel_slip": [0.2, 1.0],
    "ooc_reversal_drag": [0.09, 0.3],
}
# Effects that need a drive with hard speed ramps (--accel): a test drive uses this ramp.
TEST_ACCEL = {"ooc_accel_slip": 2.0}


def parse_effects(specs, parser):
    """['name=v1,v2', ...] -> {name: [floats]}; errors go through parser.error (exit 2)."""
    effects = {}
    for spec in specs:
        if "=" not in spec:
            parser.error(f"--effect {spec!r}: expected NAME=V1[,V2...]")
        name, _, vals = spec.partition("=")
        name = name.strip()
        if name not in EFFECTS:
            parser.error(f"--effect: unknown effect {name!r}; known: "
                         + ", ".join(EFFECTS))
        if name in effects:
            parser.error(f"--effect: {name} given twice")
        try:
            values = [float(v) for v in vals.split(",")]
        except ValueError:
            parser.error(f"--effect {spec!r}: values must be numbers separated by commas")
        if not all(math.isfinite(v) for v in values):
            parser.error(f"--effect {spec!r}: values must be finite")
        count = EFFECTS[name][0]
        if count is None:
            if not 1 <= len(values) <= len(WALLS):
                parser.error(f"--effect {name}: takes 1..{len(WALLS)} values "
                             f"(one per wall), got {len(values)}")
            values = values + [0.0] * (len(WALLS) - len(values))
        elif len(values) != count:
            parser.error(f"--effect {name}: takes {count} value(s), got {len(values)}")
        if name == "turn_noise" and values[0] < 0:
            parser.error("--effect turn_noise: q must be >= 0 (it is a variance rate)")
        effects[name] = values
    return effects


# ---------------------------------------------------------------------------
# Map errors: the map written differs from the world the laser sees
# ---------------------------------------------------------------------------

# kind -> (number of values, summary)
MAP_ERRORS = {
    "object": (4, "x, y, w, h (m): a box centred at (x, y), w x h, in the world, not in "
                  "the map (ranges shorter)"),
    "phantom": (4, "x1, y1, x2, y2 (m): a wall in the map, not in the world (ranges longer)"),
    "shift": (2, "i, d (index, m): map wall i written d along its left normal"),
    **world_events.KINDS,
}

# Suggested test placements (tests/diagnose/check_map.py): name -> (kind, values, note)
MAP_ERROR_CASES = {
    "cabinet": ("object", [5.0, 0.2, 0.6, 0.4],
                "0.6 x 0.4 cabinet against the bottom wall (y 0..0.4)"),
    "pillar": ("object", [4.3, 3.2, 0.3, 0.3],
               "0.3 x 0.3 pillar in the open, at the centre of the lower lobe"),
    "pallet": ("object", [7.5, 3.0, 1.0, 0.5],
               "1.0 x 0.5 pallet in the open, right of the lower lobe"),
    "phantom": ("phantom", [1.5, 3.0, 1.5, 4.5],
                "1.5 m partition drawn at x = 1.5 that is not there"),
    "shift_room": ("shift", [0, 0.10],
                   "bottom room wall (index 0) drawn 0.10 m into the room"),
    "shift_box": ("shift", [4, 0.10],
                  "bottom wall of the 1.2 m box (index 4) drawn 0.10 m into the box"),
}


def box_walls(x, y, w, h):
    """Segments of an axis-aligned box, counter-clockwise."""
    x0, x1, y0, y1 = x - w / 2.0, x + w / 2.0, y - h / 2.0, y + h / 2.0
    return polygon_walls([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def segment_distance(px, py, seg):
    """Distance of the points (px, py) (arrays) from the segment (x1, y1, x2, y2)."""
    x1, y1, x2, y2 = seg
    ex, ey = x2 - x1, y2 - y1
    ee = ex * ex + ey * ey
    u = np.clip(((px - x1) * ex + (py - y1) * ey) / ee, 0.0, 1.0) if ee > 0 else 0.0
    return np.hypot(px - x1 - u * ex, py - y1 - u * ey)


def box_distance(px, py, x, y, w, h):
    """Distance of the points (px, py) from the filled box (0 inside)."""
    dx = np.maximum(np.abs(px - x) - w / 2.0, 0.0)
    dy = np.maximum(np.abs(py - y) - h / 2.0, 0.0)
    return np.hypot(dx, dy)


def parse_map_errors(specs, parser, path=None):
    """['kind=v1,...', ...] -> {"object": [[x, y, w, h]..], "phantom": [[..]..],
    "shift": [[i, d]..]} (kinds absent when not given); errors go through parser.error
    (exit 2). With a Path, an object closer than OBJECT_CLEARANCE to it is refused."""
    out = {}
    rx = [p[0] for p in ROOM]
    ry = [p[1] for p in ROOM]
    room = (min(rx), max(rx), min(ry), max(ry))

    def inside(x, y):
        return room[0] <= x <= room[1] and room[2] <= y <= room[3]

    for spec in specs:
        if "=" not in spec:
            parser.error(f"--map-error {spec!r}: expected KIND=V1,... with KIND one of "
                         + ", ".join(MAP_ERRORS))
        kind, _, vals = spec.partition("=")
        kind = kind.strip()
        if kind not in MAP_ERRORS:
            parser.error(f"--map-error: unknown kind {kind!r}; known: " + ", ".join(MAP_ERRORS))
        try:
            values = [float(v) for v in vals.split(",")]
        except ValueError:
            parser.error(f"--map-error {spec!r}: values must be numbers separated by commas")
        if not all(math.isfinite(v) for v in values):
            parser.error(f"--map-error {spec!r}: values must be finite")
        count = MAP_ERRORS[kind][0]
        if len(values) != count:
            parser.error(f"--map-error {kind}: takes {count} values "
                         f"({MAP_ERRORS[kind][1].split(':')[0]}), got {len(values)}")
        if kind == "object":
            x, y, w, h = values
            if w <= 0.0 or h <= 0.0:
                parser.error(f"--map-error {spec!r}: the size w, h must be > 0")
            if not (inside(x - w / 2, y - h / 2) and inside(x + w / 2, y + h / 2)):
                parser.error(f"--map-error {spec!r}: the object must lie inside the room "
                             f"({room[0]:g}..{room[1]:g} x {room[2]:g}..{room[3]:g})")
            if path is not None:
                d = float(box_distance(path.x_grid, path.y_grid, x, y, w, h).min())
                if d < OBJECT_CLEARANCE:
                    parser.error(f"--map-error {spec!r}: the object is {d:.2f} m from the "
                                 f"robot's path (it needs >= {OBJECT_CLEARANCE} m, or the "
                                 "robot would drive through it); the path is a figure-eight "
                                 "of circles centred (4.3, 3.2) r 1.4 and (4.3, 7.2) r 1.0 "
                                 "joined by their crossing tangents")
        elif kind == "phantom":
            x1, y1, x2, y2 = values
            if math.hypot(x2 - x1, y2 - y1) <= 1e-6:
                parser.error(f"--map-error {spec!r}: the phantom wall has zero length")
            if not (inside(x1, y1) and inside(x2, y2)):
                parser.error(f"--map-error {spec!r}: the phantom wall must lie inside the room")
        elif kind in world_events.KINDS:
            values = world_events.check(kind, values, spec, parser.error, inside, path, segment_distance)
        else:
            i, d = values
            if i != int(i) or not 0 <= int(i) < len(WALLS):
                parser.error(f"--map-error {spec!r}: the wall index must be an integer in "
                             f"0..{len(WALLS) - 1} (the real walls' records)")
            if abs(d) > SHIFT_MAX:
                parser.error(f"--map-error {spec!r}: |d| must be <= {SHIFT_MAX:g} m")
            values = [int(i), d]
            if any(v[0] == values[0] for v in out.get("shift", [])):
                parser.error(f"--map-error shift: wall {values[0]} shifted twice")
        out.setdefault(kind, []).append(values)
    return out


def map_walls(map_errors):
    """The wall records written: the real walls (shifted as asked), then the phantoms."""
    walls = [list(map(float, w)) for w in WALLS]
    for i, d in (map_errors or {}).get("shift", []):
        x1, y1, x2, y2 = walls[i]
        length = math.hypot(x2 - x1, y2 - y1)
        nx, ny = -(y2 - y1) / length, (x2 - x1) / length
        walls[i] = [x1 + d * nx, y1 + d * ny, x2 + d * nx, y2 + d * ny]
    walls += [list(map(float, p)) for p in (map_errors or {}).get("phantom", [])]
    walls += world_events.map_walls(map_errors)
    return walls


def object_walls(map_errors):
    """Segments of the map errors' objects (in the world, not in the map), shape (K, 4)."""
    segs = [s for o in (map_errors or {}).get("object", []) for s in box_walls(*o)]
    return np.array(segs, dtype=float).reshape(-1, 4)


# ---------------------------------------------------------------------------
# Reference path: figure-eight from two circles and their internal tangents
# ---------------------------------------------------------------------------

class Path:
    """A closed path of constant-curvature pieces, parameterised by arc length s.

    Lower circle C1 (radius R1, driven clockwise), upper circle C2 (radius R2, counter-
    clockwise). The internal tangents cross at P, which divides C1C2 in the ratio R1:R2;
    with d = |C1C2| each tangent makes the angle alpha, sin(alpha) = (R1 + R2)/d, with
    the line C1C2, and each lobe is an arc of pi + 2 alpha.
    """

    def __init__(self, c1=(4.3, 3.2), r1=1.4, c2=(4.3, 7.2), r2=1.0):
        d = math.hypot(c2[0] - c1[0], c2[1] - c1[1])
        assert abs(c2[0] - c1[0]) < 1e-12, "the construction assumes C2 straight above C1"
        alpha = math.asin((r1 + r2) / d)
        d1 = d * r1 / (r1 + r2)
        d2 = d * r2 / (r1 + r2)
        l1 = math.sqrt(d1 * d1 - r1 * r1)     # P to the tangent point on C1
        l2 = math.sqrt(d2 * d2 - r2 * r2)     # P to the tangent point on C2
        lobe = math.pi + 2.0 * alpha
        # (length, curvature) pieces starting at P, heading pi/2 - alpha
        self.pieces = [(l2, 0.0), (r2 * lobe, 1.0 / r2), (l2 + l1, 0.0),
                       (r1 * lobe, -1.0 / r1), (l1, 0.0)]
        self.start = (c1[0], c1[1] + d1, math.pi / 2.0 - alpha)
        # start pose of each piece
        self.bounds = [0.0]
        self.piece_start = []
        x, y, th = self.start
        for length, kappa in self.pieces:
            self.piece_start.append((x, y, th))
            x, y, th = self._advance(x, y, th, kappa, length)
            self.bounds.append(self.bounds[-1] + length)
        self.length = self.bounds[-1]
        end_err = math.hypot(x - self.start[0], y - self.start[1])
        assert end_err < 1e-9 and abs(th - self.start[2]) < 1e-9, "path does not close"
        # dense samples (1 cm) for the projection
        n = int(math.ceil(self.length / 0.01))
        self.s_grid = np.linspace(0.0, self.length, n, endpoint=False)
        poses = np.array([self.pose(s) for s in self.s_grid])
        self.x_grid, self.y_grid = poses[:, 0], poses[:, 1]

    @staticmethod
    def _advance(x, y, th, kappa, u):
        """Pose after arc length u on a piece of curvature kappa."""
        if kappa == 0.0:
            return x + u * math.cos(th), y + u * math.sin(th), th
        th2 = th + kappa * u
        return (x + (math.sin(th2) - math.sin(th)) / kappa,
                y - (math.cos(th2) - math.cos(th)) / kappa, th2)

    def _piece(self, s):
        s = s % self.length
        i = min(bisect.bisect_right(self.bounds, s) - 1, len(self.pieces) - 1)
        return i, s - self.bounds[i]

    def curvature(self, s):
        return self.pieces[self._piece(s)[0]][1]

    def pose(self, s):
        i, u = self._piece(s)
        x, y, th = self.piece_start[i]
        return self._advance(x, y, th, self.pieces[i][1], u)

    def project(self, x, y, s_guess, window=1.5):
        """Arc length (unwrapped, near s_guess) of the path point nearest to (x, y)."""
        ds = (self.s_grid - s_guess + self.length / 2.0) % self.length - self.length / 2.0
        near = np.abs(ds) <= window
        d2 = (self.x_grid - x) ** 2 + (self.y_grid - y) ** 2
        d2 = np.where(near, d2, np.inf)
        k = int(np.argmin(d2))
        s = s_guess + ds[k]
        # refine along the local tangent
        px, py, pth = self.pose(s)
        s += (x - px) * math.cos(pth) + (y - py) * math.sin(pth)
        return s


# ---------------------------------------------------------------------------
# Speed schedule
# ---------------------------------------------------------------------------

def speed_schedule(rng, duration):
    """Seeded list of (t_end, target_speed) phases covering [0, duration]."""
    phases = []
    t = 0.0
    while t < duration:
        # forward stretch, sometimes in two parts at different speeds
        forward = rng.uniform(6.0, 12.0)
        parts = 2 if rng.random() < 0.4 else 1
        for _ in range(parts):
            t += forward / parts
            phases.append((t, rng.uniform(0.2, 0.8)))
        if rng.random() < 0.3:                 # a short stop before the reversal
            t += rng.uniform(0.3, 1.0)
            phases.append((t, 0.0))
        t += rng.uniform(1.5, 3.5)             # backward stretch
        phases.append((t, -rng.uniform(0.2, 0.5)))
    return phases


# ---------------------------------------------------------------------------
# Motion simulation
# ---------------------------------------------------------------------------

BACKLASH_SPAN = 0.05      # m of travel after a reversal over which backlash acts


class SpanLoss:
    """Backlash on one signed travel stream (a wheel's, for wheel_backlash).

    factor(travel) is called once per cycle with the stream's noise-free drive-model
    travel of that cycle and returns the factor of the cycle's travel: a reversal (sign
    opposite to the last non-zero sign) sets s_rev = 0 for this cycle; while
    s_rev < 0.05 m, only the part of the travel inside the span loses, a fraction b/0.05,
    so exactly b is lost per reversal whatever the cycle length. s_rev then grows by
    |travel| (infinite before the first reversal)."""

    def __init__(self, b):
        self.b = b
        self.s_rev = math.inf
        self.last_sign = 0

    def factor(self, travel):
        sign = (travel > 0.0) - (travel < 0.0)
        if sign != 0 and self.last_sign != 0 and sign != self.last_sign:
            self.s_rev = 0.0
        f = 1.0
        if self.b and self.s_rev < BACKLASH_SPAN:
            frac = (min(1.0, (BACKLASH_SPAN - self.s_rev) / abs(travel))
                    if travel != 0.0 else 1.0)
            f = 1.0 - self.b / BACKLASH_SPAN * frac
        self.s_rev += abs(travel)
        if sign != 0:
            self.last_sign = sign
        return f


def simulate_motion(drive, n_steps, effects, path, rng_sched, rng_noise, rng_turn,
                    noisy_rates=False, steer_feedback=True, record=None, accel=ACCEL):
    """Run the drive. Returns (enc counts (n+1, 2) int64, truth (n+1, 3) with theta
    unwrapped).

    steer_feedback=False drops the 1 Hz correction (open-loop steering, for the self-check:
    the encoder counts and the noise are then the same whatever the effects). A dict given
    as ``record`` receives per-cycle arrays (n,): "travel" (the drive model's noise-free
    rho before the effects), "wheel_R", "wheel_L" (its noise-free wheel travels, diff)."""
    schedule = speed_schedule(rng_sched, n_steps * DT + 1.0)
    sched_t = [p[0] for p in schedule]

    # noise draws, one stream per purpose (independent of the effects chosen)
    std_normals = rng_noise.standard_normal((n_steps, 2)).tolist()
    turn_normals = rng_turn.standard_normal(n_steps).tolist()

    # effect parameters (0 = nominal)
    turn_slip = effects.get("turn_slip", [0.0])[0]
    rot_slip = effects.get("rotation_slip", [0.0])[0]
    speed_k = effects.get("speed_scale", [0.0])[0]
    ecc_a, ecc_b = effects.get("wheel_eccentricity", [0.0, 0.0])
    backlash = effects.get("backlash", [0.0])[0]
    region = effects.get("region_scale", None)
    drift_g = effects.get("radius_drift", [0.0])[0]
    turn_q = effects.get("turn_noise", [0.0])[0]
    wb_R, wb_L = (SpanLoss(b) for b in effects.get("wheel_backlash", [0.0, 0.0]))
    wss_R, wss_L = effects.get("wheel_speed_scale", [0.0, 0.0])
    drift_cx, drift_cy = effects.get("ooc_world_drift", [0.0, 0.0])
    hs_k, hs_th0 = effects.get("ooc_heading_scale", [0.0, 0.0])
    ab_tc, ab_kR = effects.get("ooc_abrupt_scale", [math.inf, 0.0])
    drag_k = effects.get("ooc_one_wheel_drag", [0.0])[0]
    cubic_k = effects.get("ooc_turn_slip_cubic", [0.0])[0]
    acc_k, acc_a0 = effects.get("ooc_accel_slip", [0.0, 0.0])
    rdrag_c, rdrag_span = effects.get("ooc_reversal_drag", [0.0, 0.0])
    wheel_effects = ("wheel_backlash" in effects or wss_R or wss_L or ab_kR or drag_k
                     or rdrag_c)
    if drive != "diff" and wheel_effects:
        raise ValueError("per-wheel effects need the diff drive")
    rec_travel = np.zeros(n_steps)
    rec_R = np.zeros(n_steps)
    rec_L = np.zeros(n_steps)
    r_wheel = WHEEL_RADIUS  # param wheel_radius_m for diff; 0.05 for sync (no param)

    # map bounding box for region_scale (of the map as written)
    wx = [w[0] for w in WALLS] + [w[2] for w in WALLS]
    wy = [w[1] for w in WALLS] + [w[3] for w in WALLS]
    bx0, bx1, by0, by1 = min(wx), max(wx), min(wy), max(wy)

    if drive == "diff":
        m_per_tick = 2.0 * math.pi * WHEEL_RADIUS / TICKS_PER_REV
        tp = DIFF_TRUTH
    else:
        tp = SYNC_TRUTH

    enc = np.zeros((n_steps + 1, 2), dtype=np.int64)
    truth = np.zeros((n_steps + 1, 3))
    x, y, th = path.start
    truth[0] = (x, y, th)

    cum_a = cum_b = 0.0          # continuous cumulative counts
    cnt_a = cnt_b = 0            # quantised cumulative counts
    v_cmd = 0.0                  # commanded speed (ramped)
    s_path = 0.0                 # commanded progress along the path (unwrapped)
    e_y = e_th = 0.0             # errors sampled at the last correction
    s_abs = s_signed = s_enc = 0.0
    s_rev = math.inf
    last_sign = 0
    phase = 0

    for k in range(n_steps):
        t = k * DT
        # --- low-rate correction from the TRUE pose -------------------------------
        if k % CONTROL_EVERY == 0 and steer_feedback:
            s_path = path.project(x, y, s_path)
            px, py, pth = path.pose(s_path)
            e_y = -(x - px) * math.sin(pth) + (y - py) * math.cos(pth)
            e_th = (th - pth + math.pi) % (2.0 * math.pi) - math.pi
        # --- commanded speed, ramped towards the phase's target -------------------
        while phase < len(schedule) - 1 and t >= sched_t[phase]:
            phase += 1
        target = schedule[phase][1]
        v_prev = v_cmd
        v_cmd += max(-accel * DT, min(accel * DT, target - v_cmd))
        a_cmd = (v_cmd - v_prev) / DT       # the motors' acceleration this cycle
        rho_cmd = v_cmd * DT
        sgn = 1.0 if v_cmd >= 0.0 else -1.0
        u = max(-U_MAX, min(U_MAX, -K1 * e_y - sgn * K2 * e_th))
        kappa = path.curvature(s_path + 0.5 * rho_cmd) + u
        dth_cmd = kappa * rho_cmd
        s_path += rho_cmd

        # --- encoders (nominal model turns the command into counts) ---------------
        if drive == "diff":
            cum_a += (rho_cmd + 0.5 * WHEELBASE * dth_cmd) / m_per_tick   # right
            cum_b += (rho_cmd - 0.5 * WHEELBASE * dth_cmd) / m_per_tick   # left
        else:
            cum_a += rho_cmd * TICKS_PER_M
            cum_b += dth_cmd * TICKS_PER_RAD
        new_a, new_b = math.floor(cum_a), math.floor(cum_b)
        da, db = new_a - cnt_a, new_b - cnt_b
        cnt_a, cnt_b = new_a, new_b
        enc[k + 1] = (cnt_a, cnt_b)

        # --- truth increment from the drive model (paper eq. 1-4) -----------------
        # (rho_m, dth_m) is the drive model's noise-free increment (mean), (rho, dth)
        # the truth's increment with the sampled non-systematic noise.
        n1, n2 = std_normals[k]
        if drive == "diff":
            er, el = da * m_per_tick, db * m_per_tick
            mr, ml = tp["delta_R"] * er, tp["delta_L"] * el
            wr = mr + math.sqrt(tp["K_w"] * abs(er)) * n1
            wl = ml + math.sqrt(tp["K_w"] * abs(el)) * n2
            base = WHEELBASE * tp["delta_d"]
            # the path statistics use the drive model's increment before any effect
            rho_d = 0.5 * (mr + ml)
            rec_R[k], rec_L[k] = mr, ml
            if wheel_effects:
                # Per-wheel effects, on the drive model's noise-free wheel travels
                # R = rho + dtheta d/2, L = rho - dtheta d/2 (d = wheelbase * delta_d, so
                # these are mr, ml exactly); each factor is applied to the noisy travel too.
                # (--noisy-rates: evaluated on the noisy travels instead)
                xR, xL = (wr, wl) if noisy_rates else (mr, ml)
                gR = wb_R.factor(xR)
                gL = wb_L.factor(xL)
                if wss_R or wss_L:
                    gR *= 1.0 + wss_R * abs(xR / DT)
                    gL *= 1.0 + wss_L * abs(xL / DT)
                if ab_kR and t >= ab_tc:
                    gR *= 1.0 + ab_kR
                if drag_k:
                    gL *= 1.0 - drag_k * (xL / DT) ** 2
                if rdrag_c:
                    # the robot's travel since its last reversal, this cycle a reversal
                    # too (the statistics below are updated after the wheel effects)
                    sg = (rho_d > 0.0) - (rho_d < 0.0)
                    since = 0.0 if sg != 0 and last_sign != 0 and sg != last_sign else s_rev
                    if since < rdrag_span:
                        gL *= 1.0 - rdrag_c
                mr, wr = mr * gR, wr * gR
                ml, wl = ml * gL, wl * gL
            rho_m, dth_m = 0.5 * (mr + ml), (mr - ml) / base
            enc_travel = 0.5 * (er + el)
            rho, dth = 0.5 * (wr + wl), (wr - wl) / base
        else:
            erho, eth = da / TICKS_PER_M, db / TICKS_PER_RAD
            rho_m = tp["delta_rho"] * erho
            rho_d = rho_m
            enc_travel = erho
            dth_m = eth + tp["E_theta"] * erho
            rho = rho_m + math.sqrt(tp["K_rho"] * abs(erho)) * n1
            dth = dth_m + math.sqrt(tp["K_theta"] * abs(erho)) * n2
        side = side_m = 0.0
        if noisy_rates:                      # literal reading: rates from the noisy draw
            rho_m, dth_m = rho, dth
            rho_d = rho

        # path statistics: values at the start of the cycle; a reversal resets s_rev
        travel = rho_d
        rec_travel[k] = travel
        sign = (travel > 0.0) - (travel < 0.0)
        if sign != 0 and last_sign != 0 and sign != last_sign:
            s_rev = 0.0

        # --- motion effects, in the catalogue's order ------------------------------
        # Each effect's factor or term is evaluated on the running noise-free increment
        # (rho_m, dth_m, side_m) and applied to it and to the truth's increment alike.
        if turn_slip:
            add = turn_slip * (rho_m / DT) * (dth_m / DT) * rho_m
            side += add
            side_m += add
        if rot_slip:
            f = 1.0 - rot_slip * abs(dth_m / DT)
            dth *= f
            dth_m *= f
        f = 1.0                              # product of the translation factors
        if speed_k:
            f *= 1.0 + speed_k * abs(rho_m / DT)
        if ecc_a or ecc_b:
            phi = s_enc / r_wheel
            f *= 1.0 + ecc_a * math.cos(phi) + ecc_b * math.sin(phi)
        if backlash and s_rev < 0.05:
            # only the part of this step's travel inside the 5 cm span loses: exactly b
            # per reversal, whatever the step length
            frac = min(1.0, (0.05 - s_rev) / abs(travel)) if travel != 0.0 else 1.0
            f *= 1.0 - backlash / 0.05 * frac
        if region is not None:
            col = min(2, max(0, int(math.floor(3.0 * (x - bx0) / (bx1 - bx0)))))
            row = min(2, max(0, int(math.floor(3.0 * (y - by0) / (by1 - by0)))))
            f *= 1.0 + region[3 * row + col]
        if drift_g:
            f *= 1.0 + drift_g * s_abs / 100.0
        rho *= f
        rho_m *= f
        if turn_q:
            dth += math.sqrt(turn_q * abs(dth_m)) * turn_normals[k]

        # --- out-of-catalogue robot-level forms ---------------------------------------
        if hs_k:
            f = 1.0 + hs_k * math.cos(th - hs_th0)
            rho *= f
            rho_m *= f
        if acc_k and abs(a_cmd) > acc_a0:
            # speeding up (a v > 0) the wheels spin: the robot travels less than they
            # turn; braking they skid: it travels further
            spin = 1.0 if a_cmd * (v_cmd + v_prev) > 0.0 else -1.0
            f = 1.0 - spin * acc_k * (abs(a_cmd) - acc_a0)
            rho *= f
            rho_m *= f
        if cubic_k:
            a_lat = (rho_m / DT) * (dth_m / DT)
            add = cubic_k * a_lat ** 3 * rho_m
            side += add
            side_m += add

        # update the statistics with this cycle's drive-model travel
        s_abs += abs(travel)
        s_signed += travel
        s_enc += enc_travel
        s_rev += abs(travel)
        if sign != 0:
            last_sign = sign

        # --- mid-point pose rule ----------------------------------------------------
        mid = th + 0.5 * dth
        c, s = math.cos(mid), math.sin(mid)
        x += rho * c - side * s
        y += rho * s + side * c
        th += dth
        if drift_cx or drift_cy:             # pushed in the world frame (tilted floor)
            x += drift_cx * abs(travel)
            y += drift_cy * abs(travel)
        truth[k + 1] = (x, y, th)

    if record is not None:
        record.update(travel=rec_travel, wheel_R=rec_R, wheel_L=rec_L)
    return enc, truth


# ---------------------------------------------------------------------------
# Laser
# ---------------------------------------------------------------------------

def true_walls(effects):
    """Wall segments as they really are (wall_offset applied), shape (W, 4)."""
    w = np.array(WALLS, dtype=float)
    off = effects.get("wall_offset")
    if off is not None:
        dx, dy = w[:, 2] - w[:, 0], w[:, 3] - w[:, 1]
        length = np.hypot(dx, dy)
        nx, ny = -dy / length, dx / length
        o = np.asarray(off)
        w = w + np.stack([o * nx, o * ny, o * nx, o * ny], axis=1)
    return w


def cast_rays(ox, oy, ang, walls, incidence=False):
    """Vectorised ray casting. ox, oy: (S,), ang: (S, B) world beam angles,
    walls: (W, 4). Returns (S, B) ranges, inf where no wall is hit; with incidence=True
    also (S, B) |cos| of the angle between the beam and the hit wall's normal (nan where
    no wall is hit)."""
    dx, dy = np.cos(ang)[..., None], np.sin(ang)[..., None]          # (S, B, 1)
    ax, ay = walls[:, 0], walls[:, 1]                                  # (W,)
    ex, ey = walls[:, 2] - ax, walls[:, 3] - ay
    qx = ax - ox[:, None, None]                                        # (S, 1, W)
    qy = ay - oy[:, None, None]
    den = dx * ey - dy * ex                                            # (S, B, W)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = (qx * ey - qy * ex) / den
        u = (qx * dy - qy * dx) / den
    hit = (np.abs(den) > 1e-12) & (r > 1e-9) & (u >= 0.0) & (u <= 1.0)
    r = np.where(hit, r, np.inf)
    if not incidence:
        return r.min(axis=2)
    iw = r.argmin(axis=2)                                              # (S, B)
    rng = np.take_along_axis(r, iw[..., None], axis=2)[..., 0]
    length = np.hypot(ex, ey)
    # |beam . unit normal| = |dx ey - dy ex| / length = |den| / length of the hit wall
    cos_inc = np.abs(np.take_along_axis(den, iw[..., None], axis=2)[..., 0]) / length[iw]
    return rng, np.where(np.isfinite(rng), cos_inc, np.nan)


def simulate_scans(truth, n_steps, effects, rng_scan, map_errors=None, seen=None):
    """Scan times (S,) and ranges (S, B) with nan for no return. map_errors: the
    objects of parse_map_errors stand in the world (phantoms and shifts change only the
    map written). A list given as ``seen`` receives, per map error, (kind, values,
    beams, scans): how many beams (in how many scans) meet it: an object that is the
    first thing a beam hits, a phantom or shifted wall that is the map's first wall on
    the beam (its predicted hit)."""
    k_scan = np.arange(SCAN_EVERY, n_steps + 1, SCAN_EVERY)
    t_scan = k_scan * DT
    t_truth = np.arange(n_steps + 1) * DT
    tau = effects.get("scan_latency", [0.0])[0]
    t_take = np.clip(t_scan - tau, 0.0, t_truth[-1])
    x = np.interp(t_take, t_truth, truth[:, 0])
    y = np.interp(t_take, t_truth, truth[:, 1])
    th = np.interp(t_take, t_truth, truth[:, 2])         # theta is unwrapped

    dmx, dmy = effects.get("laser_mount_xy", [0.0, 0.0])
    dpsi = effects.get("laser_mount_yaw", [0.0])[0]
    mx, my, myaw = MOUNT[0] + dmx, MOUNT[1] + dmy, MOUNT[2] + dpsi
    c, s = np.cos(th), np.sin(th)
    ox = x + c * mx - s * my
    oy = y + s * mx + c * my
    alpha = ANGLE_MIN + ANGLE_INC * np.arange(N_BEAMS)      # beam angles, laser frame
    alpha = alpha * (1.0 + effects.get("ooc_beam_angle_scale", [0.0])[0])
    beams = myaw + alpha
    ang = th[:, None] + beams[None, :]

    world = np.concatenate([true_walls(effects), object_walls(map_errors)])
    r_true, cos_inc = cast_rays(ox, oy, ang, world, incidence=True)
    r_true, changed = world_events.apply(r_true, t_scan, ox, oy, ang, map_errors, cast_rays, box_walls)
    if seen is not None and map_errors:
        seen.extend(map_error_visibility(ox, oy, ang, r_true, map_errors))
        ok = np.isfinite(r_true) & (r_true <= RANGE_MAX)
        for (kind, i), m in changed.items():
            seen.append((kind, map_errors[kind][i], int((m & ok).sum()), int((m & ok).any(axis=1).sum())))
    r = r_true
    c_inc = effects.get("ooc_incidence_bias", [0.0])[0]
    if c_inc:
        # held at its 80 degree value beyond 80 degrees of incidence (1/cos would reach
        # metres at grazing beams; those beams hit near corners and are gated anyway)
        cos_c = np.maximum(cos_inc, INCIDENCE_COS_MIN)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = r + c_inc * (1.0 / cos_c - 1.0)
    c_t = effects.get("ooc_range_time_drift", [0.0])[0]
    if c_t:
        r = r + c_t * t_scan[:, None]
    r = r + effects.get("range_bias", [0.0])[0]
    r = r * (1.0 + effects.get("range_scale", [0.0])[0])
    r = r + RANGE_SIGMA * rng_scan.standard_normal(r.shape)
    r[~np.isfinite(r_true) | (r_true > RANGE_MAX) | (r <= 0.0) | (r > RANGE_MAX)] = np.nan
    return k_scan, r


def map_error_visibility(ox, oy, ang, r_true, map_errors):
    """[(kind, values, beams, scans)] of each map error (see simulate_scans)."""
    out = []
    ok = np.isfinite(r_true) & (r_true <= RANGE_MAX)

    def count(mask):
        mask = mask & ok
        return int(mask.sum()), int(mask.any(axis=1).sum())

    for o in map_errors.get("object", []):
        r_o = cast_rays(ox, oy, ang, np.array(box_walls(*o), dtype=float))
        out.append(("object", o, *count(np.isfinite(r_o) & (r_o <= r_true + 1e-9))))
    walls = np.array(map_walls(map_errors), dtype=float)
    r_map = cast_rays(ox, oy, ang, walls)
    n_real = len(WALLS)
    for j, p in enumerate(map_errors.get("phantom", [])):
        r_wo = cast_rays(ox, oy, ang, np.delete(walls, n_real + j, axis=0))
        out.append(("phantom", p, *count(r_map < r_wo - 1e-9)))
    for i, d in map_errors.get("shift", []):
        r_wo = cast_rays(ox, oy, ang, np.delete(walls, i, axis=0))
        out.append(("shift", [i, d], *count(r_map < r_wo - 1e-9)))
    return out


def min_clearance(truth, map_errors=None):
    """Smallest distance of the true path to any (nominal) wall or object, m."""
    p = truth[:, :2]
    w = np.concatenate([np.array(WALLS, dtype=float), object_walls(map_errors)])
    a, e = w[:, :2], w[:, 2:] - w[:, :2]
    rel = p[:, None, :] - a[None, :, :]
    u = np.clip((rel * e).sum(-1) / (e * e).sum(-1), 0.0, 1.0)
    d = rel - u[..., None] * e[None]
    return float(np.sqrt((d * d).sum(-1)).min())


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
