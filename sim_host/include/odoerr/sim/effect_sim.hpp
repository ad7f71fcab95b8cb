// sim_host: drives with a chosen catalogue effect injected, written as odolog v1.
//
// The paper's constant circle cannot separate most effects, so this simulator drives an
// exciting programme in a 10 m room with a pillar: figure-eights (turns both ways) of two
// radii at three speeds, and straight runs with reversals. It steers open loop on its plan,
// with a weak once-a-second correction on the true pose (a high-rate controller on a noisy
// pose would correlate the inputs with the process noise, which looks like scan latency).
// Truth: the drive's error model (systematic and non-systematic) plus the injected effects,
// motion effects through the catalogue's own definitions, measurement effects by exact
// physics (moved mount, rotated laser, late scans, shifted walls) so that the estimator's
// first-order measurement model is tested, not assumed.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace odoerr::sim {

struct EffectSimConfig {
  std::string drive = "diff";  ///< "diff" or "sync"
  std::uint64_t seed = 1;
  double minutes = 4.0;
  /// Injected effects: name -> parameter values in the catalogue's order.
  std::map<std::string, std::vector<double>> effects;
  /// Injected feature terms (`feature:FEATURE@TARGET=C`, effects/features.hpp): the truth's
  /// increment gains C x feature on the target, applied by FeatureMotion after the catalogue's
  /// effects (what discovery can put back into the model). At most 4.
  struct FeatureTerm {
    std::string feature, target;
    double coef = 0;
  };
  std::vector<FeatureTerm> features;
};

/// Writes the drive as odolog v1 text. False with *error for an unknown effect or a wrong
/// number of values.
bool simulateEffectDrive(const EffectSimConfig& cfg, std::string* odolog, std::string* error);

/// Parses "name=v1,v2,..." into cfg->effects, or "feature:FEATURE@TARGET=C" into
/// cfg->features. False with *error on malformed text or an unknown name.
bool parseEffectArg(const std::string& arg, EffectSimConfig* cfg, std::string* error);

/// The catalogue's effect names and parameter counts (for messages and tests).
std::vector<std::pair<std::string, int>> catalogueEffects();

}  // namespace odoerr::sim
