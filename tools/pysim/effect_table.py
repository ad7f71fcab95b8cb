"""The injectable effects of odosim.py: names, parameter counts, test sizes, parsing."""

from __future__ import annotations

from world import WALLS, parse_values

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
        values = parse_values("--effect", spec, vals, parser)
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
