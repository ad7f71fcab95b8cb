// diagnose, from discovery to a model: `--with feature:...` (the feature effects configured
// from names) and `--with auto` (forward selection over the named catalogue effects and the
// discovered features, each step accepted only when the cross-validated held-out error
// falls), and `--suggest DIR` (a C++ effect skeleton from the chosen features).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "discovery.hpp"
#include "engine.hpp"
#include "ranking.hpp"

namespace odoerr::sim::diag {

/// A `--with` list split into catalogue effects and feature slots.
struct WithSpec {
  std::vector<int> catalogue;         ///< indices into the catalogue
  std::vector<Term> features;         ///< feature terms (motion or beam)
  std::vector<std::string> names;     ///< as given, for the JSON
  bool automatic = false;             ///< "auto"
};

/// Parses `--with` tokens: catalogue names, "auto", and feature terms "feature:NAME@TARGET"
/// (a motion feature and its target, e.g. feature:ds_R_speed@wheel_R) or "feature:NAME"
/// (a beam feature, e.g. feature:inv_cos_inc). After a "feature:" token the prefix may be
/// left out ("feature:ds_R_speed@wheel_R,ds_L_speed@wheel_L"). False with *error naming
/// the token and what is known.
bool parseWith(const std::vector<std::string>& tokens, const std::vector<EffectInfo>& catalogue, bool sync,
               WithSpec* out, std::string* error);

/// The slots of the feature effects for `terms`, their priors set from the baseline's
/// residual regression of each term (3 x |coef| or 20 x its sigma, the larger; a term the
/// regression cannot fit gets the reference size of a typical finding).
FeatureSlots slotsFor(const std::vector<Term>& terms, const Residuals& base);

/// Forward selection of `--with auto` (docs/diagnostics.md, "From discovery to a model").
/// Returns the "auto" object of the contract; *final_with the tokens it kept. leave_out:
/// beams its held-out comparisons do not score (compareHeldout), or null.
template <template <typename> class DriveT>
nlohmann::ordered_json autoSearch(const Engine<DriveT>& en, const Ranking<DriveT>& rank, const Residuals& base,
                                  const Scales& scales, const DiagnoseOptions& opt, std::vector<std::string>* final_with,
                                  const std::vector<std::uint8_t>* leave_out);

/// Writes DIR/discovered_effect.hpp: an effect struct in the tutorial's form for the motion
/// terms, a measurement struct for the beam terms, with the estimates as comments.
bool writeSuggestion(const std::string& dir, const std::vector<Term>& terms, const std::vector<double>& coef,
                     const std::vector<double>& sigma, std::string* error);

}  // namespace odoerr::sim::diag
