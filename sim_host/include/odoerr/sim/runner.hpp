// sim_host: one closed-loop drive of the paper's experiment (simulator + estimator), with a
// trace of the estimates against the truth, and an optional odolog recording of the drive.
#pragma once

#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "odoerr/estimator.hpp"
#include "odoerr/k_ml_driver.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/sim/paper_sim.hpp"

namespace odoerr::sim {

/// Initial non-systematic estimate relative to the truth (the paper: 100x below or above).
enum class NonSysStart { kSmall, kLarge };

inline const char* toString(NonSysStart s) { return s == NonSysStart::kSmall ? "small" : "large"; }

/// The non-systematic estimator: the paper's Observable Filter, or the recursive maximum
/// likelihood of K from the AKF's innovations (core/include/odoerr/k_ml.hpp).
enum class OfKind { kPaper, kMl };

inline const char* toString(OfKind k) { return k == OfKind::kPaper ? "paper" : "ml"; }
/// The ML recursion's forms as --ml-form and summary.json name them, in KMlForm's order.
inline constexpr const char* kKMlFormNames[] = {"pose", "scan", "beam"};
inline const char* toString(KMlForm f) { return kKMlFormNames[static_cast<int>(f)]; }
/// The form named `name`; false when none is.
inline bool parseKMlForm(const std::string& name, KMlForm* f) {
  for (int i = 0; i < 3; ++i) {
    if (name == kKMlFormNames[i]) {
      *f = static_cast<KMlForm>(i);
      return true;
    }
  }
  return false;
}

/// MlDriver (the AKF driven by the recursive ML estimator of K) lives in the core
/// (odoerr/k_ml_driver.hpp), so that the firmware image can measure it too.
using odoerr::MlDriver;

/// The filter's priors and options, shared with the firmware (fw/paper_setup.hpp).
using FilterSetup = fw::FilterSetup;

/// Layout of one trace record: systematic params, non-systematic params, their sigmas, and
/// the pose error against the truth.
template <typename Drive>
struct TraceLayout {
  static constexpr int kP = Drive::kParams;
  static constexpr int kM = Drive::kNonSys;
  static constexpr int kValue = 0;                 // kP + kM values
  static constexpr int kSigma = kP + kM;           // kP + kM sigmas
  static constexpr int kPosErr = 2 * (kP + kM);    // |p - p_true| (m)
  static constexpr int kHeadErr = kPosErr + 1;     // |theta - theta_true| (rad)
  static constexpr int kPosSigma = kPosErr + 2;    // sqrt(Pxx + Pyy)
  static constexpr int kHeadSigma = kPosErr + 3;   // sqrt(Ptt)
  static constexpr int kSize = kPosErr + 4;
};

struct Trace {
  std::vector<double> distance_m;  ///< per record
  std::vector<double> values;      ///< records x layout size, row-major
  int width = 0;
  std::uint32_t beams_used = 0, gated = 0, grazing = 0, too_close = 0, no_return = 0, rejected = 0;
  std::uint32_t of_updates = 0, of_rejected = 0, of_clamped = 0;
};

/// Receives every simulated cycle (for odolog recording). Optional.
template <typename Drive>
using StepSink = std::function<void(const SimStep<Drive>&)>;

/// Builds the estimator for a simulator: the simulator's room and laser, the paper's
/// priors, the non-systematic estimate started 100x below or above the simulated truth.
template <typename S, template <typename> class DriveT>
typename fw::PaperTypes<S, DriveT>::EstimatorT makeEstimator(const PaperSim<DriveT<double>>& sim,
                                                    const FilterSetup& setup, NonSysStart start) {
  FilterSetup s = setup;
  s.laser = sim.config().laser;
  s.room_m = sim.config().room;
  s.wheelbase_m = sim.config().wheelbase_m;
  const double f = start == NonSysStart::kSmall ? setup.nonsys_factor_small : setup.nonsys_factor_large;
  const typename DriveT<S>::NonSysVec k0 = (sim.trueNonSys() * f).template cast<S>();
  return fw::makePaperEstimator<S, DriveT>(s, sim.initialEstimate(), k0);
}

/// Runs one closed-loop drive, recording every `record_every` cycles (and at the end).
template <typename S, template <typename> class DriveT>
Trace runDrive(const SimConfig& cfg, std::uint64_t seed, NonSysStart start, const FilterSetup& setup,
               int record_every, const StepSink<DriveT<double>>& sink = nullptr,
               OfKind of_kind = OfKind::kPaper, const KMlConfig<S>& ml_cfg = {}) {
  using SimDrive = DriveT<double>;
  using L = TraceLayout<SimDrive>;
  PaperSim<SimDrive> sim(cfg, seed);
  auto est = makeEstimator<S, DriveT>(sim, setup, start);
  using Est = decltype(est);
  const bool use_ml = of_kind == OfKind::kMl;
  MlDriver<Est> ml(est, ml_cfg);
  auto akfNow = [&]() -> const typename Est::AkfT& { return use_ml ? ml.akf() : est.akf(); };
  constexpr int kP = SimDrive::kParams;
  constexpr int kM = SimDrive::kNonSys;

  Trace tr;
  tr.width = L::kSize;
  auto record = [&](double dist) {
    const auto& x = akfNow().state();
    const auto& p = akfNow().covariance();
    const auto k = use_ml ? ml.ml().estimate() : est.of().estimate();
    const auto pk = use_ml ? ml.ml().covarianceWithSystematic(x, p) : est.of().covariance();
    tr.distance_m.push_back(dist);
    const std::size_t base = tr.values.size();
    tr.values.resize(base + L::kSize);
    double* row = tr.values.data() + base;
    for (int i = 0; i < kP; ++i) {
      row[L::kValue + i] = double(x[Est::Model::kDriveOffset + i]);
      row[L::kSigma + i] = std::sqrt(double(p(Est::Model::kDriveOffset + i, Est::Model::kDriveOffset + i)));
    }
    for (int i = 0; i < kM; ++i) {
      row[L::kValue + kP + i] = double(k[i]);
      row[L::kSigma + kP + i] = std::sqrt(double(pk(i, i)));
    }
    const Pose<double> t = sim.truth();
    row[L::kPosErr] = std::hypot(double(x[0]) - t.x, double(x[1]) - t.y);
    row[L::kHeadErr] = std::abs(wrapAngle(double(x[2]) - t.theta));
    row[L::kPosSigma] = std::sqrt(double(p(0, 0) + p(1, 1)));
    row[L::kHeadSigma] = std::sqrt(double(p(2, 2)));
  };
  record(0.0);
  std::array<S, kMaxBeams> ranges{};
  for (int k = 1; k <= cfg.steps; ++k) {
    const auto& x = akfNow().state();
    const Pose<double> pe{double(x[0]), double(x[1]), double(x[2])};
    typename SimDrive::ParamVec pp;
    for (int i = 0; i < kP; ++i) pp[i] = double(x[Est::Model::kDriveOffset + i]);
    const SimStep<SimDrive> st = sim.step(pe, pp);
    if (sink) sink(st);
    const auto u = convertInput<typename Est::Input>(st.input);
    for (int i = 0; i < cfg.laser.beams; ++i) ranges[i] = S(st.ranges[i]);
    if (use_ml) {
      ml.cycle(u, ranges.data());
    } else {
      (void)est.cycle(u, ranges.data());
    }
    if (k % record_every == 0 || k == cfg.steps) record(k * cfg.step_m);
  }
  const auto& c = akfNow().counters();
  tr.beams_used = c.beams_used;
  tr.gated = c.gated;
  tr.grazing = c.grazing;
  tr.too_close = c.too_close;
  tr.no_return = c.no_return + c.no_map_hit;
  tr.rejected = c.bad_innovation + c.bad_covariance + c.bad_inputs + c.bad_predictions;
  if (use_ml) {
    tr.of_updates = ml.ml().counters().steps;
    tr.of_rejected = ml.ml().counters().skipped;
    tr.of_clamped = ml.ml().counters().clipped;
  } else {
    tr.of_updates = est.of().counters().updates;
    tr.of_rejected = est.of().counters().rejected;
    tr.of_clamped = est.of().counters().clamped;
  }
  return tr;
}

}  // namespace odoerr::sim
