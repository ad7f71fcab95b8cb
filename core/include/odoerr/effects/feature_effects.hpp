// odoerr core: the generic feature effects. A finding of residual discovery ("wheel_R
// travel error = 0.03 x ds_R_speed") enters the model as a configured slot of one of
// these, without writing an effect struct:
//
//   FeatureMotion<N>: inc += sum_i c_i * f_i(inc, ctx) * target_i     (kMotion)
//   FeatureRange<N>:  range += sum_i c_i * g_i(beam)                   (kMeasurement)
//
// The features and targets are those of effects/features.hpp (the one source of truth
// that the host's discovery code uses too). The coefficients c_i are the effect's
// parameters and join the augmented state like any effect's; nominal 0.
//
// Priors: a coefficient's unit depends on its slot's feature, so the prior sigma and the
// reference size are configured per slot (configure(...)) and read with
// effects::priorSigma(effect, i) / effects::referenceSize(effect, i) (catalogue.hpp); the
// type-only priorSigma<E>(i) refuses these effects at compile time.
//
// Neither effect is a member of the Catalogue: diagnose does not rank them.
#pragma once

#include <limits>

#include <Eigen/Core>

#include "odoerr/effects/features.hpp"
#include "odoerr/effects/motion_effects.hpp"  // NominalZero, startJacobians
#include "odoerr/model.hpp"

namespace odoerr::effects {

namespace feature_detail {
inline constexpr const char* kSlotNames[16] = {"c0", "c1", "c2",  "c3",  "c4",  "c5",  "c6",  "c7",
                                        "c8", "c9", "c10", "c11", "c12", "c13", "c14", "c15"};
}

/// A motion correction that is a sum over N configured slots of coefficient x feature,
/// each added to its target: out = in + sum_i c_i f_i(in) dir_i. An unconfigured slot
/// (feature none) changes nothing and has zero Jacobian columns.
///
/// Jacobians: exact w.r.t. the increment (rho, th; no feature depends on side) and the
/// coefficients. The features and targets that read the pose (cos/sin_heading_ds, x_ds,
/// y_ds, world_x, world_y) take it from the motion context, as RegionScale does: their
/// dependence on the pose is not in F (the effect API has no pose Jacobian), a first-order
/// term of size c * f * (pose error), which the filter neglects.
template <int N = 4>
struct FeatureMotion : NominalZero<FeatureMotion<N>> {
  static_assert(N >= 1 && N <= 16, "1 to 16 slots");
  static constexpr EffectKind kKind = EffectKind::kMotion;
  static constexpr int kParams = N;
  static constexpr const char* kName = "feature_motion";
  static constexpr const char* kDescription =
      "a motion error found by residual discovery: a sum of coefficient x feature, each on its target";
  static constexpr const char* const* kParamNames = feature_detail::kSlotNames;  ///< c0..c{N-1}
  static constexpr bool kUsesHeading = true;     ///< the filter fills MotionContext::heading
  static constexpr bool kHistory = true;         ///< the history features (HistoryMotionContext)
  static constexpr bool kConfiguredPrior = true;  ///< priors per slot: priorSigma(effect, i)

  struct Slot {
    MotionFeature feature = MotionFeature::kNone;
    MotionTarget target = MotionTarget::kAlong;
    double prior_sigma = 0;  ///< prior sigma of c_i (target unit / feature unit)
    double reference = 0;    ///< a size of c_i worth detecting
  };
  Slot slots[N]{};
  double wheelbase = 0.5;  ///< d of the ds_R/ds_L features and wheel targets (m; the drive's nominal)
  double xc = 0, yc = 0;   ///< map centre of x_ds, y_ds (m)
  /// t_c of the step features (ds_after, ...: s since the log's start); infinite: none.
  double t_change = std::numeric_limits<double>::infinity();

  /// Configures slot i; false (nothing changed) when i is out of range, an enum is out of
  /// range or a prior is negative or not finite.
  bool configure(int i, MotionFeature f, MotionTarget t, double prior_sigma, double reference) {
    if (i < 0 || i >= N || static_cast<int>(f) >= kMotionFeatureCount ||
        static_cast<int>(t) >= kMotionTargetCount || !(prior_sigma >= 0) || !(reference >= 0) ||
        !isFinite(prior_sigma) || !isFinite(reference)) {
      return false;
    }
    slots[i] = Slot{f, t, prior_sigma, reference};
    return true;
  }
  double priorSigma(int i) const { return i >= 0 && i < N ? slots[i].prior_sigma : 0.0; }
  double referenceSize(int i) const { return i >= 0 && i < N ? slots[i].reference : 0.0; }

  /// Slot i's feature value in a cycle (what the host regresses on), for the increment in.
  template <typename S>
  FeatureValue<S> feature(int i, const Increment<S>& in, const HistoryMotionContext<S>& ctx) const {
    return motionFeature(slots[i].feature, in.rho, in.theta, ctx, S(wheelbase), S(xc), S(yc), S(t_change));
  }

  template <typename S>
  Increment<S> apply(const Increment<S>& in, const S* p, const HistoryMotionContext<S>& ctx,
                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {
    startJacobians(d_in, d_p);
    Increment<S> out = in;
    const S d = S(wheelbase), x0 = S(xc), y0 = S(yc), tc = S(t_change);
    for (int i = 0; i < N; ++i) {
      const Slot& sl = slots[i];
      if (sl.feature == MotionFeature::kNone) continue;
      const FeatureValue<S> v = motionFeature(sl.feature, in.rho, in.theta, ctx, d, x0, y0, tc);
      S dir[3];
      motionTargetDirection(sl.target, ctx, d, dir);
      const S cf = p[i] * v.f;
      out.rho += cf * dir[0];
      out.theta += cf * dir[1];
      out.side += cf * dir[2];
      for (int r = 0; r < 3; ++r) {
        d_p(r, i) = v.f * dir[r];
        d_in(r, 0) += p[i] * v.d_rho * dir[r];
        d_in(r, 1) += p[i] * v.d_th * dir[r];
      }
    }
    return out;
  }
};

/// A range correction that is a sum over N configured slots of coefficient x beam feature:
/// range += sum_i c_i g_i. d range / d c_i = g_i, at the ray as cast (as for range_bias and
/// range_scale); the features' dependence on the pose is not in H (first order in c).
template <int N = 4>
struct FeatureRange : NominalZero<FeatureRange<N>> {
  static_assert(N >= 1 && N <= 16, "1 to 16 slots");
  static constexpr EffectKind kKind = EffectKind::kMeasurement;
  static constexpr bool kShiftsRay = false;
  static constexpr int kParams = N;
  static constexpr const char* kName = "feature_range";
  static constexpr const char* kDescription =
      "a range error found by residual discovery: a sum of coefficient x beam feature";
  static constexpr const char* const* kParamNames = feature_detail::kSlotNames;  ///< c0..c{N-1}
  static constexpr bool kConfiguredPrior = true;

  struct Slot {
    BeamFeature feature = BeamFeature::kNone;
    double prior_sigma = 0;  ///< prior sigma of c_i (m / feature unit)
    double reference = 0;    ///< a size of c_i worth detecting
  };
  Slot slots[N]{};

  /// Configures slot i; false (nothing changed) when out of range or a prior is invalid.
  bool configure(int i, BeamFeature f, double prior_sigma, double reference) {
    if (i < 0 || i >= N || static_cast<int>(f) >= kBeamFeatureCount || !(prior_sigma >= 0) ||
        !(reference >= 0) || !isFinite(prior_sigma) || !isFinite(reference)) {
      return false;
    }
    slots[i] = Slot{f, prior_sigma, reference};
    return true;
  }
  double priorSigma(int i) const { return i >= 0 && i < N ? slots[i].prior_sigma : 0.0; }
  double referenceSize(int i) const { return i >= 0 && i < N ? slots[i].reference : 0.0; }

  template <typename S>
  S range(const BeamContext<S>& b, const S* p, S* dr_dp) const {
    const BeamFeatureInputs<S> in = beamFeatureInputs(b);
    S corr = S(0);
    for (int i = 0; i < N; ++i) {
      const S g = beamFeature(slots[i].feature, in);
      dr_dp[i] = g;
      corr += p[i] * g;
    }
    return corr;
  }
};

}  // namespace odoerr::effects
