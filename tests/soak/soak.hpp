// The float32 soak (issue 16, part 3): the float core (the target's Scalar) driven for a
// long closed-loop drive of the paper's simulator, with the paper's noise, bursts of outlier
// ranges, beams without a return and dropped scans; checks the covariance, the NEES and
// that the counters account for every rejected beam. Host only (std library, heap).
#pragma once

#include <cstdint>
#include <string>

namespace odoerr::soak {

struct SoakOptions {
  long cycles = 1000000;
  std::uint64_t seed = 1;
  double radius_m = 4.5;            ///< the circle stays 50 cm clear of the walls
  double scan_drop_p = 0.1;         ///< per cycle: the scan is lost (no ranges at all)
  double beam_nan_p = 0.01;         ///< per beam: no return (NaN, 0, negative or beyond range)
  double burst_start_p = 0.002;     ///< per cycle: an outlier burst starts (about every 5 m)
  int burst_cycles_min = 10;        ///< its length in cycles (10 - 50 cm of travel)
  int burst_cycles_max = 50;
  int burst_beams_min = 2;          ///< adjacent beams hit by the burst
  int burst_beams_max = 8;
  double outlier_min = 0.2;         ///< outlier range = true range * U(min, max): an object
  double outlier_max = 0.7;         ///< in front of the wall (a person, a door left open),
  double outlier_margin_m = 0.3;    ///< and at least this much short (10 range sigmas)
  long nees_window = 10000;         ///< cycles per NEES window
  bool k_start_truth = true;        ///< false: the paper's start, K 100x below the truth
};

/// Figures of one soak (both drives report the same fields).
struct SoakResult {
  std::string drive;
  int states = 0;
  long cycles = 0;
  double seconds = 0;  ///< wall time (for the report only)
  // injected
  long scans_dropped = 0;
  long scans_offered = 0;
  long beams_offered = 0;
  long beams_nan_injected = 0;
  long bursts = 0;
  long outliers_injected = 0;
  // counted by the core (AkfCounters) and by beam outcome (the observer)
  long beams_used = 0, no_return = 0, no_map_hit = 0, grazing = 0, too_close = 0, gated = 0;
  long bad_innovation = 0, bad_covariance = 0, bad_inputs = 0, bad_predictions = 0;
  long predictions = 0;
  long nan_counted_no_return = 0;   ///< injected no-return beams refused as kNoReturn
  long outliers_gated = 0;          ///< injected outliers refused by the NIS gate
  long outliers_other_refusal = 0;  ///< refused before the gate (no map hit, grazing)
  long outliers_accepted = 0;       ///< fused: silently accepted
  long clean_gated = 0;             ///< uncorrupted beams the gate refused
  long of_updates = 0, of_rejected = 0, of_clamped = 0;
  // covariance
  double max_asymmetry = 0;         ///< max |P - P^T| (absolute)
  double min_eigenvalue = 1e300;    ///< smallest eigenvalue of P over the run
  double max_eigenvalue = 0;        ///< largest
  double worst_condition = 0;       ///< max over cycles of lambda_max / lambda_min
  double worst_corr_condition = 0;  ///< the same for the correlation matrix (scale-free)
  long min_eig_cycle = 0;
  long worst_cond_cycle = 0;
  long non_pd_cycles = 0;           ///< cycles with lambda_min <= 0 or non-finite P
  // consistency
  double nees_mean = 0;             ///< whole-run mean of e^T P^-1 e (pose + systematic)
  double nees_lo = 0, nees_hi = 0;  ///< the band of a window's mean (see soak.cpp)
  long nees_windows = 0;
  long nees_windows_out = 0;
  double nees_window_min = 1e300, nees_window_max = 0;
  double pose_rms_m = 0;            ///< position error RMS over the run
  double final_pos_err_m = 0;
};

SoakResult runSync(const SoakOptions& o);
SoakResult runDiff(const SoakOptions& o);

/// The soak's acceptance checks; empty when all pass, else one line per failure.
std::string checkResult(const SoakResult& r);
/// One JSON object with every field.
std::string toJson(const SoakResult& r);

}  // namespace odoerr::soak
