// The recursive maximum-likelihood estimator of K (core/include/odoerr/k_ml.hpp): its score
// against central differences of the AKF's innovation log-likelihood on a recorded drive.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "odoerr/sim/runner.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

template <template <typename> class DriveT>
void checkScore(double tol) {
  using D = DriveT<double>;
  SimConfig cfg;
  cfg.steps = 200;  // 2 m
  FilterSetup setup;
  std::vector<SimStep<D>> steps;
  StepSink<D> sink = [&steps](const SimStep<D>& st) { steps.push_back(st); };
  (void)runDrive<double, DriveT>(cfg, 7, NonSysStart::kSmall, setup, cfg.steps, sink);
  ASSERT_EQ(int(steps.size()), cfg.steps);
  PaperSim<D> sim(cfg, 7);
  const typename D::NonSysVec k_true = sim.trueNonSys();
  KMlConfig<double> mc;
  mc.every = 1 << 30;  // never steps: K stays where it is set, the score accumulates
  auto replay = [&](const typename D::NonSysVec& k, double* ll, typename D::NonSysVec* score, int* used) {
    auto est = makeEstimator<double, DriveT>(sim, setup, NonSysStart::kSmall);
    MlDriver<decltype(est)> drv(est, mc);
    drv.restartK(k);
    std::vector<double> ranges(std::size_t(kMaxBeams), 0.0);
    for (const auto& st : steps) {
      const auto u = convertInput<typename decltype(est)::Input>(st.input);
      for (int i = 0; i < cfg.laser.beams; ++i) ranges[std::size_t(i)] = st.ranges[std::size_t(i)];
      drv.cycle(u, ranges.data());
    }
    *ll = drv.logLikelihood();
    *score = drv.ml().blockScore();
    *used = int(drv.akf().counters().beams_used);
  };
  double ll0 = 0;
  typename D::NonSysVec score;
  int used0 = 0;
  replay(k_true, &ll0, &score, &used0);
  ASSERT_GT(used0, 1000);
  const double eps = 1e-3;
  for (int i = 0; i < D::kNonSys; ++i) {
    typename D::NonSysVec kp = k_true, km = k_true, dummy;
    kp[i] *= 1 + eps;
    km[i] *= 1 - eps;
    double llp = 0, llm = 0;
    int up = 0, um = 0;
    replay(kp, &llp, &dummy, &up);
    replay(km, &llm, &dummy, &um);
    ASSERT_EQ(up, used0) << "the fused beams changed with K: the difference is not a derivative";
    ASSERT_EQ(um, used0);
    const double fd = (llp - llm) / (2 * eps * k_true[i]);
    std::printf("score[%d] recursion %.6g  central difference %.6g  (rel %.3g)\n", i, score[i], fd,
                std::abs(score[i] - fd) / std::abs(fd));
    EXPECT_NEAR(score[i], fd, tol * std::abs(fd)) << "K index " << i;
  }
}

}  // namespace

TEST(KMl, ScoreMatchesFiniteDifferenceSync) { checkScore<SyncDrive>(0.05); }
TEST(KMl, ScoreMatchesFiniteDifferenceDiff) { checkScore<DiffDrive>(0.05); }
