// One full filter cycle (AKF predict, 36 sequential scalar beam updates, OF step) in float
// and double, beside a textbook batch EKF of the same cycle (dynamic-size Eigen matrices,
// one 36x36 LDLT solve). The inputs are a recorded closed-loop drive of the paper's
// experiment, replayed cyclically. After the run the batch/sequential ratios are printed.
//
//   build/host/bench/bench_cycle [--benchmark_repetitions=5]
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "odoerr/sim/runner.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

template <template <typename> class DriveT>
struct Recording {
  std::vector<SimStep<DriveT<double>>> steps;
  static const Recording& get() {
    static const Recording rec = [] {
      Recording r;
      SimConfig cfg;
      FilterSetup setup;
      (void)runDrive<double, DriveT>(cfg, 77, NonSysStart::kLarge, setup, cfg.steps,
                                     [&r](const SimStep<DriveT<double>>& s) { r.steps.push_back(s); });
      return r;
    }();
    return rec;
  }
};

template <typename S, template <typename> class DriveT>
typename DriveT<S>::Input toInput(const SimStep<DriveT<double>>& s) {
  return convertInput<typename DriveT<S>::Input>(s.input);
}

template <typename S, template <typename> class DriveT>
void BM_FullCycle(benchmark::State& state) {
  const auto& rec = Recording<DriveT>::get();
  SimConfig cfg;
  FilterSetup setup;
  PaperSim<DriveT<double>> sim(cfg, 77);
  const auto fresh = makeEstimator<S, DriveT>(sim, setup, NonSysStart::kLarge);
  auto est = fresh;
  std::vector<std::array<S, kMaxBeams>> ranges(rec.steps.size());
  for (std::size_t k = 0; k < rec.steps.size(); ++k) {
    for (int i = 0; i < 36; ++i) ranges[k][i] = S(rec.steps[k].ranges[i]);
  }
  std::size_t k = 0;
  for (auto _ : state) {
    auto res = est.cycle(toInput<S, DriveT>(rec.steps[k]), ranges[k].data());
    benchmark::DoNotOptimize(res);
    if (++k == rec.steps.size()) {
      k = 0;
      est = fresh;  // restart the drive (rare: once per 3000 cycles)
    }
  }
  state.counters["beams_per_cycle"] =
      double(est.akf().counters().beams_used) / double(est.akf().counters().predictions);
}

/// Textbook EKF of the same cycle: dynamic-size matrices, all beams stacked, one solve.
template <typename S, template <typename> class DriveT>
void BM_BatchTextbook(benchmark::State& state) {
  using M = Model<DriveT<S>>;
  using AkfT = Akf<M>;
  using MatX = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;
  using VecX = Eigen::Matrix<S, Eigen::Dynamic, 1>;
  const auto& rec = Recording<DriveT>::get();
  SimConfig cfg;
  FilterSetup setup;
  PaperSim<DriveT<double>> sim(cfg, 77);
  const auto fresh = makeEstimator<S, DriveT>(sim, setup, NonSysStart::kLarge);
  const auto& model = fresh.akf().model();
  const auto& map = fresh.map();
  const auto laser = fresh.laser();
  // The batch filter has no OF: it gets the true K (the recording's start is 100x above).
  const typename M::NonSysVec k_ns = fresh.of().estimate() / S(100);
  const int n = M::kStates;
  const VecX x0 = fresh.akf().state();
  const MatX p0 = fresh.akf().covariance();
  VecX x = x0;
  MatX p = p0;
  std::size_t k = 0;
  double fused = 0;
  for (auto _ : state) {
    const auto& st = rec.steps[k];
    const auto u = toInput<S, DriveT>(st);
    // Predict.
    typename M::StateVec xs = x;
    Eigen::Matrix<S, 3, M::kStates> f_pose;
    Eigen::Matrix<S, 3, M::kNoise> g_pose;
    const Pose<S> next = AkfT::transition(model, xs, u, &f_pose, &g_pose);
    MatX f = MatX::Identity(n, n);
    f.topRows(3) = f_pose;
    MatX g = MatX::Zero(n, M::kNoise);
    g.topRows(3) = g_pose;
    const auto q = model.drive.noiseVariance(u, k_ns);
    p = f * p * f.transpose() + g * q.asDiagonal() * g.transpose();
    x[0] = next.x;
    x[1] = next.y;
    x[2] = next.theta;
    // Batch update of all valid beams at the predicted state.
    MatX h = MatX::Zero(laser.beams(), n);
    VecX nu = VecX::Zero(laser.beams());
    int m = 0;
    const Pose<S> pp{x[0], x[1], x[2]};
    for (int i = 0; i < laser.beams(); ++i) {
      const S z = S(st.ranges[i]);
      if (!std::isfinite(z)) continue;
      S r = 0;
      Eigen::Matrix<S, 1, 3> hi;
      if (AkfT::expectedRange(map, laser, pp, i, setup.akf.max_incidence_rad, &r, &hi) != Status::kOk) continue;
      // The same 5-sigma gate as the sequential filter, on the prior innovation variance.
      const S var_i = hi * p.topLeftCorner(3, 3) * hi.transpose() + laser.config().sigma * laser.config().sigma;
      if (!((z - r) * (z - r) <= S(25) * var_i)) continue;
      h.block(m, 0, 1, 3) = hi;
      nu[m] = z - r;
      ++m;
    }
    fused += m;
    const MatX hm = h.topRows(m);
    const MatX s = hm * p * hm.transpose() + MatX::Identity(m, m) * (laser.config().sigma * laser.config().sigma);
    const Eigen::LDLT<MatX> ldlt(s);
    const MatX kt = ldlt.solve(hm * p);  // K^T = S^-1 H P
    x += kt.transpose() * nu.head(m);
    p -= kt.transpose() * (hm * p);
    benchmark::DoNotOptimize(x.data());
    if (++k == rec.steps.size()) {
      k = 0;
      x = x0;
      p = p0;
    }
  }
  state.counters["beams_per_cycle"] = fused / double(state.iterations());
}

BENCHMARK_TEMPLATE(BM_FullCycle, float, SyncDrive);
BENCHMARK_TEMPLATE(BM_FullCycle, double, SyncDrive);
BENCHMARK_TEMPLATE(BM_BatchTextbook, float, SyncDrive);
BENCHMARK_TEMPLATE(BM_BatchTextbook, double, SyncDrive);
BENCHMARK_TEMPLATE(BM_FullCycle, float, DiffDrive);
BENCHMARK_TEMPLATE(BM_FullCycle, double, DiffDrive);
BENCHMARK_TEMPLATE(BM_BatchTextbook, float, DiffDrive);
BENCHMARK_TEMPLATE(BM_BatchTextbook, double, DiffDrive);

/// Console output plus a closing table of batch/sequential time ratios.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.run_type == Run::RT_Iteration || r.aggregate_name == "mean") {
        times_[r.run_name.function_name + "<" + r.run_name.args + ">"] = r.GetAdjustedCPUTime();
        std::string name = r.benchmark_name();
        times_[name] = r.GetAdjustedCPUTime();
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    std::printf("\nbatch textbook EKF / full sequential cycle (CPU time ratio):\n");
    for (const char* d : {"SyncDrive", "DiffDrive"}) {
      for (const char* s : {"float", "double"}) {
        const std::string seq = std::string("BM_FullCycle<") + s + ", " + d + ">";
        const std::string bat = std::string("BM_BatchTextbook<") + s + ", " + d + ">";
        const double a = find(seq), b = find(bat);
        if (a > 0 && b > 0) std::printf("  %-6s %-9s %6.1fx  (%.0f ns vs %.0f ns)\n", s, d, b / a, b, a);
      }
    }
  }

 private:
  double find(const std::string& prefix) const {
    for (const auto& [k, v] : times_) {
      if (k.rfind(prefix, 0) == 0) return v;
    }
    return 0;
  }
  std::map<std::string, double> times_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
