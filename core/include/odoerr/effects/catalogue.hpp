// odoerr core: the catalogue of candidate physical effects, as one compile-time list.
// docs/effect-catalogue.md defines each; docs/writing-an-effect.md shows how to add one.
#pragma once

#include <tuple>
#include <type_traits>

#include "odoerr/effects/measurement_effects.hpp"
#include "odoerr/effects/motion_effects.hpp"

namespace odoerr::effects {

using Catalogue = std::tuple<TurnSlip, RotationSlip, SpeedScale, WheelEccentricity, Backlash, WheelBacklash,
                             RegionScale, RadiusDrift, TurnNoise, RangeBias, RangeScale, LaserMountXY, LaserMountYaw,
                             ScanLatency, WallOffset>;

/// Effects the simulator injects and a firmware may compose, but diagnose does not rank.
/// WheelSpeedScale: beside speed_scale it was mis-ranked on a 4-minute drive (13th with the
/// truth estimated right; and it displaced a true speed_scale, whose gain it took); its form
/// is in the feature library (ds_R_speed / ds_L_speed on wheel_R / wheel_L), which
/// discovery reports and `--with feature:` adds (docs/diagnostics.md).
using Unranked = std::tuple<WheelSpeedScale>;

/// What `odoerr sim --effect` can inject: the catalogue and the unranked effects.
template <typename A, typename B>
struct TupleCat;
template <typename... A, typename... B>
struct TupleCat<std::tuple<A...>, std::tuple<B...>> {
  using type = std::tuple<A..., B...>;
};
using SimEffects = typename TupleCat<Catalogue, Unranked>::type;

/// Configures the per-wheel effects (PerWheel) of a composed model's effect tuple with the
/// drive's nominal wheelbase: DiffDrive::wheelbase, or 0 for a drive without separately
/// driven wheels (the sync drive), which makes them no-ops.
template <typename... E>
void setWheelbase(std::tuple<E...>& effects, double wheelbase) {
  std::apply(
      [&](auto&... e) {
        (
            [&](auto& eff) {
              if constexpr (std::is_base_of_v<PerWheel, std::decay_t<decltype(eff)>>) eff.wheelbase = wheelbase;
            }(e),
            ...);
      },
      effects);
}

/// Effects whose priors are configured per instance (kConfiguredPrior, e.g. the feature
/// effects of feature_effects.hpp): their coefficients' units depend on the configuration.
template <typename E, typename = void>
struct HasConfiguredPrior : std::false_type {};
template <typename E>
struct HasConfiguredPrior<E, std::void_t<decltype(E::kConfiguredPrior)>> : std::bool_constant<E::kConfiguredPrior> {};

/// Prior sigma of parameter i of effect E (a single listed value applies to all).
template <typename E>
constexpr double priorSigma(int i) {
  static_assert(!HasConfiguredPrior<E>::value, "this effect's priors are configured: call priorSigma(effect, i)");
  constexpr int n = sizeof(E::kPriorSigma) / sizeof(double);
  return E::kPriorSigma[i < n ? i : n - 1];
}
/// A magnitude of parameter i worth detecting.
template <typename E>
constexpr double referenceSize(int i) {
  static_assert(!HasConfiguredPrior<E>::value, "this effect's priors are configured: call referenceSize(effect, i)");
  constexpr int n = sizeof(E::kReference) / sizeof(double);
  return E::kReference[i < n ? i : n - 1];
}
/// The same for an effect instance: the configured value where the effect has one (a
/// feature effect's slot), else the type's.
template <typename E>
constexpr double priorSigma(const E& e, int i) {
  if constexpr (HasConfiguredPrior<E>::value) {
    return e.priorSigma(i);
  } else {
    (void)e;
    return priorSigma<E>(i);
  }
}
template <typename E>
constexpr double referenceSize(const E& e, int i) {
  if constexpr (HasConfiguredPrior<E>::value) {
    return e.referenceSize(i);
  } else {
    (void)e;
    return referenceSize<E>(i);
  }
}

}  // namespace odoerr::effects
