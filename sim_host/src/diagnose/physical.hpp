// diagnose: physical bounds on the estimates of named effects. An effect whose estimate
// lies outside what the physics allows (by more than two sigmas) is a symptom of another
// misfit it absorbs, not a finding: it is not named, and the reason says so.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

namespace odoerr::sim::diag {

/// "" when the estimate of parameter i of `effect` is physically possible; else why not.
inline std::string physicalViolation(const std::string& effect, int i, double est, double sigma) {
  const double lo = est - 2 * sigma, hi = est + 2 * sigma;
  char buf[320];
  // A tyre's lateral slip angle per unit of centripetal acceleration: at most the peak slip
  // angle of rubber (about 0.2 rad) reached at the friction limit of a slippery floor
  // (mu 0.3, 2.9 m/s^2): 0.07 s^2/m.
  if (effect == "turn_slip" && (lo > 0.07 || hi < -0.07)) {
    std::snprintf(buf, sizeof buf,
                  "its estimate %.4f s^2/m is nonphysical: a tyre cannot slide sideways more than about 0.07 s^2/m "
                  "(its peak slip angle, 0.2 rad, at the friction limit of a slippery floor); it absorbs another misfit",
                  est);
    return buf;
  }
  // Scrubbing loses heading, play loses travel: neither can add any.
  if ((effect == "rotation_slip" || effect == "backlash" || effect == "wheel_backlash") && hi < 0) {
    std::snprintf(buf, sizeof buf,
                  "its estimate %.4f is nonphysical: %s can only lose motion, so its parameter is not negative; it "
                  "absorbs another misfit",
                  est, effect == "rotation_slip" ? "a scrubbing turn" : "gear play");
    return buf;
  }
  (void)i;
  return "";
}

}  // namespace odoerr::sim::diag
