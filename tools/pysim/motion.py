"""odosim.py's motion: the reference path, the speed schedule and the simulated wheels and
truth (encoder counts and true poses, with the effects applied)."""

from __future__ import annotations

import bisect
import math

import numpy as np

from world import (ACCEL, CONTROL_EVERY, DIFF_TRUTH, DT, K1, K2, SYNC_TRUTH, TICKS_PER_M,
                   TICKS_PER_RAD, TICKS_PER_REV, U_MAX, WALLS, WHEELBASE, WHEEL_RADIUS)

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
