// odoerr core: the catalogue of candidate physical effects, as one compile-time list.
// docs/effect-catalogue.md defines each; docs/writing-an-effect.md shows how to add one.
#pragma once

#include <tuple>

#include "odoerr/effects/measurement_effects.hpp"
#include "odoerr/effects/motion_effects.hpp"

namespace odoerr::effects {

using Catalogue = std::tuple<TurnSlip, RotationSlip, SpeedScale, WheelSpeedScale, WheelEccentricity, Backlash,
                             WheelBacklash, RegionScale, RadiusDrift, TurnNoise, RangeBias, RangeScale,
                             LaserMountXY, LaserMountYaw, ScanLatency, WallOffset>;

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

/// Prior sigma of parameter i of effect E (a single listed value applies to all).
template <typename E>
constexpr double priorSigma(int i) {
  constexpr int n = sizeof(E::kPriorSigma) / sizeof(double);
  return E::kPriorSigma[i < n ? i : n - 1];
}
/// A magnitude of parameter i worth detecting.
template <typename E>
constexpr double referenceSize(int i) {
  constexpr int n = sizeof(E::kReference) / sizeof(double);
  return E::kReference[i < n ? i : n - 1];
}

}  // namespace odoerr::effects
