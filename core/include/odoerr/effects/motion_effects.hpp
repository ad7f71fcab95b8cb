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
  static constexpr double kSpan = 0.05;  ///< travel after a reversal over which it is lost (m)
  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    Increment<S> out = in;
    // A reversal in this very cycle starts the span now.
    const int sign = in.rho > S(0) ? 1 : (in.rho < S(0) ? -1 : 0);
    const bool reversing = sign != 0 && ctx.last_sign != 0 && sign != ctx.last_sign;
    const S s_rev = reversing ? S(0) : ctx.s_rev;
    if (!(s_rev < S(kSpan))) return out;
    const S f = S(1) / S(kSpan);
    // Only the part of the cycle's travel inside the span loses, so that exactly b is lost
    // per reversal whatever the cycle length (a whole 1 cm cycle scaled from s_rev = 4.9 cm
    // lost 20 % too much, and the estimate came out 20 % low).
    const S inside = S(kSpan) - s_rev, a = std::abs(in.rho);
    if (a <= inside) {
      out.rho = in.rho * (S(1) - p[0] * f);
      d_in(0, 0) = S(1) - p[0] * f;
      d_p(0, 0) = -in.rho * f;
    } else {  // the cycle leaves the span: its first `inside` metres lose, a constant amount
      const S sg = in.rho > S(0) ? S(1) : S(-1);
      out.rho = in.rho - sg * p[0] * f * inside;
      d_p(0, 0) = -sg * f * inside;
    }
    return out;
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

  /// Grid cell of a position (clamped into the grid).
  int cell(double x, double y) const {
    auto idx = [](double v, double lo, double hi) {
      int i = hi > lo ? static_cast<int>((v - lo) / (hi - lo) * kGrid) : 0;
      return i < 0 ? 0 : (i >= kGrid ? kGrid - 1 : i);
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
