// sim_host: `odoerr bound` — the Cramér-Rao bound of every estimated quantity along a
// drive (docs/nonsystematic.md).
//
// Pose and systematic parameters: the posterior CRB, computed as the EKF covariance
// recursion with the core's Jacobians (Akf::transition, Akf::expectedRange) evaluated at
// the TRUE path, the true systematic parameters and the true K, from the filter's prior.
//
// Non-systematic parameters K: the Fisher information of the measurement record about K,
// through the AKF's innovations (prediction-error decomposition of the likelihood of the
// model linearised at the true path). For the scalar innovation of each beam,
// nu ~ N(mu(K), s(K)) given the past,
//   I_ij += 0.5 ds_i ds_j / s^2            (covariance term; ds = h dP h^T, dP the exact
//                                           derivative of the Riccati recursion in K)
//         + h E[xi_i xi_j^T] h^T / s       (mean term; xi = d xhat / dK_i, the sensitivity
//                                           of the filter's prediction to K, whose second
//                                           moment is propagated jointly with the error)
// The bound is sigma_K = sqrt((I^-1)_ii) (data only: no prior on K).
//
// K with delta unknown (bound_joint.hpp): the joint information of theta = (K, delta), with
// delta a parameter of the data distribution (the pose-only filter at theta: the prediction
// and F, G depend on delta) plus the filter's prior information on delta; K's bound is the
// KK block of its inverse.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "odoerr/sim/odolog.hpp"
#include "odoerr/sim/paper_experiment.hpp"

namespace odoerr::sim {

/// One quantity's bound at one point of the path.
struct BoundValue {
  std::string name;
  double truth = 0;
  double sigma = -1;      ///< CRB standard deviation; < 0 when not yet defined
  double bound_pct = -1;  ///< 100 sigma / |truth|; < 0 when not defined (truth 0 or sigma undefined)
};

/// The bound at one distance along the path.
struct BoundPoint {
  double distance_m = 0;
  int cycles = 0;
  double x_sigma_m = 0, y_sigma_m = 0, position_sigma_m = 0, heading_sigma_rad = 0;
  std::vector<BoundValue> systematic;
  std::vector<BoundValue> nonsystematic;            ///< full Fisher information (both terms)
  std::vector<BoundValue> nonsystematic_cov_term;   ///< the covariance term alone
  std::vector<std::vector<double>> fisher;          ///< full information matrix of K
  std::vector<std::vector<double>> fisher_cov_term; ///< its covariance term
  /// K with the systematic parameters delta unknown (joint information of theta = (K, delta),
  /// delta a parameter of the data with the filter's prior on it; K's block of its inverse).
  std::vector<BoundValue> nonsystematic_delta_unknown;
  /// K from the joint information's KK block alone (the same model with delta given).
  std::vector<BoundValue> nonsystematic_delta_given;
  std::vector<BoundValue> systematic_joint;         ///< delta's block of the same inverse (K unknown too)
  std::vector<std::vector<double>> fisher_joint;    ///< joint information, order (K..., delta...), prior included
};

struct BoundResult {
  std::string source;  ///< "sim" or the log's path
  std::string drive;   ///< "sync" or "diff"
  int cycles = 0, scans = 0;
  std::uint64_t beams = 0;         ///< beams in the recursion (valid return, predictable at the truth)
  std::uint64_t beams_skipped = 0; ///< valid returns not predictable at the truth (no hit, grazing)
  double max_cov_mismatch = 0;     ///< max |C_ee - P| / max|P| (0 up to rounding: a self-check)
  double seconds = 0;
  std::vector<BoundPoint> along;   ///< every `every_m` metres
  BoundPoint final_point;
};

struct BoundOptions {
  double every_m = 1.0;  ///< spacing of the along-path records
  /// When > 0: a record every this many cycles instead (the paper experiment's CSV rows).
  int every_cycles = 0;
  /// Optional: write the linearisation (per cycle F, G, dQ/dK, beam rows H) as JSON for
  /// an independent dense computation (tests/bound/dense_check.py).
  std::string dump_path;
  /// Scales the prior sigma of the systematic parameters (both recursions); 1 = the
  /// filter's. For the limit delta known (tests) and for studies.
  double systematic_prior_scale = 1.0;
};

/// The bound on a simulated drive of the paper's experiment (run `seed`, K started
/// `start`): the truth path as simulated, the filter's priors from `setup`.
bool boundOfSimulatedDrive(DriveKind drive, const SimConfig& cfg, std::uint64_t seed, const FilterSetup& setup,
                           const BoundOptions& opt, BoundResult* out, std::string* error);

/// Truth values a log must give: the systematic parameters and K of its drive, by name.
/// From the log's `meta truth NAME=V ...` record, overridden by `overrides` (NAME=V).
/// False with *error naming what is missing.
bool truthOfOdolog(const Odolog& log, const std::vector<std::string>& overrides,
                   std::vector<std::pair<std::string, double>>* truth, std::string* error);

/// The bound on an odolog drive with truth records: cycles as `odoerr replay` makes them
/// (one per `cycle_m` of encoder travel, scans at their stamps), the truth pose
/// interpolated at each cycle, the beams with a valid return.
bool boundOfOdolog(const Odolog& log, const std::vector<std::pair<std::string, double>>& truth, double cycle_m,
                   const BoundOptions& opt, BoundResult* out, std::string* error);

/// The result as JSON (schema in docs/nonsystematic.md).
nlohmann::ordered_json boundJson(const BoundResult& r);

}  // namespace odoerr::sim
