// diagnose, the detection power: for each family of forms the ranking tests (each catalogue
// effect), the smallest size this drive would have revealed at the ranking's own threshold,
// so that "consistent" says what it could not have missed.
//
// A candidate with k informed parameters is named when its likelihood ratio passes
// chi2_k's (1 - 1e-3) quantile and k ln n (BIC), and its Wald statistic chi2_k's (1 - 1e-2)
// quantile (ranking.cpp). With a true size theta_i in parameter i alone, both statistics
// are about non-central chi2_k with lambda = (theta_i / sigma_i)^2, sigma_i the sigma the
// candidate's augmented run achieved; the smallest detectable size at power P is
// sigma_i sqrt(lambda_P), lambda_P the non-centrality at which the statistic passes the
// larger threshold with probability P. sigma_i is the marginal sigma (the others free), so
// the size is conservative: a correlated parameter can only make the true power higher.
//
// The feature library's terms (discovery): a term is kept when its cluster-robust z passes
// 4.5 and it lowers the cross-validated misfit by 1 %; its smallest detectable coefficient is
// the larger of sigma_j (4.5 + z_P) and the coefficient whose fall of the misfit is 1 %.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "discovery.hpp"
#include "ranking.hpp"
#include "run_types.hpp"

namespace odoerr::sim::diag {

/// The power at which the smallest detectable sizes are stated.
inline constexpr double kDetectionPower = 0.8;

/// {"power", "threshold", "families": [...]}: per effect family, per parameter, the
/// smallest size detectable at kDetectionPower (null when the drive does not excite it, with
/// the reason). n_innov: the innovations of the reference run (the BIC's n).
nlohmann::ordered_json detectionPower(const std::vector<EffectInfo>& fx, const std::vector<Candidate>& cand,
                                      long n_innov, bool has_laser);

/// The same for the feature library's terms (discovery's candidates; regression.hpp,
/// minDetectableCoefs): {"rule", "motion": {"rows", "terms": [...]}, "beam": {...}}, each
/// term's smallest detectable coefficient in its unit, or null when the drive does not
/// determine it. From the residuals of the model as it was (`base`).
nlohmann::ordered_json featurePower(const Residuals& base);

/// The verdict's sentence for a consistent drive: "nothing larger than NAME.P X, ... (80 %
/// power); not excited by this drive: ...", from detectionPower's JSON.
std::string nothingLargerThan(const nlohmann::ordered_json& power);

}  // namespace odoerr::sim::diag
