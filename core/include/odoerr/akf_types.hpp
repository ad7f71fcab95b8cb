// odoerr core: the AKF's status codes, health counters, settings and scan summary (akf.hpp).
#pragma once

#include <cstdint>

#include "odoerr/scalar.hpp"

namespace odoerr {

/// Why a step or a beam was not applied. Every rejection is counted, never silent.
enum class Status : std::uint8_t {
  kOk = 0,
  kBadInput,       ///< a non-finite input
  kNoReturn,       ///< beam had no valid return (nan, <= 0 or beyond range_max)
  kNoMapHit,       ///< the predicted beam hits no wall
  kGrazing,        ///< incidence on the predicted wall beyond the limit
  kTooClose,       ///< predicted range within kNearRangeSigmas sigma of zero (returns cut off)
  kGated,          ///< normalised innovation squared above the gate
  kBadInnovation,  ///< innovation variance not finite or not above the measurement variance
  kBadCovariance,  ///< the update would make a variance non-positive or non-finite
};

/// Health counters (monotonic; the firmware publishes them as telemetry).
struct AkfCounters {
  std::uint32_t predictions = 0;
  std::uint32_t bad_inputs = 0;
  std::uint32_t bad_predictions = 0;
  std::uint32_t beams_used = 0;
  std::uint32_t no_return = 0;
  std::uint32_t no_map_hit = 0;
  std::uint32_t grazing = 0;
  std::uint32_t too_close = 0;  ///< beams refused: predicted range too short (kTooClose)
  std::uint32_t gated = 0;
  std::uint32_t bad_innovation = 0;
  std::uint32_t bad_covariance = 0;
  std::uint32_t pose_fixes_used = 0;      ///< scalar pose-fix components fused
  std::uint32_t pose_fixes_rejected = 0;  ///< scalar pose-fix components refused
};

template <typename S>
struct AkfConfig {
  /// Beams whose incidence angle on the predicted wall exceeds this are skipped: near
  /// grazing incidence dr/dtheta grows like tan(incidence) and one beam can wreck the
  /// heading. 75 degrees by default.
  S max_incidence_rad = S(75.0 / 180.0) * kPi<S>;
  /// Gate on the normalised innovation squared (nu^2 / S) of one beam: 25 = 5 sigma.
  S gate_nis = S(25);
  /// Fuse a scan's beams in the order of their NIS at the prior mean, most consistent
  /// first, instead of in beam order. In a linear filter the order does not matter; with a
  /// wide heading prior (a real robot's odometry, scans every half metre) the first beams
  /// fused move the state, and in beam order one wrongly associated beam can move it far
  /// enough that the good beams after it are gated. Costs a second ray cast per beam:
  /// a host option (odoerr replay --order-beams), off in the firmware. Read by the
  /// Estimator, which then calls updateScanOrdered instead of updateScan.
  bool order_by_prior_nis = false;
};

/// Per-scan summary for statistics.
template <typename S>
struct ScanStats {
  int used = 0;
  int skipped = 0;
  S nis_sum = S(0);  ///< sum of nu^2/S over the used beams
};

}  // namespace odoerr
