// sim_host: `odoerr diagnose` — does the odometry model explain the measurements, where
// does it fail, which physical effect is missing, and how much does adding it help on data
// the fit did not see. docs/diagnostics.md explains every statistic and the decision rules.
//
// It runs the firmware's estimator (double precision, with the whole effect catalogue
// composed in at compile time; effects not under test are held at nominal) over an odolog
// drive, many times: a baseline, one augmented run and one held run per candidate, a joint
// run for the information structure, and the held-out fits. Runs are independent and use
// `threads` worker threads.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "odoerr/sim/odolog.hpp"

#include "odoerr/sim/filter_tuning.hpp"

namespace odoerr::sim {

struct DiagnoseOptions {
  std::string out_dir;            ///< CSV outputs for the report ("" = none)
  std::vector<std::string> with;  ///< effects to add for the held-out comparison (catalogue names,
                                  ///< feature:NAME@TARGET, feature:BEAM_FEATURE, or auto)
  std::string suggest_dir;        ///< write a C++ effect skeleton of the discovered features here ("" = none)
  double change_at_s = std::numeric_limits<double>::quiet_NaN();  ///< t_c of the step features in --with (log time, s; NaN: none)
  double map_cell_m = 0.25;       ///< cell of the grid of residuals at the beams' hit points (m)
  bool map_exclude = true;        ///< beams ending in a region the map gets wrong leave the ranking
  double map_index_cell_m = -1;   ///< grid cell of the map's ray-cast index (m; < 0 chosen, 0 none)
  int threads = 2;
  double cycle_m = 0.01;
  double k0_w = 1e-4;      ///< diff: initial K_w (m)
  double k0_rho = 1e-3;    ///< sync: initial K_rho (m)
  double k0_theta = 1e-4;  ///< sync: initial K_theta (rad^2/m)
  FilterTuning tuning;     ///< real-robot settings (the paper's by default)
  // Held-out comparison: k-fold cross-validation over time. After a warm-up the drive is
  // cut into blocks of block_s; fold f holds out every folds-th block (f, f + folds, ...),
  // so that across the folds every block is held out exactly once.
  int folds = 4;           ///< cross-validation folds
  double warmup_s = 10.0;  ///< never held out: the filter starts here
  double block_s = 2.0;    ///< length of a held-out block (s)
  double gap_s = 0.5;      ///< data this close to a held-out block is not used to fit
  double reanchor_s = 2.0; ///< in held-out blocks one scan (or fix) per this is fused (the rest predicted)
};

/// Runs the diagnosis; fills *out with the contract of docs/diagnostics.md. False with
/// *error naming the problem (unknown effect in `with`, unusable log, unwritable output).
bool diagnoseOdolog(const Odolog& log, const DiagnoseOptions& opt, nlohmann::ordered_json* out,
                    std::string* error);

/// The catalogue's effect names, in catalogue order.
std::vector<std::string> diagnoseEffectNames();

}  // namespace odoerr::sim
