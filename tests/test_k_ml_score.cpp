// The recursive maximum-likelihood estimator of K (core/include/odoerr/k_ml.hpp): its score in
// each form (per beam, per whole scan, per whole scan with the pose's sensitivities only)
// against central differences of the AKF's innovation log-likelihood on a recorded drive, for
// K and for the differential drive's heading-noise scale c; the forms' information against
// each other.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "odoerr/sim/runner.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

SimConfig twoMetres() {
  SimConfig cfg;
  cfg.steps = 200;
  return cfg;
}

/// A closed-loop drive of 2 m (seed 7, K from 100x below) recorded once, its simulator, and
/// the ML settings under which the score only accumulates: no K step, the AKF with K itself.
template <template <typename> class DriveT>
struct RecordedDrive {
  using D = DriveT<double>;
  SimConfig cfg = twoMetres();
  FilterSetup setup;
  PaperSim<D> sim{cfg, 7};
  std::vector<SimStep<D>> steps;
  KMlConfig<double> mc;
  RecordedDrive() {
    StepSink<D> sink = [this](const SimStep<D>& st) { steps.push_back(st); };
    (void)runDrive<double, DriveT>(cfg, 7, NonSysStart::kSmall, setup, cfg.steps, sink);
    mc.every = 1 << 30;  // never steps: K stays where it is set, the score accumulates
    mc.inflate = 0;      // the AKF runs with K itself
    mc.reset_log = 0;
  }
};

template <template <typename> class DriveT>
void checkScore(double tol) {
  using D = DriveT<double>;
  RecordedDrive<DriveT> rd;
  const SimConfig& cfg = rd.cfg;
  const FilterSetup& setup = rd.setup;
  const std::vector<SimStep<D>>& steps = rd.steps;
  const PaperSim<D>& sim = rd.sim;
  ASSERT_EQ(int(steps.size()), cfg.steps);
  const typename D::NonSysVec k_true = sim.trueNonSys();
  const KMlConfig<double>& mc = rd.mc;
  using KMat = Eigen::Matrix<double, D::kNonSys, D::kNonSys>;
  KMat info_last = KMat::Zero();
  using Form = KMlForm;
  auto replay = [&](const typename D::NonSysVec& k, double* ll, typename D::NonSysVec* score, int* used,
                    Form form = Form::kBeam) {
    auto est = makeEstimator<double, DriveT>(sim, setup, NonSysStart::kSmall);
    KMlConfig<double> c = mc;
    c.form = form;
    MlDriver<decltype(est)> drv(est, c);
    drv.restartK(k);
    std::vector<double> ranges(std::size_t(kMaxBeams), 0.0);
    for (const auto& st : steps) {
      const auto u = convertInput<typename decltype(est)::Input>(st.input);
      for (int i = 0; i < cfg.laser.beams; ++i) ranges[std::size_t(i)] = st.ranges[std::size_t(i)];
      drv.cycle(u, ranges.data());
    }
    *ll = drv.logLikelihood();
    *score = drv.ml().blockScore().template head<D::kNonSys>();  // K (c, when estimated, follows)
    *used = int(drv.akf().counters().beams_used);
    info_last = drv.ml().blockInformation().template topLeftCorner<D::kNonSys, D::kNonSys>();
  };
  double ll0 = 0;
  typename D::NonSysVec score;
  int used0 = 0;
  replay(k_true, &ll0, &score, &used0);
  ASSERT_GT(used0, 1000);
  const KMat info_beam = info_last;
  double ll_scan = 0;
  typename D::NonSysVec score_scan, score_pose;
  int used_scan = 0;
  replay(k_true, &ll_scan, &score_scan, &used_scan, Form::kScan);
  ASSERT_EQ(used_scan, used0) << "the scan form changed the AKF";
  const KMat info_scan = info_last;
  replay(k_true, &ll_scan, &score_pose, &used_scan, Form::kPose);
  ASSERT_EQ(used_scan, used0) << "the pose form changed the AKF";
  const KMat info_pose = info_last;
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
    std::printf("score[%d] whole scans %.6g  (rel %.3g)\n", i, score_scan[i], std::abs(score_scan[i] - fd) / std::abs(fd));
    EXPECT_NEAR(score[i], fd, tol * std::abs(fd)) << "K index " << i;
    EXPECT_NEAR(score_scan[i], fd, tol * std::abs(fd)) << "K index " << i << " (whole scans)";
    // The pose form leaves out the systematic parameters' sensitivities: its score is another
    // unbiased estimating equation, not the likelihood's derivative. Measured in units of the
    // score's standard deviation (sqrt of the information), it stays close: 0.03-0.07.
    const double sd = std::sqrt(info_beam(i, i));
    std::printf("score[%d] pose form %.6g  (%.3f standard deviations from the central difference)\n", i,
                score_pose[i], std::abs(score_pose[i] - fd) / sd);
    EXPECT_LT(std::abs(score_pose[i] - fd), 0.15 * sd) << "K index " << i << " (pose form)";
    for (int j = 0; j < D::kNonSys; ++j) {
      std::printf("info(%d,%d) per beam %.6g  whole scans %.6g  pose form %.6g\n", i, j, info_beam(i, j),
                  info_scan(i, j), info_pose(i, j));
      EXPECT_NEAR(info_pose(i, j), info_beam(i, j), tol * std::sqrt(info_beam(i, i) * info_beam(j, j)));
      EXPECT_NEAR(info_scan(i, j), info_beam(i, j), tol * std::sqrt(info_beam(i, i) * info_beam(j, j)));
    }
  }
}

/// The differential drive's heading-noise scale c (KMlConfig::heading_scale): the score of
/// log c the recursion carries, in each form, against central differences of the innovation
/// log-likelihood of an AKF whose G has its heading row scaled by sqrt(c) (Akf::predict's
/// observer may rescale it), at c = 1.
void checkHeadingScaleScore(double tol) {
  using D = DiffDrive<double>;
  RecordedDrive<DiffDrive> rd;
  const SimConfig& cfg = rd.cfg;
  const FilterSetup& setup = rd.setup;
  const std::vector<SimStep<D>>& steps = rd.steps;
  const PaperSim<D>& sim = rd.sim;
  ASSERT_EQ(int(steps.size()), cfg.steps);
  const D::NonSysVec k_true = sim.trueNonSys();
  KMlConfig<double> mc = rd.mc;  // the score accumulates at c = 1 (the AKF's own delta_d)
  mc.heading_scale = true;
  std::vector<double> ranges(std::size_t(kMaxBeams), 0.0);
  auto score = [&](KMlForm form, double* info) {
    auto est = makeEstimator<double, DiffDrive>(sim, setup, NonSysStart::kSmall);
    KMlConfig<double> c = mc;
    c.form = form;
    MlDriver<decltype(est)> drv(est, c);
    drv.restartK(k_true);
    for (const auto& st : steps) {
      const auto u = convertInput<decltype(est)::Input>(st.input);
      for (int i = 0; i < cfg.laser.beams; ++i) ranges[std::size_t(i)] = st.ranges[std::size_t(i)];
      drv.cycle(u, ranges.data());
    }
    EXPECT_EQ(drv.ml().blockScore().size(), 2) << "K_w and c";
    *info = drv.ml().blockInformation()(1, 1);
    return drv.ml().blockScore()[1];
  };
  auto logLikelihood = [&](double c, int* used) {
    auto est = makeEstimator<double, DiffDrive>(sim, setup, NonSysStart::kSmall);
    auto akf = est.akf();
    const double f = std::sqrt(c);
    double ll = 0;
    for (const auto& st : steps) {
      const auto u = convertInput<decltype(est)::Input>(st.input);
      auto scale = [f](const auto&, auto& g) { g.row(PoseIdx::kTheta) *= f; };
      if (akf.predict(u, k_true, 0.0, scale) != Status::kOk) continue;
      for (int i = 0; i < cfg.laser.beams; ++i) ranges[std::size_t(i)] = st.ranges[std::size_t(i)];
      auto observe = [&ll](const auto& rec) {
        if (rec.status != Status::kOk) return;
        const double nu = rec.measured - rec.predicted;
        ll += -0.5 * (std::log(rec.variance) + nu * nu / rec.variance);
      };
      (void)akf.updateScan(est.map(), est.laser(), ranges.data(), observe);
    }
    *used = int(akf.counters().beams_used);
    return ll;
  };
  const double eps = 1e-3;
  int up = 0, um = 0, u0 = 0;
  (void)logLikelihood(1.0, &u0);
  const double fd =
      (logLikelihood(1 + eps, &up) - logLikelihood(1 - eps, &um)) / (std::log(1 + eps) - std::log(1 - eps));
  ASSERT_GT(u0, 1000);
  ASSERT_EQ(up, u0) << "the fused beams changed with c: the difference is not a derivative";
  ASSERT_EQ(um, u0);
  double info = 0;
  const double beam = score(KMlForm::kBeam, &info);
  const double sd = std::sqrt(info);
  double unused = 0;
  const double whole = score(KMlForm::kScan, &unused);
  const double pose = score(KMlForm::kPose, &unused);
  std::printf("score of log c: central difference %.6g, per beam %.6g, whole scans %.6g, pose form %.6g "
              "(information %.4g)\n", fd, beam, whole, pose, info);
  EXPECT_NEAR(beam, fd, tol * std::abs(fd));
  EXPECT_NEAR(whole, fd, tol * std::abs(fd));
  EXPECT_LT(std::abs(pose - fd), 0.15 * sd) << "pose form, in units of the score's standard deviation";
}

}  // namespace

TEST(KMl, ScoreMatchesFiniteDifferenceSync) { checkScore<SyncDrive>(0.05); }
TEST(KMl, ScoreMatchesFiniteDifferenceDiff) { checkScore<DiffDrive>(0.05); }
TEST(KMl, HeadingScaleScoreMatchesFiniteDifference) { checkHeadingScaleScore(0.05); }
