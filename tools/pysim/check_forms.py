"""Self-check of the per-wheel and out-of-catalogue forms, in-process (check_odosim.py runs
it), on open-loop drives without the 1 Hz steering correction, so the encoder counts are the
same with and without the effect; motion checks on noise-free drives, where the truth gives
each cycle's wheel travels exactly. Each form's formula is recovered from the truth by code
written here, e.g. wheel_backlash loses exactly b per own-wheel reversal (end to end and on a
scripted sequence where one wheel reverses alone), ooc_world_drift displaces the truth by
(cx, cy) |travel| in the world frame, ooc_abrupt_scale starts at t_c, the incidence bias is
zero at normal incidence and c (1/cos 40 deg - 1) at 40 degrees; a measurement form leaves
the encoders, truth and range noise of the same seed unchanged."""

import math

import numpy as np

import laser as sim_laser
import motion as sim_motion
import world as sim_world
from check_base import check, ray_ranges


class ZeroRng:
    """Stands in for the noise generator: every draw is 0 (a noise-free drive)."""

    @staticmethod
    def standard_normal(shape):
        return np.zeros(shape)


def open_loop(effects, seed=7, minutes=1.0, noise=False, drive="diff"):
    """(enc, truth, record) of an open-loop drive (no steering correction)."""
    n = int(round(minutes * 60.0 / sim_world.DT))
    rngs = [np.random.default_rng([seed, i]) for i in range(4)]
    rec = {}
    enc, truth = sim_motion.simulate_motion(drive, n, effects, sim_motion.Path(), rngs[0],
                                            rngs[1] if noise else ZeroRng(), rngs[2],
                                            steer_feedback=False, record=rec)
    return enc, truth, rec


def increments(truth):
    """Per cycle (rho, dtheta, side) from the truth: the mid-point rule inverted."""
    d = np.diff(truth, axis=0)
    mid = truth[:-1, 2] + 0.5 * d[:, 2]
    c, s = np.cos(mid), np.sin(mid)
    return c * d[:, 0] + s * d[:, 1], d[:, 2], -s * d[:, 0] + c * d[:, 1]


def wheels(truth):
    """Per cycle true wheel travels (R, L) of a diff drive (side must be 0)."""
    rho, dth, _ = increments(truth)
    half = 0.5 * sim_world.WHEELBASE * sim_world.DIFF_TRUTH["delta_d"]
    return rho + dth * half, rho - dth * half


def own_reversals(x):
    """Indices of the cycles where the sign of x flips against its last non-zero sign."""
    out, last = [], 0
    for i, v in enumerate(x):
        sg = int(v > 0) - int(v < 0)
        if sg and last and sg != last:
            out.append(i)
        if sg:
            last = sg
    return out


def span_losses(x_clean, x_eff, revs):
    """Travel lost from each reversal to the next (or to the end)."""
    bounds = list(revs) + [len(x_clean)]
    d = x_eff - x_clean
    # the lost travel has the sign of the travel: count it as a positive loss
    return [float(-(np.sign(x_clean[a:b]) * d[a:b]).sum()) for a, b in zip(bounds, bounds[1:])]


def check_wheel_forms():
    b_R, b_L = 0.01, 0.006
    # scripted: the right wheel reverses alone (3 mm, 7 mm and 3 cm steps, one straddling
    # the end of the span); the left wheel keeps its direction and loses nothing
    right = [0.003] * 20 + [-0.007] * 12 + [0.03] * 4 + [-0.003] * 30
    left = [0.004] * len(right)
    losses_R, losses_L = [], []
    for b, seq, out in ((b_R, right, losses_R), (b_L, left, losses_L)):
        sl = sim_motion.SpanLoss(b)
        lost = [x - x * sl.factor(x) for x in seq]
        revs = own_reversals(seq)
        out.extend(span_losses(np.array(seq), np.array(seq) - np.array(lost), revs))
    check(len(losses_R) == 3 and max(abs(v - b_R) for v in losses_R) < 1e-12
          and losses_L == [],
          f"wheel_backlash scripted: right wheel loses {[round(v, 6) for v in losses_R]} "
          f"at its 3 own reversals (b_R {b_R}), the left wheel, not reversing, "
          f"{len(losses_L)} losses")

    enc0, tr0, rec0 = open_loop({})
    R0, L0 = wheels(tr0)
    check(np.allclose(R0, rec0["wheel_R"], atol=1e-12) and np.allclose(L0, rec0["wheel_L"], atol=1e-12),
          "noise-free open-loop drive: wheel travels recovered from the truth")
    enc, tr, _ = open_loop({"wheel_backlash": [b_R, b_L]})
    R, L = wheels(tr)
    same_enc = np.array_equal(enc, enc0)
    # reversals and signs from the drive model's own travel (exact zeros when standing)
    WR, WL = rec0["wheel_R"], rec0["wheel_L"]
    lR = span_losses(WR, WR + (R - R0), own_reversals(WR))
    lL = span_losses(WL, WL + (L - L0), own_reversals(WL))
    ok = (same_enc and len(lR) >= 2 and len(lL) >= 2
          and max(abs(v - b_R) for v in lR) < 1e-9 and max(abs(v - b_L) for v in lL) < 1e-9)
    first = own_reversals(WR)[0]
    untouched = np.allclose(R[:first], R0[:first], atol=1e-15)
    check(ok and untouched,
          f"wheel_backlash {b_R},{b_L} end to end: {len(lR)} right / {len(lL)} left own "
          f"reversals, loss per reversal R {min(lR):.6f}..{max(lR):.6f}, L "
          f"{min(lL):.6f}..{max(lL):.6f} m, nothing lost before the first")

    kR, kL = 0.05, 0.02
    enc, tr, _ = open_loop({"wheel_speed_scale": [kR, kL]})
    R, L = wheels(tr)
    m = np.abs(R0) > 1e-6
    eR = np.abs(R[m] / R0[m] - (1 + kR * np.abs(R0[m]) / sim_world.DT)).max()
    m = np.abs(L0) > 1e-6
    eL = np.abs(L[m] / L0[m] - (1 + kL * np.abs(L0[m]) / sim_world.DT)).max()
    check(np.array_equal(enc, enc0) and eR < 1e-9 and eL < 1e-9,
          f"wheel_speed_scale {kR},{kL}: each wheel's travel scaled by 1 + k_X |v_X| "
          f"(max error {max(eR, eL):.1e})")

    t_c, k_ab = 20.0, -0.02
    enc, tr, _ = open_loop({"ooc_abrupt_scale": [t_c, k_ab]})
    R, L = wheels(tr)
    kc = int(round(t_c / sim_world.DT))
    m = np.abs(R0) > 1e-6
    ratio = np.where(m, R / np.where(m, R0, 1.0), np.nan)
    before_ok = np.array_equal(tr[:kc + 1], tr0[:kc + 1])
    after_ok = np.nanmax(np.abs(ratio[kc:] - (1 + k_ab))) < 1e-9
    first_changed = int(np.argmax(np.any(tr != tr0, axis=1))) - 1    # cycle index
    check(before_ok and after_ok and np.allclose(L, L0, atol=1e-12) and first_changed == kc,
          f"ooc_abrupt_scale {t_c},{k_ab}: truth identical up to t_c, the right wheel "
          f"scaled by 1 + kR from the cycle at t = {first_changed * sim_world.DT:.2f} s on, "
          f"the left untouched")

    k_dr = 0.1
    enc, tr, _ = open_loop({"ooc_one_wheel_drag": [k_dr]})
    R, L = wheels(tr)
    m = np.abs(L0) > 1e-6
    eL = np.abs(L[m] / L0[m] - (1 - k_dr * (L0[m] / sim_world.DT) ** 2)).max()
    check(np.array_equal(enc, enc0) and eL < 1e-9 and np.allclose(R, R0, atol=1e-12),
          f"ooc_one_wheel_drag {k_dr}: L scaled by 1 - k v_L^2 (max error {eL:.1e}), "
          f"R untouched")


def check_robot_forms():
    enc0, tr0, rec0 = open_loop({})
    rho0, dth0, side0 = increments(tr0)
    travel = rec0["travel"]

    cx, cy = 0.012, -0.008
    enc, tr, _ = open_loop({"ooc_world_drift": [cx, cy]})
    s_abs = np.concatenate([[0.0], np.cumsum(np.abs(travel))])
    ex = np.abs((tr[:, 0] - tr0[:, 0]) - cx * s_abs).max()
    ey = np.abs((tr[:, 1] - tr0[:, 1]) - cy * s_abs).max()
    check(np.array_equal(enc, enc0) and np.array_equal(tr[:, 2], tr0[:, 2])
          and ex < 1e-9 and ey < 1e-9,
          f"ooc_world_drift {cx},{cy}: truth displaced by (cx, cy) |travel| in the world "
          f"frame ({tr[-1, 0] - tr0[-1, 0]:+.4f}, {tr[-1, 1] - tr0[-1, 1]:+.4f} m after "
          f"{s_abs[-1]:.1f} m; error {max(ex, ey):.1e}), heading unchanged")

    k, th0 = 0.03, 0.5
    enc, tr, _ = open_loop({"ooc_heading_scale": [k, th0]})
    rho, dth, side = increments(tr)
    m = np.abs(rho0) > 1e-6
    want = 1 + k * np.cos(tr0[:-1, 2] - th0)
    err = np.abs(rho[m] / rho0[m] - want[m]).max()
    check(np.array_equal(tr[:, 2], tr0[:, 2]) and err < 1e-9,
          f"ooc_heading_scale {k},{th0}: rho scaled by 1 + k cos(theta - theta0) "
          f"(factor {want.min():.3f}..{want.max():.3f}, error {err:.1e})")

    kc = 0.2
    enc, tr, _ = open_loop({"ooc_turn_slip_cubic": [kc]})
    rho, dth, side = increments(tr)
    a = (rho0 / sim_world.DT) * (dth0 / sim_world.DT)
    want = kc * a ** 3 * rho0
    err = np.abs(side - want).max()
    check(np.array_equal(tr[:, 2], tr0[:, 2]) and np.abs(side0).max() < 1e-12 and err < 1e-12
          and np.abs(want).max() > 1e-5,
          f"ooc_turn_slip_cubic {kc}: side = k (v w)^3 rho per cycle (largest "
          f"{1e3 * np.abs(want).max():.3f} mm, error {err:.1e})")

    # with the drive's noise: an effect changes neither the encoders nor the noise draws
    encn, trn, _ = open_loop({}, noise=True)
    encw, trw, _ = open_loop({"ooc_world_drift": [cx, cy]}, noise=True)
    check(np.array_equal(encn, encw) and np.array_equal(trn[:, 2], trw[:, 2]),
          "same seed, same noise: open-loop noisy drives with and without world drift "
          "have the same encoders and heading")


def check_beam_forms():
    # one scan from a fixed pose facing the wall x = 10 at normal incidence
    x, y, th = 3.0, 4.0, 0.0      # beam 0 deg hits x = 10 square on, beam 40 deg at 40 deg
    truth = np.tile([x, y, th], (sim_world.SCAN_EVERY + 1, 1))
    ref_k, ref = sim_laser.simulate_scans(truth, sim_world.SCAN_EVERY, {}, np.random.default_rng(1))
    alpha = sim_world.ANGLE_MIN + sim_world.ANGLE_INC * np.arange(sim_world.N_BEAMS)
    laser = [sim_world.N_BEAMS, sim_world.ANGLE_MIN, sim_world.ANGLE_INC, sim_world.RANGE_MAX,
             sim_world.RANGE_SIGMA, *sim_world.MOUNT]
    c = 0.015
    _, r = sim_laser.simulate_scans(truth, sim_world.SCAN_EVERY, {"ooc_incidence_bias": [c]},
                                    np.random.default_rng(1))
    d = (r - ref)[0]
    i0 = int(np.argmin(np.abs(alpha)))                    # straight ahead: normal
    i40 = int(np.argmin(np.abs(alpha - math.radians(40))))  # hits x = 10 at 40 deg
    ox = x + sim_world.MOUNT[0]
    # incidence of each beam computed here: the wall hit by the ray cast of this file
    walls = np.array(sim_world.WALLS)
    want = np.zeros(sim_world.N_BEAMS)
    for i in range(sim_world.N_BEAMS):
        best, cosv = math.inf, None
        ca, sa = math.cos(alpha[i]), math.sin(alpha[i])
        for x1, y1, x2, y2 in walls:
            ex, ey = x2 - x1, y2 - y1
            det = -ca * ey + sa * ex
            if abs(det) < 1e-12:
                continue
            rr = (-(x1 - ox) * ey + (y1 - y) * ex) / det
            u = (ca * (y1 - y) - sa * (x1 - ox)) / det
            if rr > 0 and 0 <= u <= 1 and rr < best:
                best = rr
                cosv = abs(ca * ey - sa * ex) / math.hypot(ex, ey)
        want[i] = c * (1.0 / max(cosv, math.cos(math.radians(80))) - 1.0)
    err = np.nanmax(np.abs(d - want))
    w40 = c * (1.0 / math.cos(math.radians(40)) - 1.0)
    check(abs(d[i0]) < 1e-12 and abs(d[i40] - w40) < 1e-9 and err < 1e-9,
          f"ooc_incidence_bias {c}: zero at normal incidence ({d[i0]:.1e}), "
          f"c (1/cos 40 - 1) = {1e3 * d[i40]:.3f} mm at 40 deg, c (1/cos - 1) on every beam "
          f"(error {err:.1e})")

    s = 0.002
    _, r = sim_laser.simulate_scans(truth, sim_world.SCAN_EVERY, {"ooc_beam_angle_scale": [s]},
                                    np.random.default_rng(1))
    noise = ref[0] - ray_ranges(x, y, th, laser, walls)          # the same draws
    lz = list(laser)
    want = np.array([ray_ranges(x, y, th, lz[:1] + [a * (1 + s)] + [0.0] + lz[3:], walls)[0]
                     for a in alpha]) + noise
    err = np.nanmax(np.abs(r[0] - want))
    check(abs(r[0][i0] - ref[0][i0]) < 1e-12 and err < 1e-9,
          f"ooc_beam_angle_scale {s}: beam alpha cast at alpha (1 + s): straight ahead "
          f"unchanged, every beam matches a ray cast at the scaled angle (error {err:.1e})")

    enc0, tr0, _ = open_loop({}, noise=True)
    n = len(tr0) - 1
    k0, r0 = sim_laser.simulate_scans(tr0, n, {}, np.random.default_rng(3))
    ct = 1e-4
    k1, r1 = sim_laser.simulate_scans(tr0, n, {"ooc_range_time_drift": [ct]},
                                      np.random.default_rng(3))
    d = r1 - r0
    err = np.nanmax(np.abs(d - ct * (k0 * sim_world.DT)[:, None]))
    check(err < 1e-9 and abs(np.nanmax(d) - ct * k0[-1] * sim_world.DT) < 1e-9,
          f"ooc_range_time_drift {ct}: ranges + c t (scan at {k0[-1] * sim_world.DT:.0f} s: "
          f"+{1e3 * np.nanmax(d):.2f} mm; error {err:.1e})")
