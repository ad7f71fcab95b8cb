// diagnose, what a filter run over a log is made of: the model's catalogue with the feature
// effects (a discovery's slots), the effects' descriptions, what a run records of its
// held-out predictions and posteriors, and the run's mode. Engine (engine.hpp) runs it.
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

#include "odoerr/effects/catalogue.hpp"
#include "odoerr/effects/feature_effects.hpp"
#include "odoerr/estimator.hpp"

namespace odoerr::sim::diag {

using effects::Catalogue;

/// The catalogue and the feature effects: the model of `--with feature:...` and `--with auto`.
using FeatureMotionE = effects::FeatureMotion<4>;
using FeatureRangeE = effects::FeatureRange<4>;
using Featured = typename effects::TupleCat<Catalogue, std::tuple<FeatureMotionE, FeatureRangeE>>::type;

/// The feature effects' slots (a discovery put into the model): at most 4 of each.
struct FeatureSlots {
  struct Motion {
    effects::MotionFeature f;
    effects::MotionTarget t;
    double prior, ref;
  };
  struct Beam {
    effects::BeamFeature f;
    double prior, ref;
  };
  std::vector<Motion> motion;
  std::vector<Beam> beam;
  double t_change = std::numeric_limits<double>::infinity();  ///< t_c of the step features (log time, s)
  static constexpr std::size_t kMax = 4;
  bool empty() const { return motion.empty() && beam.empty(); }
};

template <typename D, typename Tuple>
struct ModelOf;
template <typename D, typename... E>
struct ModelOf<D, std::tuple<E...>> {
  using type = Model<D, E...>;
};

constexpr double kCap = 25.0;     // NIS cap of one innovation in the likelihood (= the gate)
constexpr double kHeld = 0.0;     // prior sigma of a parameter held at a value (exactly constant)
/// The coarse grid of a noise effect's profile, in units of its reference size.
constexpr double kNoiseGrid[4] = {0.0, 0.5, 2.0, 8.0};

struct EffectInfo {
  std::string name, description;
  EffectKind kind;
  int offset, n;
  std::vector<double> prior, ref;
  std::vector<std::string> pnames;
};

/// One predicted (not fused) held-out measurement in a run: its time and the predicting
/// copy's pose error against truth (NaN without truth).
struct HeldEvent {
  double t, pose_err;
};

/// The same after the comparison: with the NIS and negative log-likelihood per degree of
/// freedom over the beams that both runs predicted.
struct HeldScan {
  double t, nis, nll, pose_err;
};

/// One beam (or pose fix) of a predicted held-out measurement. Before and after are
/// compared on the beams both predicted (matched by key), so that a model cannot improve
/// its mean by leaving hard beams unpredicted.
struct HeldBeam {
  long long key;  ///< scan * 64 + beam; a pose fix: -(index + 1)
  int scan;       ///< its HeldEvent in the run
  double nis, nll, nu2;
  bool ok;        ///< predicted (a variance and a wall)
  bool inside;    ///< inside the gate (its innovation counts in the innovation RMS)
};

/// The filter's pose after fusing a measurement (a scan or a pose fix), for the residuals
/// of discovery: the event it belongs to, the posterior pose, speed and turn rate.
struct PostPose {
  int event;
  double t, x, y, th, v, w;
};

/// A beam predicted at the posterior of its scan (the filter's residual after the fusion).
struct PostBeam {
  int post;   ///< its PostPose
  int beam;
  double nu;  ///< measured - predicted at the posterior (measurement effects included)
};

enum class Mode { kFull, kFit, kEval };

}  // namespace odoerr::sim::diag
