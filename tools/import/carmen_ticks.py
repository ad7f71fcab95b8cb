"""carmen_ticks.py: a CARMEN log's raw odometry written as the encoder ticks of the
equivalent differential drive (carmen_to_odolog.py's docstring, "Mapping", states the
rule): each sub-step read with the mid-point model, its sideways part dropped while the
ticks stay within TRACK_POS_M / TRACK_HEADING_RAD of the logged odometry, otherwise an arc
to the logged end point and a turn in place."""

import math

WHEEL_RADIUS_M = 0.0825
TICKS_PER_REV = 4096
WHEELBASE_M = 0.33
TICK_M = 2 * math.pi * WHEEL_RADIUS_M / TICKS_PER_REV
TRACK_POS_M = 0.01         # m, rad: when one arc would leave the ticks' pose farther than this
TRACK_HEADING_RAD = 0.005  # from the logged odometry, the sub-step becomes arc + turn


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


class TickWriter:
    """Writes `enc` records into body (a list of lines shared with the other records) and
    keeps the statistics the meta lines report."""

    def __init__(self, body):
        self.body = body
        self.cum_r = 0.0
        self.cum_l = 0.0
        self.ticks = (0, 0)         # the last written counts
        self.dead = None            # the pose they dead-reckon to, in the current odometry frame
        self.t_end = None           # the time of the last enc record
        self.substeps = 0
        self.splits = 0
        self.split_side = 0.0
        self.split_turn = 0.0
        self.side_sum = 0.0
        self.side_max = 0.0
        self.path = 0.0
        self.rot = 0.0
        self.max_dth = 0.0

    def start(self, t):
        """The first enc record, `enc t 0 0`."""
        self.body.append(f"enc {t:.6f} 0 0")
        self.t_end = t

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

    def substep(self, a, b, t, t_prev):
        """The motion from odometry pose a to b as ticks, at time t (t_prev: the time written
        before it, for the mid-time of a split)."""
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
            self.advance(chord, 2 * phi, t_prev + (t - t_prev) / 2)
            self.advance(0.0, turn, t)
            self.splits += 1
            self.split_side += abs(side)
            self.split_turn = max(self.split_turn, abs(turn))
        self.substeps += 1
        self.path += math.hypot(dx, dy)
        self.rot += abs(dth)
        self.max_dth = max(self.max_dth, abs(dth))
