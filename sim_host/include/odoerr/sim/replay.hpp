// sim_host: `odoerr replay` — runs the firmware's estimator (double precision) over an
// odolog drive: one cycle per cm of encoder travel; scans and pose fixes fused at their own
// time stamps, with the encoder counts interpolated to that instant. Writes in OUT:
//   trajectory.tum   t x y z qx qy qz qw (TUM format, for evo and similar tools)
//   estimates.csv    pose, parameters and K with sigmas after every cycle (+ truth if logged)
//   innovations.csv  every beam: status (used, gated, grazing, ...), measured, predicted,
//                    innovation, its variance and NIS (gated beams included)
//   replay.json      counts, mean NIS over all innovations, final estimates, RMSE vs truth
#pragma once

#include <string>
#include <vector>

#include "odoerr/sim/filter_tuning.hpp"
#include "odoerr/sim/odolog.hpp"

namespace odoerr::sim {

struct ReplayOptions {
  std::string out_dir;
  double cycle_m = 0.01;
  /// Initial non-systematic estimates (sigma: 10x the value, an order-of-magnitude prior).
  double k0_w = 1e-4;       ///< diff: K_w (m)
  double k0_rho = 1e-3;     ///< sync: K_rho (m)
  double k0_theta = 1e-4;   ///< sync: K_theta (rad^2/m)
  /// Beams fused per scan (0: all; else spread evenly, LaserGeometry's beam selection).
  int beams_used = 0;
  /// Grid cell of the map's index (m); < 0: chosen from the map's size, 0: no index.
  double map_cell_m = -1;
  /// Real-robot settings (the paper's by default).
  FilterTuning tuning;
  /// Lost-track detection and relocalisation against the map at every scan
  /// (relocalise.hpp; docs/calibrate.md, "Lost and found"); writes tracking.csv.
  bool relocalise = false;
  /// With relocalise: a declared loss ends the replay (lost at the end, no search), for
  /// scoring settings by whether they keep the track at all (odoerr calibrate's range sigma).
  bool stop_when_lost = false;
};

/// A stretch where the track was lost: from the scan that declared it to the scan that
/// recovered it (t_recovered < 0: never).
struct LostEpisode {
  double t_lost = 0, t_recovered = -1;
  double fit_lost = 0;         ///< the scan's fit at the filter's pose when declared lost
  double fit_recovered = 0;    ///< at the relocalised pose
  double jump_m = 0, jump_rad = 0;  ///< relocalised pose minus the filter's
  int map_searches = 0;        ///< whole-map searches run while lost (TrackingRules::global)
  bool found_on_map = false;   ///< recovered by a whole-map search, not a window around the pose
};

struct ReplayParam {
  std::string name;
  double value, sigma;
};

struct ReplaySummary {
  std::size_t cycles = 0, scans = 0, scans_late = 0, poses = 0, poses_late = 0;
  std::size_t beams_used = 0, beams_gated = 0, beams_skipped = 0;
  double nis_mean = 0;
  double pose_rmse_m = -1, heading_rmse_rad = -1;  ///< -1: no truth in the log
  /// The same at the truth records' own times only (the last estimate at each; no
  /// interpolation between records): the figure for sparse truth.
  double pose_rmse_at_records_m = -1, heading_rmse_at_records_rad = -1;
  std::size_t truth_records_scored = 0;
  std::vector<ReplayParam> params;                 ///< final systematic then K
  /// With ReplayOptions::relocalise: scans whose fit was checked, their median fit, the
  /// episodes; lost_at_end when the last episode was never recovered (the final
  /// parameters are then those before it).
  std::size_t scans_checked = 0, scans_poor = 0, pose_corrections = 0;
  double fit_median = -1;
  std::vector<LostEpisode> episodes;
  bool lost_at_end = false;
  bool stopped_when_lost = false;  ///< ReplayOptions::stop_when_lost ended the replay
};

/// Replays `log`; false with *error naming the problem (unsupported map size, no init...).
bool replayOdolog(const Odolog& log, const ReplayOptions& opt, ReplaySummary* sum, std::string* error);

}  // namespace odoerr::sim
