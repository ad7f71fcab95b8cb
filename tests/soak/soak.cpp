// The float32 soak: see soak.hpp and docs/reliability.md, "Float32 soak".
#include "soak.hpp"

#include <Eigen/Eigenvalues>
#include <boost/math/distributions/chi_squared.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include <vector>

#include "odoerr/sim/runner.hpp"
#include "odoerr/sim/random.hpp"

namespace odoerr::soak {
namespace {

/// Chi-square quantile with k degrees of freedom (Boost.Math).
double chiSquareQuantile(double p, int k) {
  const boost::math::chi_squared_distribution<double> d(k);
  return boost::math::quantile(d, p);
}

template <template <typename> class DriveT>
SoakResult run(const SoakOptions& o, const char* name) {
  using D = DriveT<double>;
  using S = float;
  sim::SimConfig cfg;
  cfg.radius = o.radius_m;
  sim::PaperSim<D> world(cfg, o.seed);
  fw::FilterSetup setup;
  setup.laser = cfg.laser;
  setup.room_m = cfg.room;
  setup.wheelbase_m = cfg.wheelbase_m;
  const double kf = o.k_start_truth ? 1.0 : setup.nonsys_factor_small;
  const typename DriveT<S>::NonSysVec k0 = (world.trueNonSys() * kf).template cast<S>();
  auto est = fw::makePaperEstimator<S, DriveT>(setup, world.initialEstimate(), k0);
  using Est = decltype(est);
  using Akf = typename Est::AkfT;
  constexpr int N = Est::Model::kStates;
  constexpr int kP = D::kParams;
  using MatD = Eigen::Matrix<double, N, N>;
  using VecD = Eigen::Matrix<double, N, 1>;

  SoakResult r;
  r.drive = name;
  r.states = N;
  // A window's mean NEES against the band of ONE sample of chi2(N) (two-sided 99.8 %): the
  // parameter errors are correlated over thousands of cycles, so a window holds few
  // independent samples and its mean is at least as concentrated as a single one.
  r.nees_lo = chiSquareQuantile(0.001, N);
  r.nees_hi = chiSquareQuantile(0.999, N);

  std::mt19937_64 rng(o.seed ^ 0x50A4ull);
  odoerr::sim::UniformDist<double> u01(0.0, 1.0);
  const int beams = cfg.laser.beams;
  std::vector<S> ranges(static_cast<std::size_t>(beams));
  std::vector<int> kind(static_cast<std::size_t>(beams));  // 0 clean, 1 no return, 2 outlier
  int burst_left = 0, burst_first = 0, burst_n = 0;
  double nees_sum = 0, win_sum = 0, pos2_sum = 0;
  long win_n = 0;
  Eigen::SelfAdjointEigenSolver<MatD> eig;
  const auto t0 = std::chrono::steady_clock::now();

  auto observe = [&](const typename Akf::BeamRecord& b) {
    const int k = kind[static_cast<std::size_t>(b.beam)];
    if (k == 1) {
      if (b.status == Status::kNoReturn) ++r.nan_counted_no_return;
    } else if (k == 2) {
      if (b.status == Status::kGated) {
        ++r.outliers_gated;
      } else if (b.status == Status::kOk) {
        ++r.outliers_accepted;
      } else {
        ++r.outliers_other_refusal;
      }
    } else if (b.status == Status::kGated) {
      ++r.clean_gated;
    }
  };

  for (long c = 1; c <= o.cycles; ++c) {
    const auto& x = est.akf().state();
    const Pose<double> pe{double(x[0]), double(x[1]), double(x[2])};
    typename D::ParamVec pp;
    for (int i = 0; i < kP; ++i) pp[i] = double(x[Est::Model::kDriveOffset + i]);
    const sim::SimStep<D> st = world.step(pe, pp);
    const auto u = convertInput<typename Est::Input>(st.input);

    // Faults of this cycle's scan.
    const bool dropped = u01(rng) < o.scan_drop_p;
    if (burst_left == 0 && u01(rng) < o.burst_start_p) {
      burst_left = o.burst_cycles_min + int(u01(rng) * (o.burst_cycles_max - o.burst_cycles_min + 1));
      burst_n = o.burst_beams_min + int(u01(rng) * (o.burst_beams_max - o.burst_beams_min + 1));
      burst_first = int(u01(rng) * beams);
      ++r.bursts;
    }
    const S* scan = nullptr;
    if (dropped) {
      ++r.scans_dropped;
    } else {
      ++r.scans_offered;
      for (int i = 0; i < beams; ++i) {
        auto& ki = kind[static_cast<std::size_t>(i)];
        ki = 0;
        double v = st.ranges[static_cast<std::size_t>(i)];
        const int off = (i - burst_first + beams) % beams;
        if (burst_left > 0 && off < burst_n && std::isfinite(v) && v > o.outlier_margin_m + 0.1) {
          // at least outlier_margin_m short: never within the gate of a consistent filter
          v = std::min(v * (o.outlier_min + (o.outlier_max - o.outlier_min) * u01(rng)), v - o.outlier_margin_m);
          ki = 2;
          ++r.outliers_injected;
        } else if (u01(rng) < o.beam_nan_p) {
          // the ways a range finder says "no return"
          const double pick = u01(rng);
          v = pick < 0.4 ? std::nan("") : pick < 0.6 ? 0.0 : pick < 0.8 ? -1.0 : 1e9;
          ki = 1;
          ++r.beams_nan_injected;
        }
        ranges[static_cast<std::size_t>(i)] = S(v);
      }
      scan = ranges.data();
      r.beams_offered += est.laser().used();
    }
    if (burst_left > 0) --burst_left;
    (void)est.cycle(u, scan, observe);

    // Covariance: symmetric, positive definite, bounded.
    const MatD p = est.akf().covariance().template cast<double>();
    r.max_asymmetry = std::max(r.max_asymmetry, (p - p.transpose()).cwiseAbs().maxCoeff());
    if (!p.allFinite()) {
      ++r.non_pd_cycles;
      continue;
    }
    eig.compute(p, Eigen::EigenvaluesOnly);
    const double lmin = eig.eigenvalues()[0];
    const double lmax = eig.eigenvalues()[N - 1];
    if (!(lmin > 0)) ++r.non_pd_cycles;
    if (lmin < r.min_eigenvalue) {
      r.min_eigenvalue = lmin;
      r.min_eig_cycle = c;
    }
    r.max_eigenvalue = std::max(r.max_eigenvalue, lmax);
    if (lmin > 0 && lmax / lmin > r.worst_condition) {
      r.worst_condition = lmax / lmin;
      r.worst_cond_cycle = c;
    }
    const VecD dinv = p.diagonal().cwiseSqrt().cwiseInverse();
    const MatD corr = dinv.asDiagonal() * p * dinv.asDiagonal();
    eig.compute(corr, Eigen::EigenvaluesOnly);
    if (eig.eigenvalues()[0] > 0) {
      r.worst_corr_condition = std::max(r.worst_corr_condition, eig.eigenvalues()[N - 1] / eig.eigenvalues()[0]);
    }

    // NEES of pose + systematic parameters against the truth.
    const Pose<double> t = world.truth();
    VecD e = VecD::Zero();
    e[0] = double(est.akf().state()[0]) - t.x;
    e[1] = double(est.akf().state()[1]) - t.y;
    e[2] = wrapAngle(double(est.akf().state()[2]) - t.theta);
    const auto tp = world.trueParams();
    for (int i = 0; i < kP; ++i) e[3 + i] = double(est.akf().state()[Est::Model::kDriveOffset + i]) - tp[i];
    const double nees = e.dot(p.ldlt().solve(e));
    nees_sum += nees;
    win_sum += nees;
    pos2_sum += e[0] * e[0] + e[1] * e[1];
    if (++win_n == o.nees_window) {
      const double m = win_sum / double(win_n);
      ++r.nees_windows;
      if (!(m >= r.nees_lo && m <= r.nees_hi)) ++r.nees_windows_out;
      r.nees_window_min = std::min(r.nees_window_min, m);
      r.nees_window_max = std::max(r.nees_window_max, m);
      win_sum = 0;
      win_n = 0;
    }
    r.final_pos_err_m = std::hypot(e[0], e[1]);
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cycles = o.cycles;
  r.nees_mean = o.cycles > 0 ? nees_sum / double(o.cycles) : 0.0;
  r.pose_rms_m = o.cycles > 0 ? std::sqrt(pos2_sum / double(o.cycles)) : 0.0;
  const auto& ac = est.akf().counters();
  r.beams_used = ac.beams_used;
  r.no_return = ac.no_return;
  r.no_map_hit = ac.no_map_hit;
  r.grazing = ac.grazing;
  r.too_close = ac.too_close;
  r.gated = ac.gated;
  r.bad_innovation = ac.bad_innovation;
  r.bad_covariance = ac.bad_covariance;
  r.bad_inputs = ac.bad_inputs;
  r.bad_predictions = ac.bad_predictions;
  r.predictions = ac.predictions;
  r.of_updates = est.of().counters().updates;
  r.of_rejected = est.of().counters().rejected;
  r.of_clamped = est.of().counters().clamped;
  return r;
}

void fail(std::ostringstream& os, bool bad, const std::string& what) {
  if (bad) os << what << "\n";
}

}  // namespace

SoakResult runSync(const SoakOptions& o) { return run<SyncDrive>(o, "sync"); }
SoakResult runDiff(const SoakOptions& o) { return run<DiffDrive>(o, "diff"); }

std::string checkResult(const SoakResult& r) {
  std::ostringstream os;
  const std::string d = r.drive + ": ";
  fail(os, r.cycles <= 0, d + "no cycles run");
  fail(os, r.max_asymmetry != 0.0, d + "P not symmetric: max |P - P^T| = " + std::to_string(r.max_asymmetry));
  fail(os, r.non_pd_cycles != 0, d + std::to_string(r.non_pd_cycles) + " cycles with P not positive definite");
  fail(os, !(r.min_eigenvalue > 0), d + "smallest eigenvalue of P not above 0");
  // Bounded: no variance beyond the prior's scale (0.2^2 for the scale factors; the pose's
  // is far smaller in a room the laser sees).
  fail(os, !(r.max_eigenvalue < 0.1), d + "largest eigenvalue of P above 0.1: " + std::to_string(r.max_eigenvalue));
  // Every beam offered is accounted for by exactly one outcome.
  const long outcomes = r.beams_used + r.no_return + r.no_map_hit + r.grazing + r.too_close + r.gated + r.bad_innovation +
                        r.bad_covariance;
  fail(os, outcomes != r.beams_offered,
       d + "beams offered " + std::to_string(r.beams_offered) + " != outcomes counted " + std::to_string(outcomes));
  fail(os, r.nan_counted_no_return != r.beams_nan_injected,
       d + "no-return beams injected " + std::to_string(r.beams_nan_injected) + ", counted " +
           std::to_string(r.nan_counted_no_return));
  fail(os, r.outliers_injected == 0 || r.beams_nan_injected == 0 || r.scans_dropped == 0,
       d + "a fault kind was never injected");
  fail(os, r.outliers_accepted != 0, d + std::to_string(r.outliers_accepted) + " outlier beams fused");
  fail(os, r.outliers_gated + r.outliers_other_refusal + r.outliers_accepted != r.outliers_injected,
       d + "outliers not all accounted for");
  fail(os, r.gated != r.outliers_gated + r.clean_gated, d + "gate counter != gated outliers + gated clean beams");
  fail(os, r.predictions + r.bad_inputs + r.bad_predictions != r.cycles, d + "predictions do not add up to cycles");
  fail(os, r.bad_inputs + r.bad_predictions + r.bad_innovation + r.bad_covariance != 0,
       d + "numerical refusals in a clean-input run (bad input/prediction/innovation/covariance)");
  fail(os, r.nees_windows == 0, d + "no NEES window completed");
  fail(os, !(r.nees_mean >= r.nees_lo && r.nees_mean <= r.nees_hi), d + "whole-run NEES out of band");
  // A window outside the single-sample band is a 0.2 % event for a consistent filter.
  fail(os, r.nees_windows_out * 100 > r.nees_windows * 2,
       d + std::to_string(r.nees_windows_out) + " of " + std::to_string(r.nees_windows) +
           " NEES windows out of band (more than 2 %)");
  return os.str();
}

std::string toJson(const SoakResult& r) {
  std::ostringstream os;
  os.precision(6);
  os << "{\"drive\": \"" << r.drive << "\", \"states\": " << r.states << ", \"cycles\": " << r.cycles
     << ", \"seconds\": " << r.seconds << ",\n \"injected\": {\"scans_dropped\": " << r.scans_dropped
     << ", \"scans_offered\": " << r.scans_offered << ", \"beams_offered\": " << r.beams_offered
     << ", \"no_return_beams\": " << r.beams_nan_injected << ", \"bursts\": " << r.bursts
     << ", \"outlier_beams\": " << r.outliers_injected << "},\n \"counted\": {\"beams_used\": " << r.beams_used
     << ", \"no_return\": " << r.no_return << ", \"no_map_hit\": " << r.no_map_hit << ", \"grazing\": " << r.grazing << ", \"too_close\": " << r.too_close
     << ", \"gated\": " << r.gated << ", \"bad_innovation\": " << r.bad_innovation
     << ", \"bad_covariance\": " << r.bad_covariance << ", \"bad_inputs\": " << r.bad_inputs
     << ", \"bad_predictions\": " << r.bad_predictions << ", \"predictions\": " << r.predictions
     << ", \"no_return_injected_counted\": " << r.nan_counted_no_return
     << ", \"outliers_gated\": " << r.outliers_gated << ", \"outliers_refused_before_gate\": "
     << r.outliers_other_refusal << ", \"outliers_fused\": " << r.outliers_accepted
     << ", \"clean_beams_gated\": " << r.clean_gated << ", \"of_updates\": " << r.of_updates
     << ", \"of_rejected\": " << r.of_rejected << ", \"of_clamped\": " << r.of_clamped
     << "},\n \"covariance\": {\"max_asymmetry\": " << r.max_asymmetry << ", \"min_eigenvalue\": "
     << r.min_eigenvalue << ", \"min_eigenvalue_cycle\": " << r.min_eig_cycle
     << ", \"max_eigenvalue\": " << r.max_eigenvalue << ", \"worst_condition\": " << r.worst_condition
     << ", \"worst_condition_cycle\": " << r.worst_cond_cycle
     << ", \"worst_correlation_condition\": " << r.worst_corr_condition
     << ", \"non_pd_cycles\": " << r.non_pd_cycles << "},\n \"nees\": {\"mean\": " << r.nees_mean
     << ", \"band\": [" << r.nees_lo << ", " << r.nees_hi << "], \"windows\": " << r.nees_windows
     << ", \"windows_out\": " << r.nees_windows_out << ", \"window_min\": " << r.nees_window_min
     << ", \"window_max\": " << r.nees_window_max << "},\n \"pose_rms_m\": " << r.pose_rms_m
     << ", \"final_pos_err_m\": " << r.final_pos_err_m << "}";
  return os.str();
}

}  // namespace odoerr::soak
