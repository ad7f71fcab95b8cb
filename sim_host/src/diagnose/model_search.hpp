// diagnose, from discovery to a model: `--with feature:...` (the feature effects configured
// from names) and `--with auto` (forward selection over the named catalogue effects and the
// discovered features, each step accepted only when the cross-validated held-out error
// falls), and `--suggest DIR` (a C++ effect skeleton from the chosen features).
#pragma once

#include <limits>
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
/// regression cannot fit gets the reference size of a typical finding). The step features
/// (ds_R_after, ...) step at `t_change` (log time, s): prior 0.1, reference 0.005 (a drive
/// parameter that changes by 10 %, or half a percent worth finding).
FeatureSlots slotsFor(const std::vector<Term>& terms, const Residuals& base,
                      double t_change = std::numeric_limits<double>::infinity());

/// Forward selection of `--with auto` (docs/diagnostics.md, "From discovery to a model").
/// Returns the "auto" object of the contract; *final_with the tokens it kept. leave_out:
/// beams its held-out comparisons do not score (compareHeldout), or null. change_t: the time
/// of the change point discovery found (log time, s; NaN: none): the drive parameters'
/// step there is a candidate too. dependence: the non-parametric step's findings (the
/// "found" array of dependenceJson, or null): the forms it proposes in each finding's
/// variable (proposedForms: feature terms, and catalogue effects not named) are candidates.
template <template <typename> class DriveT>
nlohmann::ordered_json autoSearch(const Engine<DriveT>& en, const Ranking<DriveT>& rank, const Residuals& base,
                                  const Scales& scales, const DiagnoseOptions& opt, std::vector<std::string>* final_with,
                                  const std::vector<std::uint8_t>* leave_out, double change_t,
                                  const nlohmann::ordered_json& dependence);

/// The held-out confirmation of a named effect `e` on a drive whose residuals show no
/// structure (discovery finds no misfit in the baseline): the model with it against the
/// model without, on held-out data. Returns {"effect", "paired", "z", "worst_z",
/// "confirmed"}: confirmed unless the held-out data contradict it (neither its held-out NLL
/// nor its pose error falls, z >= 0 for both, or one rises with z >= +2).
template <template <typename> class DriveT>
nlohmann::ordered_json confirmHeldout(const Engine<DriveT>& en, int e, const DiagnoseOptions& opt,
                                      const std::vector<std::uint8_t>* leave_out);

/// The rival test: a named catalogue effect `e` against the features of the OTHER kind that
/// discovery found in the baseline's residuals (`base`: beam features for a motion effect,
/// motion features for a measurement effect), each model on its own, compared on held-out
/// data (compareModels). A mimic of the other kind (a scan latency standing in for wheels
/// that slip while the robot speeds up) explains much of a misfit, and fits the beams about
/// as well as the true form. Returns null when there is no rival (no feature of the other
/// kind, a noise effect); else {"effect", "rival", "paired", "decided_by", "z", "won"}: won
/// when the rival's held-out pose error (a log with truth) or else its NLL is lower with
/// paired z <= -2.
template <template <typename> class DriveT>
nlohmann::ordered_json rivalTest(const Engine<DriveT>& en, int e, const Residuals& base, const DiagnoseOptions& opt,
                                 const std::vector<std::uint8_t>* leave_out);

/// Writes DIR/discovered_effect.hpp: an effect struct in the tutorial's form for the motion
/// terms, a measurement struct for the beam terms, with the estimates as comments.
bool writeSuggestion(const std::string& dir, const std::vector<Term>& terms, const std::vector<double>& coef,
                     const std::vector<double>& sigma, std::string* error);

}  // namespace odoerr::sim::diag
