// odoerr core: the feature library of residual discovery, the ONE source of truth for it.
//
// `odoerr diagnose` regresses the filter's odometry and range residuals on these candidate
// features; FeatureMotion / FeatureRange (effects/feature_effects.hpp) put a finding back
// into the model as `correction = sum_i c_i * feature_i`, with the c_i in the augmented
// state. The host's discovery code and the effects both compute the features here, so a
// coefficient regressed on the host means the same thing once the filter estimates it.
//
// docs/effect-catalogue.md ("Feature effects: the discovery library") lists every feature
// and target with its formula and units.
//
// Everything is templated on the scalar, allocation-free and exception-free.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include "odoerr/map.hpp"
#include "odoerr/model.hpp"

namespace odoerr::effects {

// ---------------------------------------------------------------------------------------
// Motion features: functions of one cycle's increment (rho, th) and its context.
//
//   rho, th  the drive model's noise-free increment of the cycle (what every motion effect
//            sees: the encoders through the systematic parameters and earlier effects)
//   dt       the cycle's duration (s); rate features are 0 when dt <= 0 (unknown)
//   d        the wheelbase (diff drive; a configured constant, not the estimated delta_d)
//   R, L     the wheels' travel: R = rho + th d/2, L = rho - th d/2
//   h, x, y  the robot's heading and position at the START of the cycle (MotionContext)
//   xc, yc   the map centre (configured)
//   s_abs    the cumulative |rho| at the start of the cycle (MotionContext)
// ---------------------------------------------------------------------------------------
enum class MotionFeature : std::uint8_t {
  kNone,          ///< none: 0 (an unused slot)
  kDs,            ///< ds = rho (m)
  kAbsDs,         ///< abs_ds = |rho| (m)
  kDth,           ///< dth = th (rad)
  kAbsDth,        ///< abs_dth = |th| (rad)
  kDsR,           ///< ds_R = R (m)
  kDsL,           ///< ds_L = L (m)
  kDsRSpeed,      ///< ds_R_speed = R |R| / dt (m^2/s)
  kDsLSpeed,      ///< ds_L_speed = L |L| / dt (m^2/s)
  kVW,            ///< v_w = rho th / dt (m rad/s)
  kV2,            ///< v2 = rho |rho| / dt (m^2/s)
  kW2,            ///< w2 = th |th| / dt (rad^2/s)
  kCosHeadingDs,  ///< cos_heading_ds = cos(h) |rho| (m)
  kSinHeadingDs,  ///< sin_heading_ds = sin(h) |rho| (m)
  kXDs,           ///< x_ds = (x - xc) |rho| (m^2)
  kYDs,           ///< y_ds = (y - yc) |rho| (m^2)
  kSDs,           ///< s_ds = s_abs |rho| (m^2)
  kDt,            ///< dt = dt (s)
  // The motion's history (HistoryMotionContext: v_prev, w_prev, a_prev of the previous
  // cycle, t the time so far). With v = rho / dt, w = th / dt, a = (v - v_prev) / dt and
  // alpha = (w - w_prev) / dt; 0 while the history is too short (a needs one earlier cycle
  // of known duration, the jerk two) or in a context without history.
  kAccDs,         ///< acc_ds = a |rho| (m^2/s^2): travel gained or lost in proportion to the acceleration
  kAccPosDs,      ///< acc_pos_ds = max(a, 0) |rho| (m^2/s^2): only while speeding up (wheels that spin)
  kAccNegDs,      ///< acc_neg_ds = min(a, 0) |rho| (m^2/s^2): only while braking (wheels that skid)
  kAccRDs,        ///< acc_R_ds = a_R |R|, a_R = a + alpha d/2 (m^2/s^2): the right wheel's acceleration
  kAccLDs,        ///< acc_L_ds = a_L |L|, a_L = a - alpha d/2 (m^2/s^2): the left wheel's
  kJerkDs,        ///< jerk_ds = (a - a_prev) / dt |rho| (m^2/s^3)
  kDwDs,          ///< dw_ds = alpha |rho| (m rad/s^2): the turn rate's change
  kRevNearDs,     ///< rev_near_ds = exp(-s_rev / 0.25 m) |rho| (m): travel just after a reversal
  kTDs,           ///< t_ds = t |rho| (m s): the time since the start
  // A step at a configured time t_c (the feature effect's t_change; a change point's time):
  // the drive's own terms from t >= t_c on, 0 before (and 0 without a t_c). A drive
  // parameter that changes abruptly (a tyre that loses pressure) is one of these.
  kDsAfter,       ///< ds_after = [t >= t_c] rho (m)
  kDsRAfter,      ///< ds_R_after = [t >= t_c] R (m)
  kDsLAfter,      ///< ds_L_after = [t >= t_c] L (m)
  kDthAfter,      ///< dth_after = [t >= t_c] th (rad)
  kCount
};
constexpr int kMotionFeatureCount = static_cast<int>(MotionFeature::kCount);

/// Where a motion feature's correction c * f goes.
enum class MotionTarget : std::uint8_t {
  kAlong,    ///< along: rho += c f
  kCross,    ///< cross: side += c f
  kHeading,  ///< heading: th += c f
  kWorldX,   ///< world_x: a world-frame displacement (c f, 0): rho += c f cos h, side -= c f sin h
  kWorldY,   ///< world_y: a world-frame displacement (0, c f): rho += c f sin h, side += c f cos h
  kWheelR,   ///< wheel_R: the right wheel's travel += c f: rho += c f / 2, th += c f / d
  kWheelL,   ///< wheel_L: the left wheel's travel += c f: rho += c f / 2, th -= c f / d
  kCount
};
constexpr int kMotionTargetCount = static_cast<int>(MotionTarget::kCount);

// ---------------------------------------------------------------------------------------
// Beam features: functions of one beam's predicted range and geometry.
//
//   r      the predicted range (m)
//   inc    the SIGNED incidence angle at the wall hit (rad, in (-pi/2, pi/2), 0 = normal):
//          the angle from the wall normal that points away from the laser to the ray
//          direction, counter-clockwise positive. With it, a ray rotated by +dalpha
//          (counter-clockwise) changes its range by r tan(inc) dalpha.
//   alpha  the beam's angle relative to the laser's x axis (rad; angle_min + i angle_inc,
//          without the mount yaw)
//   v, w   the robot's signed forward speed (m/s) and turn rate (rad/s) over the last cycle
//
// Not in the library: the time since the log's start. The filter's measurement hook does
// not know it (the AKF sees cycle durations, which are 0 when unknown, never the scans'
// stamps), and a feature the filter cannot compute as the host does would break the
// contract that both compute the same numbers.
// ---------------------------------------------------------------------------------------
enum class BeamFeature : std::uint8_t {
  kNone,            ///< none: 0 (an unused slot)
  kOne,             ///< one = 1 (a range bias)
  kRange,           ///< range = r (m; a range scale)
  kAbsInc,          ///< abs_inc = |inc| (rad)
  kInc2,            ///< inc2 = inc^2 (rad^2)
  kInvCosInc,       ///< inv_cos_inc = 1 / cos(inc) - 1 (1)
  kAlpha,           ///< alpha (rad)
  kAlpha2,          ///< alpha2 = alpha^2 (rad^2)
  kAngleSens,       ///< angle_sens = dr / dalpha = r tan(inc) (m/rad)
  kAlphaAngleSens,  ///< alpha_angle_sens = alpha * angle_sens (m): a beam-angle scale error
  kV,               ///< v (m/s)
  kW,               ///< w (rad/s)
  kWAngleSens,      ///< w_angle_sens = w * angle_sens (m/s): a latency in rotation
  kCount
};
constexpr int kBeamFeatureCount = static_cast<int>(BeamFeature::kCount);

namespace feature_detail {
inline constexpr const char* kMotionFeatureNames[kMotionFeatureCount] = {
    "none",     "ds",         "abs_ds",     "dth",           "abs_dth",        "ds_R",     "ds_L",
    "ds_R_speed", "ds_L_speed", "v_w",      "v2",            "w2",             "cos_heading_ds", "sin_heading_ds",
    "x_ds",     "y_ds",       "s_ds",       "dt",            "acc_ds",         "acc_pos_ds", "acc_neg_ds",
    "acc_R_ds", "acc_L_ds",   "jerk_ds",    "dw_ds",         "rev_near_ds",    "t_ds",
    "ds_after", "ds_R_after", "ds_L_after", "dth_after"};
inline constexpr const char* kMotionFeatureUnits[kMotionFeatureCount] = {
    "1",       "m",       "m",       "rad",     "rad",     "m",        "m",       "m^2/s", "m^2/s",
    "m*rad/s", "m^2/s",   "rad^2/s", "m",       "m",       "m^2",      "m^2",     "m^2",   "s",
    "m^2/s^2", "m^2/s^2", "m^2/s^2", "m^2/s^2", "m^2/s^2", "m^2/s^3",  "m*rad/s^2", "m",   "m*s",
    "m",       "m",       "m",       "rad"};
inline constexpr const char* kMotionTargetNames[kMotionTargetCount] = {"along",   "cross",   "heading", "world_x",
                                                                "world_y", "wheel_R", "wheel_L"};
inline constexpr const char* kMotionTargetUnits[kMotionTargetCount] = {"m", "m", "rad", "m", "m", "m", "m"};
inline constexpr const char* kBeamFeatureNames[kBeamFeatureCount] = {
    "none",       "one",   "range",      "abs_inc", "inc2", "inv_cos_inc", "alpha",
    "alpha2",     "angle_sens", "alpha_angle_sens", "v", "w", "w_angle_sens"};
inline constexpr const char* kBeamFeatureUnits[kBeamFeatureCount] = {"1",     "1",   "m", "rad", "rad^2", "1", "rad",
                                                              "rad^2", "m/rad", "m", "m/s", "rad/s", "m/s"};

template <typename Enum, int Count>
inline bool parse(const char* s, const char* const (&names)[Count], Enum* out) {
  if (s == nullptr) return false;
  for (int i = 0; i < Count; ++i) {
    if (std::strcmp(s, names[i]) == 0) {
      if (out != nullptr) *out = static_cast<Enum>(i);
      return true;
    }
  }
  return false;
}
template <int Count>
constexpr const char* name(int i, const char* const (&names)[Count]) {
  return i >= 0 && i < Count ? names[i] : "?";
}
template <typename S>
constexpr S sgn(S v) {
  return v > S(0) ? S(1) : (v < S(0) ? S(-1) : S(0));
}
}  // namespace feature_detail

/// The name of a feature or target ("ds_R_speed"; "?" when out of range).
constexpr const char* motionFeatureName(MotionFeature f) {
  return feature_detail::name(static_cast<int>(f), feature_detail::kMotionFeatureNames);
}
constexpr const char* motionTargetName(MotionTarget t) {
  return feature_detail::name(static_cast<int>(t), feature_detail::kMotionTargetNames);
}
constexpr const char* beamFeatureName(BeamFeature f) {
  return feature_detail::name(static_cast<int>(f), feature_detail::kBeamFeatureNames);
}
/// The unit of a feature's value or of a target's quantity (a coefficient's unit is the
/// target's unit over the feature's; a beam coefficient's is m over the feature's).
constexpr const char* motionFeatureUnit(MotionFeature f) {
  return feature_detail::name(static_cast<int>(f), feature_detail::kMotionFeatureUnits);
}
constexpr const char* motionTargetUnit(MotionTarget t) {
  return feature_detail::name(static_cast<int>(t), feature_detail::kMotionTargetUnits);
}
constexpr const char* beamFeatureUnit(BeamFeature f) {
  return feature_detail::name(static_cast<int>(f), feature_detail::kBeamFeatureUnits);
}

/// Parses a name as printed by the *Name functions (exact, case-sensitive). Returns false
/// (and leaves *out alone) for an unknown name or nullptr.
inline bool parseMotionFeature(const char* s, MotionFeature* out) {
  return feature_detail::parse(s, feature_detail::kMotionFeatureNames, out);
}
inline bool parseMotionTarget(const char* s, MotionTarget* out) {
  return feature_detail::parse(s, feature_detail::kMotionTargetNames, out);
}
inline bool parseBeamFeature(const char* s, BeamFeature* out) {
  return feature_detail::parse(s, feature_detail::kBeamFeatureNames, out);
}

/// A motion feature's value and its partial derivatives w.r.t. the increment's rho and th
/// (at the context held fixed). d|u|/du is taken as sign(u), 0 at u = 0.
template <typename S>
struct FeatureValue {
  S f = S(0);
  S d_rho = S(0);
  S d_th = S(0);
};

/// Whether feature f is a step at a configured time (ds_after, ds_R_after, ds_L_after, dth_after).
constexpr bool isStepFeature(MotionFeature f) {
  return f == MotionFeature::kDsAfter || f == MotionFeature::kDsRAfter || f == MotionFeature::kDsLAfter ||
         f == MotionFeature::kDthAfter;
}

/// Whether feature f reads the motion's history (HistoryMotionContext).
constexpr bool isHistoryFeature(MotionFeature f) {
  return f == MotionFeature::kAccDs || f == MotionFeature::kAccPosDs || f == MotionFeature::kAccNegDs ||
         f == MotionFeature::kAccRDs || f == MotionFeature::kAccLDs || f == MotionFeature::kJerkDs ||
         f == MotionFeature::kDwDs || f == MotionFeature::kTDs || isStepFeature(f);
}

/// A history feature (isHistoryFeature) of a cycle with increment (rho, th) after the
/// history h; d is the wheelbase.
///
/// Its partial derivatives hold the rates (a, alpha, the jerk) fixed: they leave out the
/// rates' own dependence on this cycle's increment (1/dt^2, 1/dt^3 times the increment's
/// error). That dependence cancels over the next cycle, whose rate sees the same error with
/// the opposite sign (the sum of a |rho| over cycles telescopes), but a filter that keeps no
/// earlier increment in its state cannot see the cancellation: with it, the covariance took
/// the encoders' noise 1/dt^2 times over and the model with the feature predicted worse.
///
/// The step features read h.t against t_change (infinite: no step configured, the feature 0).
template <typename S>
inline FeatureValue<S> historyFeature(MotionFeature f, S rho, S th, const HistoryMotionContext<S>& h, S d,
                                      S t_change = std::numeric_limits<S>::infinity()) {
  using feature_detail::sgn;
  FeatureValue<S> v;
  const S a_rho = std::abs(rho), s_rho = sgn(rho);
  if (f == MotionFeature::kTDs) return {h.t * a_rho, h.t * s_rho, S(0)};
  if (isStepFeature(f)) {
    if (!(h.t >= t_change)) return v;
    const S half_d = S(0.5) * d;
    switch (f) {
      case MotionFeature::kDsAfter: return {rho, S(1), S(0)};
      case MotionFeature::kDsRAfter: return {rho + th * half_d, S(1), half_d};
      case MotionFeature::kDsLAfter: return {rho - th * half_d, S(1), -half_d};
      default: return {th, S(0), S(1)};  // kDthAfter
    }
  }
  if (!(h.dt > S(0)) || h.cycles < 1) return v;
  const S inv_dt = S(1) / h.dt, half_d = S(0.5) * d;
  const S a = (rho * inv_dt - h.v_prev) * inv_dt;
  const S alpha = (th * inv_dt - h.w_prev) * inv_dt;
  switch (f) {
    case MotionFeature::kAccDs:
      v = {a * a_rho, a * s_rho, S(0)};
      break;
    case MotionFeature::kAccPosDs:
      if (a > S(0)) v = {a * a_rho, a * s_rho, S(0)};
      break;
    case MotionFeature::kAccNegDs:
      if (a < S(0)) v = {a * a_rho, a * s_rho, S(0)};
      break;
    case MotionFeature::kAccRDs: {
      const S r = rho + th * half_d, ar = a + alpha * half_d, sg = sgn(r);
      v = {ar * std::abs(r), ar * sg, half_d * ar * sg};
      break;
    }
    case MotionFeature::kAccLDs: {
      const S l = rho - th * half_d, al = a - alpha * half_d, sg = sgn(l);
      v = {al * std::abs(l), al * sg, -half_d * al * sg};
      break;
    }
    case MotionFeature::kJerkDs:
      if (h.cycles >= 2) {
        const S j = (a - h.a_prev) * inv_dt;
        v = {j * a_rho, j * s_rho, S(0)};
      }
      break;
    case MotionFeature::kDwDs:
      v = {alpha * a_rho, alpha * s_rho, S(0)};
      break;
    default:
      break;
  }
  return v;
}

/// Motion feature f of a cycle with increment (rho, th) in context ctx (dt, heading,
/// position, s_abs at the cycle's start); `wheelbase` is d, (xc, yc) the map centre. The
/// history features need a HistoryMotionContext (in any other context they are 0).
template <typename S, typename Ctx>
inline FeatureValue<S> motionFeature(MotionFeature f, S rho, S th, const Ctx& ctx, S wheelbase, S xc, S yc,
                                     S t_change = std::numeric_limits<S>::infinity()) {
  using feature_detail::sgn;
  if constexpr (std::is_base_of_v<HistoryMotionContext<S>, Ctx>) {
    if (isHistoryFeature(f))
      return historyFeature(f, rho, th, static_cast<const HistoryMotionContext<S>&>(ctx), wheelbase, t_change);
  }
  const S half_d = S(0.5) * wheelbase;
  const S inv_dt = ctx.dt > S(0) ? S(1) / ctx.dt : S(0);  // rate features vanish when dt is unknown
  const S a_rho = std::abs(rho), s_rho = sgn(rho);
  FeatureValue<S> v;
  switch (f) {
    case MotionFeature::kDs:
      v = {rho, S(1), S(0)};
      break;
    case MotionFeature::kAbsDs:
      v = {a_rho, s_rho, S(0)};
      break;
    case MotionFeature::kDth:
      v = {th, S(0), S(1)};
      break;
    case MotionFeature::kAbsDth:
      v = {std::abs(th), S(0), sgn(th)};
      break;
    case MotionFeature::kDsR:
      v = {rho + th * half_d, S(1), half_d};
      break;
    case MotionFeature::kDsL:
      v = {rho - th * half_d, S(1), -half_d};
      break;
    case MotionFeature::kDsRSpeed: {
      const S r = rho + th * half_d, g = S(2) * std::abs(r) * inv_dt;  // d(R|R|)/dR = 2|R|
      v = {r * std::abs(r) * inv_dt, g, g * half_d};
      break;
    }
    case MotionFeature::kDsLSpeed: {
      const S l = rho - th * half_d, g = S(2) * std::abs(l) * inv_dt;
      v = {l * std::abs(l) * inv_dt, g, -g * half_d};
      break;
    }
    case MotionFeature::kVW:
      v = {rho * th * inv_dt, th * inv_dt, rho * inv_dt};
      break;
    case MotionFeature::kV2:
      v = {rho * a_rho * inv_dt, S(2) * a_rho * inv_dt, S(0)};
      break;
    case MotionFeature::kW2:
      v = {th * std::abs(th) * inv_dt, S(0), S(2) * std::abs(th) * inv_dt};
      break;
    case MotionFeature::kCosHeadingDs:
      v = {ctx.cos_heading * a_rho, ctx.cos_heading * s_rho, S(0)};
      break;
    case MotionFeature::kSinHeadingDs:
      v = {ctx.sin_heading * a_rho, ctx.sin_heading * s_rho, S(0)};
      break;
    case MotionFeature::kXDs:
      v = {(ctx.x - xc) * a_rho, (ctx.x - xc) * s_rho, S(0)};
      break;
    case MotionFeature::kYDs:
      v = {(ctx.y - yc) * a_rho, (ctx.y - yc) * s_rho, S(0)};
      break;
    case MotionFeature::kSDs:
      v = {ctx.s_abs * a_rho, ctx.s_abs * s_rho, S(0)};
      break;
    case MotionFeature::kDt:
      v = {ctx.dt > S(0) ? ctx.dt : S(0), S(0), S(0)};
      break;
    case MotionFeature::kRevNearDs: {
      const S e = std::exp(-ctx.s_rev / S(0.25));  // s_rev is infinite before the first reversal
      v = {e * a_rho, e * s_rho, S(0)};
      break;
    }
    case MotionFeature::kAccDs:
    case MotionFeature::kAccPosDs:
    case MotionFeature::kAccNegDs:
    case MotionFeature::kAccRDs:
    case MotionFeature::kAccLDs:
    case MotionFeature::kJerkDs:
    case MotionFeature::kDwDs:
    case MotionFeature::kTDs:  // history features: above, or 0 without a history
    case MotionFeature::kDsAfter:
    case MotionFeature::kDsRAfter:
    case MotionFeature::kDsLAfter:
    case MotionFeature::kDthAfter:
    case MotionFeature::kNone:
    case MotionFeature::kCount:
      break;
  }
  return v;
}

/// The change of the increment (rho, th, side) per unit of c * f for target t: the
/// correction is inc += c f * dir. World targets rotate at the heading of the cycle's start
/// (ctx.cos_heading, ctx.sin_heading); wheel targets need wheelbase > 0 (else their heading
/// part is 0).
template <typename S>
inline void motionTargetDirection(MotionTarget t, const MotionContext<S>& ctx, S wheelbase, S dir[3]) {
  dir[0] = S(0);
  dir[1] = S(0);
  dir[2] = S(0);
  const S inv_d = wheelbase > S(0) ? S(1) / wheelbase : S(0);
  switch (t) {
    case MotionTarget::kAlong:
      dir[0] = S(1);
      break;
    case MotionTarget::kCross:
      dir[2] = S(1);
      break;
    case MotionTarget::kHeading:
      dir[1] = S(1);
      break;
    case MotionTarget::kWorldX:
      dir[0] = ctx.cos_heading;
      dir[2] = -ctx.sin_heading;
      break;
    case MotionTarget::kWorldY:
      dir[0] = ctx.sin_heading;
      dir[2] = ctx.cos_heading;
      break;
    case MotionTarget::kWheelR:
      dir[0] = S(0.5);
      dir[1] = inv_d;
      break;
    case MotionTarget::kWheelL:
      dir[0] = S(0.5);
      dir[1] = -inv_d;
      break;
    case MotionTarget::kCount:
      break;
  }
}

/// What the beam features of one beam are computed from (see BeamFeature).
template <typename S>
struct BeamFeatureInputs {
  S range = S(0);    ///< predicted range r (m)
  S inc = S(0);      ///< signed incidence angle (rad), in (-pi/2, pi/2)
  S cos_inc = S(1);  ///< cos(inc) = |n . u| (> 0)
  S tan_inc = S(0);  ///< tan(inc)
  S alpha = S(0);    ///< beam angle relative to the laser's x axis (rad)
  S v = S(0);        ///< robot's signed forward speed (m/s)
  S w = S(0);        ///< robot's turn rate (rad/s)
};

/// The value of beam feature f.
template <typename S>
inline S beamFeature(BeamFeature f, const BeamFeatureInputs<S>& b) {
  switch (f) {
    case BeamFeature::kOne:
      return S(1);
    case BeamFeature::kRange:
      return b.range;
    case BeamFeature::kAbsInc:
      return std::abs(b.inc);
    case BeamFeature::kInc2:
      return b.inc * b.inc;
    case BeamFeature::kInvCosInc:
      return S(1) / b.cos_inc - S(1);
    case BeamFeature::kAlpha:
      return b.alpha;
    case BeamFeature::kAlpha2:
      return b.alpha * b.alpha;
    case BeamFeature::kAngleSens:
      return b.range * b.tan_inc;
    case BeamFeature::kAlphaAngleSens:
      return b.alpha * b.range * b.tan_inc;
    case BeamFeature::kV:
      return b.v;
    case BeamFeature::kW:
      return b.w;
    case BeamFeature::kWAngleSens:
      return b.w * b.range * b.tan_inc;
    case BeamFeature::kNone:
    case BeamFeature::kCount:
      break;
  }
  return S(0);
}

/// The beam feature inputs of a ray from (px, py) in direction (ux, uy) (need not be unit)
/// onto the line of `wall` (the segment the ray hits; its ends are not checked). alpha is
/// the beam's angle in the laser frame, v and w the robot's speed and turn rate. Returns
/// false when the ray is parallel to the wall or the wall is not in front of it.
template <typename S>
inline bool beamFeatureInputs(S px, S py, S ux, S uy, const Segment<S>& wall, S alpha, S v, S w,
                              BeamFeatureInputs<S>* out) {
  const S un = std::sqrt(ux * ux + uy * uy);
  const S ex = wall.x2 - wall.x1, ey = wall.y2 - wall.y1;
  const S len = std::sqrt(ex * ex + ey * ey);
  if (!(un > S(0)) || !(len > S(0))) return false;
  ux /= un;
  uy /= un;
  const S nx = -ey / len, ny = ex / len;  // the map's unit normal (SegmentMap::add)
  const S n_dot_u = nx * ux + ny * uy;
  if (n_dot_u == S(0)) return false;
  const S r = (nx * (wall.x1 - px) + ny * (wall.y1 - py)) / n_dot_u;
  if (!(r > S(0))) return false;
  const S n_cross_u = nx * uy - ny * ux;
  // with n' = sign(n.u) n (facing away from the laser): cos inc = n'.u, sin inc = n' x u
  const S cos_inc = std::abs(n_dot_u);
  const S sin_inc = n_dot_u > S(0) ? n_cross_u : -n_cross_u;
  out->range = r;
  out->cos_inc = cos_inc;
  out->tan_inc = sin_inc / cos_inc;
  out->inc = std::atan2(sin_inc, cos_inc);
  out->alpha = alpha;
  out->v = v;
  out->w = w;
  return true;
}

/// The beam feature inputs from what the filter's measurement hook sees (the ray as cast).
/// drda = r tan(inc) (the derivation in docs/effect-catalogue.md), so tan(inc) = drda / r.
template <typename S>
inline BeamFeatureInputs<S> beamFeatureInputs(const BeamContext<S>& b) {
  BeamFeatureInputs<S> in;
  in.range = b.range;
  in.cos_inc = std::abs(b.n_dot_u);
  in.tan_inc = b.range > S(0) ? b.drda / b.range : S(0);
  in.inc = std::atan(in.tan_inc);
  in.alpha = b.alpha;
  in.v = b.c * b.vx + b.sn * b.vy;  // the velocity's forward component: signed speed
  in.w = b.w;
  return in;
}

/// The beam feature inputs of beam i of `laser` from a robot pose (x, y, theta), as the
/// filter casts it (mount offset and yaw included): the host's discovery code computes the
/// features from a posterior pose with this. v, w: the robot's speed and turn rate. Returns
/// false when the beam hits no wall (or grazes it exactly).
template <typename S, typename MapT, int MaxBeams>
inline bool beamFeatureInputs(const MapT& map, const LaserGeometry<S, MaxBeams>& laser, S x, S y,
                              S theta, int i, S v, S w, BeamFeatureInputs<S>* out) {
  if (i < 0 || i >= laser.beams()) return false;
  const LaserConfig<S>& cfg = laser.config();
  const S c = std::cos(theta), sn = std::sin(theta);
  const S lx = x + c * cfg.mount_x - sn * cfg.mount_y;
  const S ly = y + sn * cfg.mount_x + c * cfg.mount_y;
  const S ux = c * laser.dirC(i) - sn * laser.dirS(i);
  const S uy = sn * laser.dirC(i) + c * laser.dirS(i);
  const RayHit<S> hit = map.castDir(lx, ly, ux, uy);
  if (!hit.hit) return false;
  return beamFeatureInputs(lx, ly, ux, uy, map.wall(hit.wall), cfg.angle_min + S(i) * cfg.angle_inc, v, w, out);
}

}  // namespace odoerr::effects
