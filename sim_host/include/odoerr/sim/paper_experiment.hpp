// sim_host: the Monte Carlo experiment of Section 5 (both starts of the non-systematic
// parameters), aggregated like the paper's Fig. 1 and 2, written as summary.json and a CSV.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "odoerr/sim/runner.hpp"

namespace odoerr::sim {

enum class DriveKind { kSync, kDiff };

struct PaperOptions {
  DriveKind drive = DriveKind::kSync;
  int runs = 100;
  std::uint64_t seed = 1;      ///< run r uses seed + r (the same for both starts)
  int threads = 2;
  int record_every = 10;       ///< cycles between CSV rows (10 = every 10 cm)
  SimConfig sim{};
  FilterSetup setup{};
  OfKind of = OfKind::kPaper;  ///< the non-systematic estimator (--of paper|ml)
  KMlConfig<double> ml{};      ///< its settings when ml
  /// Called from the calling thread as runs complete (done, total).
  std::function<void(int, int)> progress;
};

/// Statistics over runs of one quantity at one record.
struct Stat {
  double truth = 0, mean = 0, accuracy_pct = 0, rmse = 0, sigma_mean = 0;
};

struct CaseResult {
  NonSysStart start = NonSysStart::kSmall;
  std::vector<double> distance_m;
  std::vector<std::string> names;          ///< parameter names (systematic then non-systematic)
  std::vector<std::vector<Stat>> params;   ///< [record][param]
  std::vector<double> pos_rms_m, heading_rms_rad, pos_sigma_mean_m, heading_sigma_mean_rad;
  std::uint64_t beams_used = 0, gated = 0, grazing = 0, too_close = 0, no_return = 0, rejected = 0;
  std::uint64_t of_updates = 0, of_rejected = 0, of_clamped = 0;
  /// Each run's last record: [run][param] value and reported sigma, then position and
  /// heading error (runs.csv).
  std::vector<std::vector<double>> final_values, final_sigmas;
  std::vector<double> final_pos_err_m, final_heading_err_rad;
};

struct PaperResult {
  DriveKind drive = DriveKind::kSync;
  OfKind of = OfKind::kPaper;
  KMlConfig<double> ml{};  ///< the ml estimator's settings (summary.json "ml" when of is ml)
  bool figure_eight = false;  ///< the drive's path (SimConfig::figure_eight)
  double radius_m = 0;        ///< its radius (the circle's, or each lobe's)
  int runs = 0;
  double wall_time_s = 0;
  std::vector<CaseResult> cases;  ///< small, large
  /// The Cramér-Rao bound (odoerr bound) on the experiment's nominal drive (run 0's truth
  /// path), in %, at every record of the cases ([record][param], systematic then
  /// non-systematic; NaN where undefined, e.g. at distance 0), and its computing time:
  /// delta's with K known (odoerr bound's systematic: what the AKF's mean model can reach),
  /// K's with delta unknown (nonsystematic_delta_unknown), as the AKF estimates it.
  std::vector<std::vector<double>> bound_pct;
  /// Both from the joint information of (K, delta) (systematic_joint and
  /// nonsystematic_delta_unknown); delta's takes in what Q's dependence on delta tells,
  /// which the AKF does not use.
  std::vector<std::vector<double>> bound_pct_joint;
  /// Each with the others known: delta's as bound_pct, K's with delta known (nonsystematic).
  std::vector<std::vector<double>> bound_pct_known;
  double bound_time_s = 0;
};

const char* toString(DriveKind d);

/// Runs the experiment. Throws std::invalid_argument for bad options.
PaperResult runPaperExperiment(const PaperOptions& opt);

/// The summary.json document (shape fixed by the issue; checkpoints at 5, 10, 20, 30 m).
std::string summaryJson(const PaperResult& r);
/// Per-run CSV of each run's last record (value and reported sigma of every parameter).
std::string runsCsv(const PaperResult& r, std::uint64_t seed0);
/// Per-record CSV (the plot script's input).
std::string paperCsv(const PaperResult& r);
/// Counters of the filters over all runs (health.json).
std::string healthJson(const PaperResult& r);

}  // namespace odoerr::sim
