// diagnose, discovery beyond the catalogue: the filter's residuals regressed on a library
// of candidate features (effects/features.hpp, the one source of truth; plus each wheel's
// own reversals, which only the host can count).
//
// - Motion residuals: the drive is cut into segments of about 0.5 s between fused
//   measurements; a segment's residual is where the filter put the robot at its end minus
//   where the model (the run's final parameters, effects included) takes it from where
//   the filter put it at its start, in the world frame (dx, dy, dtheta). A candidate term
//   (feature f, target t) predicts, per unit coefficient, the displacement that c * f added
//   to every cycle's increment would make at the segment's end (the heading part carried
//   along the rest of the segment).
// - Beam residuals: every beam of every fused scan predicted again at the posterior
//   (measured - predicted, over the laser sigma); candidate terms are the beam features.
//
// Each is selected sparsely (forward selection, cross-validated over the held-out blocks,
// cluster-robust sigmas; regression.hpp). The drive parameters are nuisance columns, always
// in; a scan of those columns over time finds an abrupt change. docs/diagnostics.md
// ("Discovery") documents every rule. The terms in words are in terms.cpp.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dependence.hpp"
#include "engine.hpp"
#include "odoerr/effects/features.hpp"
#include "regression.hpp"

namespace odoerr::sim::diag {

/// One number printed with a printf format (%g, %.3f, ...), for the terms in words.
std::string fmt(const char* printf_format, double value);

/// One candidate term of the library.
struct Term {
  enum class Kind { kMotion, kReversal, kBeam, kTime } kind;  ///< kReversal, kTime: host-only terms
  effects::MotionFeature mf = effects::MotionFeature::kNone;
  effects::MotionTarget mt = effects::MotionTarget::kAlong;
  effects::BeamFeature bf = effects::BeamFeature::kNone;
  int wheel = 0;  ///< kReversal: 0 right (or the robot, sync), 1 left
  std::string name() const;    ///< the feature's name ("ds_R_speed", "rev_R", "inv_cos_inc")
  std::string frame() const;   ///< robot | world | wheel_R | wheel_L | beam
  std::string target() const;  ///< along | cross | heading | world_x | world_y | wheel_R | wheel_L | range
  /// The finding in plain physical words, e.g. "the right wheel travels 2.1 % more per m/s".
  std::string words(double coef, double sigma) const;
};

/// The `--with` token of a term ("feature:ds_R_speed@wheel_R"); "" when the core's
/// feature effects cannot carry it (a wheel's reversals, the time: host-only terms).
std::string withToken(const Term& t);

/// The residual designs of one run and what the selection found in them.
struct Residuals {
  Design motion, beam;
  std::vector<Term> motion_terms, beam_terms;  ///< a term per design column
  Selection motion_sel, beam_sel;
  StateTable state;  ///< the motion segments' states and residuals per metre (dependence.hpp)
  int segments = 0;
  long beams = 0;
  double seg_s = 0;  ///< mean segment length (s)
};

/// Row scales of the motion design (per component x, y, theta) and of the beams: a second
/// run is standardised with the first's, so that their sums of squares compare.
struct Scales {
  double motion[3] = {0, 0, 0};
  double beam = 0;
};

/// The pose a fused measurement alone gives (see Discovery::laserPoses).
struct LaserPose {
  double t, x, y, th;
  bool ok;
};

template <typename En>
class Discovery {
 public:
  using RunOut = typename En::RunOut;

  Discovery(const En& en, const DiagnoseOptions& opt) : en_(en), opt_(opt) {}

  /// The designs of a run recorded with `residuals`, standardised with `scales` (when
  /// null, the run's own robust scales are used and written there), and the selection.
  Residuals analyse(const RunOut& run, Scales* scales) const;

  /// A scan for one abrupt change of the drive parameters over the motion residuals of
  /// `base`; `final_` (the model with the named effects, or null) says whether it remains.
  nlohmann::ordered_json changePoints(const Residuals& base, const Residuals* final_) const;

 private:
  std::vector<LaserPose> laserPoses(const RunOut& run) const;
  std::vector<LaserPose> smoothed(const std::vector<LaserPose>& lp, const RunOut& run, const typename En::M& model,
                                  const typename En::M::StateVec& x) const;

  const En& en_;
  const DiagnoseOptions& opt_;
};

/// DIR/discovery_motion.csv and DIR/discovery_beam.csv: the rows of each design (beams:
/// every 8th) with the response, the selected terms' fit, each selected term's column
/// and its partial residual (the response less the other terms' part), for the report's
/// plots against the features. Both in standardised units.
bool writeDiscoveryCsv(const std::string& dir, const Residuals& r, std::string* error);

/// The structured misfit of a design: its cross-validated SSE with the nuisance columns
/// only, less that with the terms selected in `base` (in the same standardised units).
double structuredMisfit(const Selection& base);

/// The "unexplained" object of the contract: the features left in `final_` (the model with
/// the named effects), and the share of the baseline's structured misfit that the named
/// effects explain (null when the baseline shows none).
nlohmann::ordered_json unexplainedJson(const Residuals& base, const Residuals& final_, bool named);

/// The share of `base`'s structured misfit that a model's residuals `with` no longer have,
/// per design and together: {"motion": x|null, "beam": x|null, "total": x|null}.
nlohmann::ordered_json explainedBy(const Residuals& base, const Residuals& with);

extern template class Discovery<Engine<SyncDrive>>;
extern template class Discovery<Engine<DiffDrive>>;
extern template class Discovery<Engine<SyncDrive, Featured>>;
extern template class Discovery<Engine<DiffDrive, Featured>>;

}  // namespace odoerr::sim::diag
