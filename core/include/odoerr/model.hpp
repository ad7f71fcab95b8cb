// odoerr core: the augmented-state layout, composed at compile time.
//
//   state = [ x, y, theta | drive systematic parameters | effect 1 params | effect 2 ... ]
//
// Model<Drive, Effects...> is the one source of truth for state indices: the pose block
// is PoseIdx, the drive block starts at kDriveOffset, effect E's block at offsetOf<E>().
// An effect is a small self-contained type of one of three kinds (docs/diagnostics.md
// walks through writing one; core/include/odoerr/effects/ holds the catalogue):
//
//   struct MyEffect {
//     static constexpr EffectKind kKind = EffectKind::kMotion;  // or kMeasurement, kNoise
//     static constexpr int kParams = 1;
//     static constexpr const char* kName = "my_effect";
//     static constexpr const char* kParamNames[kParams] = {"my_gain"};
//     template <typename S> static Eigen::Matrix<S, kParams, 1> nominal();
//     // kMotion: inc_out = g(inc_in, p, ctx); fills d inc_out / d inc_in and d inc_out / d p.
//     template <typename S>
//     Increment<S> apply(const Increment<S>& in, const S* p, const MotionContext<S>& ctx,
//                        Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const;
//     // kMeasurement: the change of a beam's predicted range, and d range / d p (at the
//     // ray as cast). With kShiftsRay, shift() first moves the ray (range() returns 0).
//     template <typename S> S range(const BeamContext<S>& b, const S* p, S* dr_dp) const;
//     template <typename S> void shift(const RayContext<S>& rc, const S* p, RayShift<S>* out) const;
//     // kNoise: extra variances of (rho, theta, side) of this cycle's increment.
//     template <typename S>
//     Eigen::Matrix<S, 3, 1> variance(const Increment<S>& inc, const S* p,
//                                     const MotionContext<S>& ctx) const;
//   };
//
// Adding an effect to the type list enlarges the fixed-size state; the filter code is
// unchanged (nothing is copied) and nothing is allocated. A model without effects
// compiles to exactly the paper's filter.
#pragma once

#include <limits>
#include <tuple>
#include <type_traits>
#include <utility>

#include "odoerr/motion.hpp"

namespace odoerr {

enum class EffectKind { kMotion, kMeasurement, kNoise };

/// The reversal odometer of one gear train (one wheel of the differential drive): the sign
/// of its last non-zero travel and its |travel| since that sign last changed.
template <typename S>
struct ReversalOdometer {
  S s_rev = std::numeric_limits<S>::infinity();  ///< |travel| since the last reversal (m)
  int last_sign = 0;                              ///< sign of the last non-zero travel

  /// Advances past a cycle whose travel was t (a travel of 0 is no reversal).
  void advance(S t) {
    const int sign = t > S(0) ? 1 : (t < S(0) ? -1 : 0);
    if (sign != 0 && last_sign != 0 && sign != last_sign) s_rev = S(0);
    if (sign != 0) last_sign = sign;
    s_rev += std::abs(t);
  }
};

/// What a motion or noise effect may depend on besides the increment itself: the cycle's
/// duration (speeds are rho / dt, dtheta / dt; 0 = unknown, speed-dependent effects then
/// stay inactive), the travel so far and the pose at the start of the cycle.
template <typename S>
struct MotionContext {
  S dt = S(0);
  S s_abs = S(0);                                  ///< cumulative |rho| (m)
  S s_signed = S(0);                               ///< cumulative signed rho (m)
  S s_rev = std::numeric_limits<S>::infinity();   ///< |travel| since the last reversal
  S s_enc = S(0);  ///< cumulative signed travel the encoders report (nominal constants): the wheel angle
  S x = S(0);
  S y = S(0);
  /// Heading at the start of the cycle, and its cos and sin. The filter fills them only
  /// for models with an effect that declares `static constexpr bool kUsesHeading = true`
  /// (Model::kUsesHeading); otherwise they stay at heading 0.
  S heading = S(0);
  S cos_heading = S(1);
  S sin_heading = S(0);
  int last_sign = 0;                               ///< sign of the last non-zero rho

  /// Sets the heading and its cos, sin (host code, simulators).
  void setHeading(S h) {
    heading = h;
    cos_heading = std::cos(h);
    sin_heading = std::sin(h);
  }

  /// Advances the odometers past a cycle whose translation was rho (encoders: enc).
  void advance(S rho, S enc) {
    s_enc += enc;
    const int sign = rho > S(0) ? 1 : (rho < S(0) ? -1 : 0);
    if (sign != 0 && last_sign != 0 && sign != last_sign) s_rev = S(0);
    if (sign != 0) last_sign = sign;
    s_abs += std::abs(rho);
    s_signed += rho;
    s_rev += std::abs(rho);
  }
};

/// The motion context of a model with an effect that needs each wheel's own reversals
/// (differential drive; the drive model's increment split as R = rho + dtheta d / 2,
/// L = rho - dtheta d / 2 by the effect's wheels()). Only such models use it: the others,
/// the firmware's among them, keep the plain MotionContext, neither larger nor slower.
template <typename S>
struct WheelMotionContext : MotionContext<S> {
  ReversalOdometer<S> wheel_r{};  ///< the right wheel's own reversal odometer
  ReversalOdometer<S> wheel_l{};  ///< the left wheel's
};

/// The motion context of a model with an effect that reads the motion's history (the feature
/// effects: accelerations, jerk, turn-rate change, time since the start): the previous
/// cycle's speeds, its acceleration and the time so far, advanced by Model::advanceContext.
/// Only such models use it (host models; the firmware's keeps the plain MotionContext).
template <typename S>
struct HistoryMotionContext : WheelMotionContext<S> {
  S v_prev = S(0);   ///< the previous cycle's forward speed rho / dt (m/s)
  S w_prev = S(0);   ///< its turn rate theta / dt (rad/s)
  S a_prev = S(0);   ///< its forward acceleration (m/s^2)
  S t = S(0);        ///< the sum of the cycle durations so far (s)
  int cycles = 0;    ///< cycles with a known duration so far (the rates need 1, the jerk 2)

  /// Past a cycle of duration cycle_dt (<= 0: unknown, the history restarts) whose drive
  /// increment was (rho, th).
  void advanceHistory(S rho, S th, S cycle_dt) {
    if (!(cycle_dt > S(0))) {
      cycles = 0;
      return;
    }
    const S v = rho / cycle_dt;
    a_prev = cycles >= 1 ? (v - v_prev) / cycle_dt : S(0);
    v_prev = v;
    w_prev = th / cycle_dt;
    t += cycle_dt;
    ++cycles;
  }
};

/// Whether an effect reads the motion's history: it declares `static constexpr bool kHistory
/// = true` and takes a `const HistoryMotionContext<S>&` in apply().
template <typename E, typename = void>
struct UsesHistory : std::false_type {};
template <typename E>
struct UsesHistory<E, std::void_t<decltype(E::kHistory)>> : std::bool_constant<E::kHistory> {};

/// Whether an effect needs the wheels' reversal odometers: it declares
/// `static constexpr bool kWheelOdometers = true`, `wheels(increment, &right, &left)` (the
/// split), and takes a `const WheelMotionContext<S>&` in apply().
template <typename E, typename = void>
struct UsesWheelOdometers : std::false_type {};
template <typename E>
struct UsesWheelOdometers<E, std::void_t<decltype(E::kWheelOdometers)>> : std::bool_constant<E::kWheelOdometers> {};

/// Where a beam's ray starts and points, relative to the nominal set-up: a shift of the
/// laser position (world frame, m) and a rotation of the ray (rad). Measurement effects
/// that move the ray (mount offsets, latency) say so here, before the ray is cast, so that
/// the cast finds the wall the shifted ray really hits (a first-order range correction
/// cannot follow a ray across a corner).
template <typename S>
struct RayShift {
  S dlx = S(0);
  S dly = S(0);
  S da = S(0);
};

/// What a ray-shifting effect may depend on.
template <typename S>
struct RayContext {
  S c, sn;              ///< cos, sin of the robot heading
  S vx, vy, w;          ///< robot velocity (world frame) and turn rate
  S lever_x, lever_y;   ///< d (laser position) / d heading
};

/// What a measurement effect may depend on: the beam's nominal prediction and its
/// geometry (all in the world frame), and the robot's latest velocity.
template <typename S>
struct BeamContext {
  S range;          ///< predicted range of the nominal model (m)
  S drdx, drdy;     ///< d range / d laser position (= d range / d robot x, y)
  S drdth;          ///< d range / d robot heading (beam rotation and mount lever)
  S drda;           ///< d range / d beam direction (rotation of the ray alone)
  S c, sn;          ///< cos, sin of the robot heading
  S n_dot_u;        ///< wall normal . ray direction
  int wall;         ///< index of the wall hit
  S vx, vy, w;      ///< robot velocity (world frame, m/s) and turn rate (rad/s)
  S alpha;          ///< the beam's angle relative to the laser's x axis (angle_min + i angle_inc)
};

namespace model_detail {
/// Whether an effect reads the heading of the motion context (kUsesHeading, default false).
template <typename E, typename = void>
struct UsesHeading : std::false_type {};
template <typename E>
struct UsesHeading<E, std::void_t<decltype(E::kUsesHeading)>> : std::bool_constant<E::kUsesHeading> {};
}  // namespace model_detail

template <typename DriveT, typename... Effects>
class Model {
 public:
  using Drive = DriveT;
  using S = typename Drive::Scalar;
  using Scalar = S;
  using Input = typename Drive::Input;
  using NonSysVec = typename Drive::NonSysVec;

  static constexpr int kDriveOffset = PoseIdx::kDim;
  static constexpr int kEffectParams = (0 + ... + Effects::kParams);
  static constexpr bool kHasEffects = sizeof...(Effects) > 0;
  static constexpr bool kHasMeasurementEffects = (false || ... || (Effects::kKind == EffectKind::kMeasurement));
  static constexpr bool kHasNoiseEffects = (false || ... || (Effects::kKind == EffectKind::kNoise));
  /// Some effect reads MotionContext::heading / cos_heading / sin_heading: only then does
  /// the filter fill them (a model without such an effect pays nothing per cycle).
  static constexpr bool kUsesHeading = (false || ... || model_detail::UsesHeading<Effects>::value);
  /// Some effect needs each wheel's reversals: the motion context is a WheelMotionContext
  /// and its wheel odometers are advanced (compile-time gate: models without such an effect,
  /// the firmware's among them, neither store nor compute them).
  static constexpr bool kHasWheelOdometers = (false || ... || UsesWheelOdometers<Effects>::value);
  /// Some effect reads the motion's history: the context is a HistoryMotionContext.
  static constexpr bool kHasHistory = (false || ... || UsesHistory<Effects>::value);
  static constexpr int kParams = Drive::kParams + kEffectParams;
  static constexpr int kStates = PoseIdx::kDim + kParams;
  static constexpr int kNoise = Drive::kNoise;
  static constexpr int kNonSys = Drive::kNonSys;

  /// What the motion effects of this model depend on.
  using Context = std::conditional_t<
      kHasHistory, HistoryMotionContext<S>,
      std::conditional_t<kHasWheelOdometers, WheelMotionContext<S>, MotionContext<S>>>;

  using StateVec = Eigen::Matrix<S, kStates, 1>;
  using StateMat = Eigen::Matrix<S, kStates, kStates>;
  using NoiseVec = Eigen::Matrix<S, kNoise, 1>;

  /// Index of the first parameter of effect E in the state.
  template <typename E>
  static constexpr int offsetOf() {
    return offsetImpl<E, Effects...>(kDriveOffset + Drive::kParams);
  }

  Drive drive{};
  // Each effect constructed on its own: GCC 12 value-initialises a std::tuple that starts
  // with an empty effect by zeroing storage it shares with the next one, which wiped the
  // default members of configured effects (WheelEccentricity's wheel_radius read 0).
  std::tuple<Effects...> effects{Effects{}...};

  Model() = default;
  explicit Model(const Drive& d) : drive(d) {}

  /// The parameter block of a state at its nominal (no systematic error) values.
  static void setNominal(StateVec& x) {
    x.template segment<Drive::kParams>(kDriveOffset) = Drive::nominal();
    setEffectNominal(x, std::index_sequence_for<Effects...>{});
  }

  /// Increment for input u at state x with noise nu; optionally the Jacobians of the
  /// increment wrt the whole state (3 x kStates; pose columns zero) and wrt the noise.
  Increment<S> increment(const Input& u, const StateVec& x, const NoiseVec& nu,
                         Eigen::Matrix<S, 3, kStates>* d_state = nullptr,
                         Eigen::Matrix<S, 3, kNoise>* d_noise = nullptr) const {
    return increment(u, x, nu, Context{}, d_state, d_noise);
  }

  /// The same in a motion context (what the motion effects depend on). drive_inc (may be
  /// nullptr) receives the drive model's increment before any effect, what the travel
  /// totals of the motion context count (docs/effect-catalogue.md; advanceContext): its rho,
  /// and its theta in a model with wheel odometers (the other members are left as they are).
  Increment<S> increment(const Input& u, const StateVec& x, const NoiseVec& nu,
                         const Context& ctx, Eigen::Matrix<S, 3, kStates>* d_state,
                         Eigen::Matrix<S, 3, kNoise>* d_noise, Increment<S>* drive_inc = nullptr) const {
    const auto p = x.template segment<Drive::kParams>(kDriveOffset);
    Increment<S> inc = drive.increment(u, p, nu);
    if (drive_inc != nullptr) {
      // Only what advanceContext reads: copying the whole increment in every model (the
      // firmware's, which passes nullptr, included) changed how GCC compiled the cycle and
      // cost 22 instructions per cycle on the Cortex-M4F.
      drive_inc->rho = inc.rho;
      if constexpr (kHasWheelOdometers || kHasHistory) drive_inc->theta = inc.theta;
    }
    if (d_state != nullptr) {
      d_state->setZero();
      d_state->template block<3, Drive::kParams>(0, kDriveOffset) = drive.dIncDParams(u, p);
      *d_noise = drive.dIncDNoise(u, p);
    }
    applyEffects(x, ctx, inc, d_state, d_noise, std::index_sequence_for<Effects...>{});
    return inc;
  }

  /// Advances the motion context's odometers past a cycle: drive_inc is the drive model's
  /// increment before the effects, enc the encoders' signed travel. The wheel odometers only
  /// when an effect needs them (split by the first such effect's wheels()); the history
  /// (speeds, acceleration, time) only when an effect reads it, with the context's dt.
  void advanceContext(Context& ctx, const Increment<S>& drive_inc, S enc) const {
    ctx.advance(drive_inc.rho, enc);
    if constexpr (kHasHistory) ctx.advanceHistory(drive_inc.rho, drive_inc.theta, ctx.dt);
    if constexpr (kHasWheelOdometers) {
      S r = drive_inc.rho;
      S l = drive_inc.rho;
      bool split = false;
      std::apply(
          [&](const auto&... e) {
            (
                [&](const auto& eff) {
                  using E = std::decay_t<decltype(eff)>;
                  if constexpr (UsesWheelOdometers<E>::value) {
                    if (!split) eff.wheels(drive_inc, &r, &l);
                    split = true;
                  }
                }(e),
                ...);
          },
          effects);
      ctx.wheel_r.advance(r);
      ctx.wheel_l.advance(l);
    }
  }

  /// Extra variances of (rho, theta, side) from the noise effects for this increment.
  Eigen::Matrix<S, 3, 1> extraVariance(const Increment<S>& inc, const StateVec& x,
                                       const MotionContext<S>& ctx) const {
    Eigen::Matrix<S, 3, 1> v = Eigen::Matrix<S, 3, 1>::Zero();
    std::apply(
        [&](const auto&... e) {
          (
              [&](const auto& eff) {
                using E = std::decay_t<decltype(eff)>;
                if constexpr (E::kKind == EffectKind::kNoise) {
                  v += eff.variance(inc, x.data() + offsetOf<E>(), ctx);
                }
              }(e),
              ...);
        },
        effects);
    return v;
  }

  /// The ray shift of the measurement effects that move the ray (kShiftsRay).
  RayShift<S> shiftRay(const StateVec& x, const RayContext<S>& rc) const {
    RayShift<S> out;
    std::apply(
        [&](const auto&... e) {
          (
              [&](const auto& eff) {
                using E = std::decay_t<decltype(eff)>;
                if constexpr (E::kKind == EffectKind::kMeasurement) {
                  if constexpr (E::kShiftsRay) eff.shift(rc, x.data() + offsetOf<E>(), &out);
                }
              }(e),
              ...);
        },
        effects);
    return out;
  }

  /// Adds the measurement effects to a beam's prediction: *range is corrected and their
  /// columns of d range / d state are written into h (the other columns are untouched).
  void measure(const StateVec& x, const BeamContext<S>& b, S* range, S* h) const {
    std::apply(
        [&](const auto&... e) {
          (
              [&](const auto& eff) {
                using E = std::decay_t<decltype(eff)>;
                if constexpr (E::kKind == EffectKind::kMeasurement) {
                  constexpr int off = offsetOf<E>();
                  *range += eff.range(b, x.data() + off, h + off);
                }
              }(e),
              ...);
        },
        effects);
  }

 private:
  template <typename E>
  static constexpr int offsetImpl(int) {
    static_assert(sizeof(E) == 0, "effect is not part of this model");
    return -1;
  }
  template <typename E, typename First, typename... Rest>
  static constexpr int offsetImpl(int at) {
    if constexpr (std::is_same_v<E, First>) {
      return at;
    } else {
      return offsetImpl<E, Rest...>(at + First::kParams);
    }
  }

  template <std::size_t... I>
  static void setEffectNominal(StateVec& x, std::index_sequence<I...>) {
    (setOneNominal<std::tuple_element_t<I, std::tuple<Effects...>>>(x), ...);
  }
  template <typename E>
  static void setOneNominal(StateVec& x) {
    x.template segment<E::kParams>(offsetOf<E>()) = E::template nominal<S>();
  }

  template <std::size_t... I>
  void applyEffects(const StateVec& x, const Context& ctx, Increment<S>& inc,
                    Eigen::Matrix<S, 3, kStates>* d_state, Eigen::Matrix<S, 3, kNoise>* d_noise,
                    std::index_sequence<I...>) const {
    (void)x;  // unused when the model has no effects
    (void)ctx;
    (void)d_state;
    (void)d_noise;
    (applyOne(std::get<I>(effects), x, ctx, inc, d_state, d_noise), ...);
  }
  template <typename E>
  void applyOne(const E& e, const StateVec& x, const Context& ctx, Increment<S>& inc,
                Eigen::Matrix<S, 3, kStates>* d_state, Eigen::Matrix<S, 3, kNoise>* d_noise) const {
    if constexpr (E::kKind == EffectKind::kMotion) {
      constexpr int off = offsetOf<E>();
      Eigen::Matrix<S, 3, 3> d_in;
      Eigen::Matrix<S, 3, E::kParams> d_p;
      const S* p = x.data() + off;
      inc = e.apply(inc, p, ctx, d_in, d_p);
      if (d_state != nullptr) {
        // chain rule: everything upstream of this effect passes through d_in. Upstream is
        // the drive's block and the effects' blocks before this one (the pose's columns and
        // every later block are still zero): only those columns are multiplied.
        constexpr int up = off - kDriveOffset;
        d_state->template middleCols<up>(kDriveOffset) = (d_in * d_state->template middleCols<up>(kDriveOffset)).eval();
        d_state->template block<3, E::kParams>(0, off) += d_p;
        *d_noise = d_in * (*d_noise);
      }
    } else {
      (void)e;
      (void)x;
      (void)ctx;
      (void)inc;
      (void)d_state;
      (void)d_noise;
    }
  }
};

}  // namespace odoerr
