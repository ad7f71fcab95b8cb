// odoerr core: the motion effects of the catalogue (docs/effect-catalogue.md is the physics
// contract). Each one changes the increment of a cycle before it is applied to the pose;
// its parameters join the augmented state when the effect is composed into a Model.
// Every effect is nominal at zero, so composing one in changes nothing until the filter
// finds evidence for it. Jacobians are exact (tests compare them with finite differences).
#pragma once

#include <Eigen/Core>

#include "odoerr/model.hpp"

namespace odoerr::effects {

/// Every catalogue effect is nominal at zero: the base that says so once (CRTP; E::kParams
/// is read only when nominal() is called, once E is complete).
template <typename E>
struct NominalZero {
  template <typename S>
  static auto nominal() {  // the return type is deduced when called (E complete by then)
    return Eigen::Matrix<S, E::kParams, 1>(Eigen::Matrix<S, E::kParams, 1>::Zero());
  }
};

/// Shared by the effects: a helper that starts the Jacobians at identity / zero.
template <typename S, int P>
inline void startJacobians(Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, P>& d_p) {
  d_in.setIdentity();
  d_p.setZero();
}

/// Travel after a reversal over which backlash loses its b (m): `backlash` and
/// `wheel_backlash`.
constexpr double kBacklashSpan = 0.05;

/// Backlash of one gear train: its travel t this cycle, the odometer before the cycle
/// (|travel| since its last reversal, sign of its last non-zero travel), the loss b. Only the
/// part of t inside the first kBacklashSpan after a reversal is scaled by 1 - b / span, so
/// that exactly b is lost per reversal. Returns t' and *g = dt'/dt, *c = dt'/db.
template <typename S>
inline S backlashTravel(S t, S b, S s_rev_before, int last_sign, S* g, S* c) {
  *g = S(1);
  *c = S(0);
  // A reversal in this very cycle starts the span now.
  const int sign = t > S(0) ? 1 : (t < S(0) ? -1 : 0);
  const bool reversing = sign != 0 && last_sign != 0 && sign != last_sign;
  const S s_rev = reversing ? S(0) : s_rev_before;
  if (!(s_rev < S(kBacklashSpan))) return t;
  const S f = S(1) / S(kBacklashSpan);
  // Only the part of the cycle's travel inside the span loses, so that exactly b is lost
  // per reversal whatever the cycle length (a whole 1 cm cycle scaled from s_rev = 4.9 cm
  // lost 20 % too much, and the estimate came out 20 % low).
  const S inside = S(kBacklashSpan) - s_rev;
  if (std::abs(t) <= inside) {
    *g = S(1) - b * f;
    *c = -t * f;
    return t * (S(1) - b * f);
  }
  // the cycle leaves the span: its first `inside` metres lose, a constant amount
  const S sg = t > S(0) ? S(1) : S(-1);
  *c = -sg * f * inside;
  return t - sg * b * f * inside;
}

/// Shared by the per-wheel effects of the differential drive (`wheel_speed_scale`,
/// `wheel_backlash`): the configured wheelbase d, the split of an increment into the two
/// wheels' travel R = rho + dtheta d / 2, L = rho - dtheta d / 2, and back after each wheel
/// changed on its own: rho = (R' + L') / 2, dtheta = (R' - L') / d, side unchanged.
/// A wheelbase of 0 means there are no separately driven wheels (the sync drive): the
/// effect is then a no-op. effects::setWheelbase configures every PerWheel effect of a model.
struct PerWheel {
  /// The drive's nominal wheelbase d (m), set by the composing code to DiffDrive::wheelbase
  /// (effects::setWheelbase). 0, the default and the sync drive's: no wheels, a no-op.
  double wheelbase = 0.0;

  bool hasWheels() const { return wheelbase > 0.0; }
  template <typename S>
  void wheels(const Increment<S>& in, S* right, S* left) const {
    const S h = S(0.5) * S(wheelbase);
    *right = in.rho + h * in.theta;
    *left = in.rho - h * in.theta;
  }
  /// out from the changed wheel travels r, l; g_r = dr/dR, g_l = dl/dL; c_r = dr/dp0 and
  /// c_l = dl/dp1 (parameter 0 acts on the right wheel, 1 on the left).
  template <typename S>
  Increment<S> recombine(const Increment<S>& in, S r, S l, S g_r, S g_l, S c_r, S c_l,
                         Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, 2>& d_p) const {
    const S h = S(0.5) * S(wheelbase);
    const S inv_d = S(1) / S(wheelbase);
    Increment<S> out = in;
    out.rho = S(0.5) * (r + l);
    out.theta = (r - l) * inv_d;
    // R = rho + h dtheta, L = rho - h dtheta
    d_in(0, 0) = S(0.5) * (g_r + g_l);
    d_in(0, 1) = S(0.5) * h * (g_r - g_l);
    d_in(1, 0) = (g_r - g_l) * inv_d;
    d_in(1, 1) = S(0.5) * (g_r + g_l);
    d_p(0, 0) = S(0.5) * c_r;
    d_p(1, 0) = c_r * inv_d;
    d_p(0, 1) = S(0.5) * c_l;
    d_p(1, 1) = -c_l * inv_d;
    return out;
  }
};

/// Lateral slip growing with centripetal acceleration: side += k v w rho.
struct TurnSlip : NominalZero<TurnSlip> {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "turn_slip";
  static constexpr const char* kParamNames[kParams] = {"k_s2_per_m"};
  static constexpr const char* kDescription =
      "the tyres slide sideways in a turn, by an amount growing with the centripetal acceleration v*w";
  static constexpr double kPriorSigma[kParams] = {0.05};
  static constexpr double kReference[kParams] = {0.02};  ///< a size worth detecting
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    Increment<S> out = in;
    if (!(ctx.dt > S(0))) return out;
    const S inv2 = S(1) / (ctx.dt * ctx.dt);
    // side += k * (rho/dt) * (theta/dt) * rho = k rho^2 theta / dt^2
    const S g = in.rho * in.rho * in.theta * inv2;
    out.side = in.side + p[0] * g;
    d_in(2, 0) = p[0] * S(2) * in.rho * in.theta * inv2;
    d_in(2, 1) = p[0] * in.rho * in.rho * inv2;
    d_p(2, 0) = g;
    return out;
  }
};

/// Heading lost when turning fast: dtheta *= 1 - k |w|.
struct RotationSlip : NominalZero<RotationSlip> {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "rotation_slip";
  static constexpr const char* kParamNames[kParams] = {"k_s"};
  static constexpr const char* kDescription =
      "the wheels scrub when the robot turns fast, so it turns less than the encoders say, more so at high turn rate";
  static constexpr double kPriorSigma[kParams] = {0.05};
  static constexpr double kReference[kParams] = {0.02};
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    Increment<S> out = in;
    if (!(ctx.dt > S(0))) return out;
    // dtheta * (1 - k |dtheta| / dt)
    const S a = std::abs(in.theta) / ctx.dt;
    out.theta = in.theta * (S(1) - p[0] * a);
    d_in(1, 1) = S(1) - S(2) * p[0] * a;
    d_p(1, 0) = -in.theta * a;
    return out;
  }
};

/// Wheel travel scale growing with speed: rho *= 1 + k |v|.
struct SpeedScale : NominalZero<SpeedScale> {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "speed_scale";
  static constexpr const char* kParamNames[kParams] = {"k_s_per_m"};
  static constexpr const char* kDescription =
      "the distance travelled per encoder count changes with speed (tyre compression, longitudinal slip)";
  static constexpr double kPriorSigma[kParams] = {0.05};
  static constexpr double kReference[kParams] = {0.02};
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    Increment<S> out = in;
    if (!(ctx.dt > S(0))) return out;
    const S a = std::abs(in.rho) / ctx.dt;
    out.rho = in.rho * (S(1) + p[0] * a);
    d_in(0, 0) = S(1) + S(2) * p[0] * a;
    d_p(0, 0) = in.rho * a;
    return out;
  }
};

/// Each wheel's travel scale growing with that wheel's speed (differential drive):
/// X *= 1 + k_X |X| / dt for X = R, L.
struct WheelSpeedScale : NominalZero<WheelSpeedScale>, PerWheel {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 2;
  static constexpr const char* kName = "wheel_speed_scale";
  static constexpr const char* kParamNames[kParams] = {"k_R_s_per_m", "k_L_s_per_m"};
  static constexpr const char* kDescription =
      "one wheel's distance per encoder count changes with its own speed (a tyre that compresses or slips more than the other)";
  static constexpr double kPriorSigma[kParams] = {0.05, 0.05};
  static constexpr double kReference[kParams] = {0.02, 0.02};
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    if (!(ctx.dt > S(0)) || !hasWheels()) return in;
    S r;
    S l;
    wheels(in, &r, &l);
    const S inv_dt = S(1) / ctx.dt;
    const S ar = std::abs(r) * inv_dt;
    const S al = std::abs(l) * inv_dt;
    return recombine(in, r * (S(1) + p[0] * ar), l * (S(1) + p[1] * al), S(1) + S(2) * p[0] * ar,
                     S(1) + S(2) * p[1] * al, r * ar, l * al, d_in, d_p);
  }
};

/// Travel scale varying once per wheel turn: rho *= 1 + a cos(phi) + b sin(phi),
/// phi = s_enc / wheel_radius (the wheel angle the encoders count, exactly known).
struct WheelEccentricity : NominalZero<WheelEccentricity> {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 2;
  static constexpr const char* kName = "wheel_eccentricity";
  static constexpr const char* kParamNames[kParams] = {"a", "b"};
  static constexpr const char* kDescription =
      "an out-of-round or off-centre wheel: the travel per count varies once per wheel revolution";
  static constexpr double kPriorSigma[kParams] = {0.05, 0.05};
  static constexpr double kReference[kParams] = {0.02, 0.02};
  double wheel_radius = 0.05;  ///< nominal wheel radius (m)
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    const S phi = ctx.s_enc / S(wheel_radius);
    const S c = std::cos(phi);
    const S s = std::sin(phi);
    Increment<S> out = in;
    out.rho = in.rho * (S(1) + p[0] * c + p[1] * s);
    d_in(0, 0) = S(1) + p[0] * c + p[1] * s;
    d_p(0, 0) = in.rho * c;
    d_p(0, 1) = in.rho * s;
    return out;
  }
};

/// Lost motion after a reversal: the travel inside the first 5 cm after it is scaled by
/// 1 - b / 0.05, so that exactly b is lost.
struct Backlash : NominalZero<Backlash> {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "backlash";
  static constexpr const char* kParamNames[kParams] = {"b_m"};
  static constexpr const char* kDescription =
      "gear play: after the robot reverses, the first millimetres of encoder travel do not move it";
  static constexpr double kPriorSigma[kParams] = {0.01};
  static constexpr double kReference[kParams] = {0.004};
  static constexpr double kSpan = kBacklashSpan;  ///< travel after a reversal over which it is lost (m)
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    Increment<S> out = in;
    out.rho = backlashTravel(in.rho, p[0], ctx.s_rev, ctx.last_sign, &d_in(0, 0), &d_p(0, 0));
    return out;
  }
};

/// Play in each wheel's own gearbox (differential drive): after that wheel's direction of
/// rotation reverses, its first b_X metres of travel are lost (as `backlash`, per wheel, on
/// each wheel's own reversal odometer ctx.wheel_r / ctx.wheel_l).
struct WheelBacklash : NominalZero<WheelBacklash>, PerWheel {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 2;
  static constexpr const char* kName = "wheel_backlash";
  static constexpr const char* kParamNames[kParams] = {"b_R_m", "b_L_m"};
  static constexpr const char* kDescription =
      "gear play in one wheel's gearbox: after that wheel reverses, its first millimetres of encoder travel do not move it";
  static constexpr double kPriorSigma[kParams] = {0.01, 0.01};
  static constexpr double kReference[kParams] = {0.004, 0.004};
  static constexpr double kSpan = kBacklashSpan;
  /// A Model that composes it keeps each wheel's reversal odometer (WheelMotionContext).
  static constexpr bool kWheelOdometers = true;
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const WheelMotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    if (!hasWheels()) return in;
    S r;
    S l;
    wheels(in, &r, &l);
    S g_r;
    S g_l;
    S c_r;
    S c_l;
    const S r2 = backlashTravel(r, p[0], ctx.wheel_r.s_rev, ctx.wheel_r.last_sign, &g_r, &c_r);
    const S l2 = backlashTravel(l, p[1], ctx.wheel_l.s_rev, ctx.wheel_l.last_sign, &g_l, &c_l);
    return recombine(in, r2, l2, g_r, g_l, c_r, c_l, d_in, d_p);
  }
};

/// A floor region with its own travel scale: rho *= 1 + c_j in cell j of a 3x3 grid over
/// the map's bounding box.
struct RegionScale : NominalZero<RegionScale> {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kGrid = 3;
  static constexpr int kParams = kGrid * kGrid;
  static constexpr const char* kName = "region_scale";
  static constexpr const char* kParamNames[kParams] = {"c0", "c1", "c2", "c3", "c4",
                                                       "c5", "c6", "c7", "c8"};
  static constexpr const char* kDescription =
      "a part of the floor (carpet, ramp, a slippery patch) scales the travel differently from the rest";
  static constexpr double kPriorSigma[kParams] = {0.05, 0.05, 0.05, 0.05, 0.05,
                                                  0.05, 0.05, 0.05, 0.05};
  static constexpr double kReference[kParams] = {0.02, 0.02, 0.02, 0.02, 0.02,
                                                 0.02, 0.02, 0.02, 0.02};
  double x_min = 0, y_min = 0, x_max = 1, y_max = 1;  ///< the map's bounding box

  /// Grid cell of a position (clamped into the grid; a coordinate that is not a number is
  /// taken as the low edge). Clamped before the conversion to int, which is undefined for a
  /// value beyond int's range (a pose far outside the map; found by fuzz_pipeline).
  int cell(double x, double y) const {
    auto idx = [](double v, double lo, double hi) {
      const double f = hi > lo ? (v - lo) / (hi - lo) * kGrid : 0.0;
      if (!(f >= 0.0)) return 0;
      return f >= double(kGrid - 1) ? kGrid - 1 : static_cast<int>(f);
    };
    return kGrid * idx(y, y_min, y_max) + idx(x, x_min, x_max);
  }
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    const int j = cell(double(ctx.x), double(ctx.y));
    Increment<S> out = in;
    out.rho = in.rho * (S(1) + p[j]);
    d_in(0, 0) = S(1) + p[j];
    d_p(0, j) = in.rho;
    return out;
  }
};

/// A wheel radius that changes slowly with distance: rho *= 1 + g s_abs / 100 m.
struct RadiusDrift : NominalZero<RadiusDrift> {
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "radius_drift";
  static constexpr const char* kParamNames[kParams] = {"g_per_100m"};
  static constexpr const char* kDescription =
      "the wheel radius changes slowly as the robot drives (wear, tyre pressure, temperature)";
  static constexpr double kPriorSigma[kParams] = {0.05};
  static constexpr double kReference[kParams] = {0.01};
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    const S a = ctx.s_abs / S(100);
    Increment<S> out = in;
    out.rho = in.rho * (S(1) + p[0] * a);
    d_in(0, 0) = S(1) + p[0] * a;
    d_p(0, 0) = in.rho * a;
    return out;
  }
};

/// Non-systematic heading noise growing with rotation: variance q |dtheta| per cycle.
struct TurnNoise : NominalZero<TurnNoise> {
  static constexpr EffectKind kKind = EffectKind::kNoise;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "turn_noise";
  static constexpr const char* kParamNames[kParams] = {"q_rad2_per_rad"};
  static constexpr const char* kDescription =
      "random heading error growing with the angle turned (uneven scrubbing), beyond the drive's own noise model";
  static constexpr double kPriorSigma[kParams] = {1e-3};
  static constexpr double kReference[kParams] = {2e-4};
  template <typename S>
  Eigen::Matrix<S, 3, 1> variance(const Increment<S>& inc, const S* p, const MotionContext<S>&) const {
    const S q = p[0] > S(0) ? p[0] : S(0);
    return Eigen::Matrix<S, 3, 1>(S(0), q * std::abs(inc.theta), S(0));
  }
};

}  // namespace odoerr::effects
