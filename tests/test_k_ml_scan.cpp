// The recursive maximum-likelihood estimator of K (core/include/odoerr/k_ml.hpp): its
// whole-scan update (KMaxLikelihood::scan, k_ml_scan.hpp) on the differential drive's model:
// the sparse pose form against the dense one, the refusals, a blind stretch, a restart and
// the heading noise's prior. Closed-loop behaviour: test_k_ml.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <utility>

#include "odoerr/sim/runner.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

/// The diff model's estimator at its start and a way to carry KMaxLikelihood's sensitivities
/// through a prediction (the Jacobians from Akf::transition), for the scan tests below.
struct DiffScanBench {
  using Est = decltype(makeEstimator<double, DiffDrive>(std::declval<const PaperSim<DiffDrive<double>>&>(),
                                                        std::declval<const FilterSetup&>(), NonSysStart::kSmall));
  using Model = Est::Model;
  using Ml = KMaxLikelihood<Model>;
  static constexpr int N = Model::kStates;
  SimConfig cfg;
  FilterSetup setup;
  PaperSim<DiffDrive<double>> sim{cfg, 5};
  Est est = makeEstimator<double, DiffDrive>(sim, setup, NonSysStart::kSmall);

  static void predict(Ml* ml, const Model& model, const Ml::StateVec& x, const Model::Input& u) {
    Eigen::Matrix<double, 3, N> f;
    Eigen::Matrix<double, 3, Model::kNoise> g;
    (void)Akf<Model>::transition(model, x, u, &f, &g);
    ml->predict<N>(model, u, f, g);
  }
};

/// The scan tests' fixture.
class KMlScan : public ::testing::Test, protected DiffScanBench {};

}  // namespace

// KMaxLikelihood::scan in its sparse form (the beams' rows are non-zero on the pose only: the
// closed-form inverse of the pose block of P) against its dense form (the Cholesky inverse of
// the whole P), both carrying every state's sensitivities, on scans made of scalar pose
// updates: the same score, information and sensitivities.
TEST_F(KMlScan, PoseFormMatchesWholeStateForm) {
  KMlConfig<double> c;
  c.inflate = 0;
  c.every = 1 << 30;
  Ml sparse(c), dense(c);
  sparse.init(sim.trueNonSys());
  dense.init(sim.trueNonSys());
  Ml::StateVec x = est.akf().state();
  Ml::StateMat p = est.akf().covariance();
  std::uint64_t seed = 12345;
  auto uniform = [&seed]() {  // a small LCG: the test needs no particular distribution
    seed = seed * 6364136223846793005ull + 1442695040888963407ull;
    return double(seed >> 11) / double(1ull << 53) - 0.5;
  };
  for (int cycle = 0; cycle < 4; ++cycle) {
    const Model::Input u{0.01 + 0.002 * cycle, 0.011};
    predict(&sparse, est.akf().model(), x, u);
    predict(&dense, est.akf().model(), x, u);
    p.topLeftCorner<3, 3>() += 1e-6 * Eigen::Matrix3d::Identity();  // the prediction's growth
    const Ml::StateMat p_prior = p;
    const Ml::StateVec x_prior = x;
    for (int b = 0; b < 5; ++b) {
      Ml::StateVec h = Ml::StateVec::Zero();
      for (int j = 0; j < 3; ++j) h[j] = uniform();
      const double s = h.dot(p * h) + 1e-4;
      const Ml::StateVec k = p * h / s;
      x += k * (0.01 * uniform());
      p -= k * (p * h).transpose();
      p = (0.5 * (p + p.transpose())).eval();
    }
    const Eigen::Matrix<double, N, 3> p3 = p_prior.leftCols<3>();
    const Eigen::Vector3d x3 = x_prior.head<3>();
    ASSERT_TRUE((sparse.scan<3, N>(p3, x3, p, x)));
    ASSERT_TRUE((dense.scan<N, N>(p_prior, x_prior, p, x)));
    const double g = sparse.blockScore()[0], gd = dense.blockScore()[0];
    const double i0 = sparse.blockInformation()(0, 0), id = dense.blockInformation()(0, 0);
    std::printf("cycle %d: score %.9g / %.9g, information %.9g / %.9g\n", cycle, g, gd, i0, id);
    EXPECT_NEAR(g, gd, 1e-6 * std::abs(gd) + 1e-9) << "cycle " << cycle;
    EXPECT_NEAR(i0, id, 1e-6 * std::abs(id)) << "cycle " << cycle;
    if (cycle > 0) {
      EXPECT_GT(std::abs(gd), 0.0) << "the sensitivities must carry something";
    }
  }
  EXPECT_EQ(sparse.counters().scans, 4u);
}

// A scan whose P before it is not positive definite (a NaN, or a singular pose block) is
// refused and counted, and the sensitivities restart; the score and information stay finite.
TEST_F(KMlScan, RefusesABadCovariance) {
  KMlConfig<double> c;
  c.inflate = 0;
  Ml ml(c);
  ml.init(sim.trueNonSys());
  const Ml::StateVec x = est.akf().state();
  const Ml::StateMat p = est.akf().covariance();
  predict(&ml, est.akf().model(), x, Model::Input{0.01, 0.011});
  Ml::StateMat p_post = p;
  p_post.topLeftCorner<3, 3>() *= 0.5;
  Eigen::Matrix<double, N, 3> bad = p.leftCols<3>();
  bad(1, 1) = std::nan("");
  EXPECT_FALSE((ml.scan<3, 3>(bad, x.head<3>(), p_post, x)));
  Eigen::Matrix<double, N, 3> singular = p.leftCols<3>();
  singular.row(1) = singular.row(0);  // two equal rows: the pose block is singular
  singular(0, 1) = singular(0, 0);
  singular(1, 0) = singular(0, 0);
  singular(1, 1) = singular(0, 0);
  EXPECT_FALSE((ml.scan<3, 3>(singular, x.head<3>(), p_post, x)));
  EXPECT_EQ(ml.counters().scans_skipped, 2u);
  EXPECT_EQ(ml.counters().scans, 0u);
  EXPECT_TRUE(ml.blockScore().allFinite());
  EXPECT_EQ(ml.blockScore()[0], 0.0) << "a refused scan adds nothing";
  // The sensitivities restarted: the next good scan scores nothing (dP and xi are zero).
  EXPECT_TRUE((ml.scan<3, 3>(Eigen::Matrix<double, N, 3>(p.leftCols<3>()), x.head<3>(), p_post, x)));
  EXPECT_EQ(ml.blockScore()[0], 0.0);
  EXPECT_EQ(ml.counters().scans, 1u);
}

// A blind stretch (cycles with no scan taken: no beam the map explains) takes no K step and
// forgets nothing: the information J, K, and the inflated K the AKF predicts with stay as
// they were. Forgetting per step would let sigma, and the AKF's K with it, grow for as long
// as the robot sees nothing (docs/nonsystematic.md: the circle from above, seed 76).
TEST_F(KMlScan, BlindStretchForgetsNothing) {
  KMlConfig<double> c;
  c.every = 1;
  c.inflate = 2;
  c.inflate_offset = 0;  // inflated for any sigma > 0
  Ml ml(c);
  ml.init(sim.trueNonSys());
  const Ml::StateVec x = est.akf().state();
  const Ml::StateMat p = est.akf().covariance();
  Ml::StateMat p_post = p;
  p_post.topLeftCorner<3, 3>() *= 0.5;
  const Model::Input u{0.01, 0.011};
  for (int cycle = 0; cycle < 5; ++cycle) {
    predict(&ml, est.akf().model(), x, u);
    const Eigen::Matrix<double, N, 3> p3 = p.leftCols<3>();
    ASSERT_TRUE((ml.scan<3, 3>(p3, x.head<3>(), p_post, x)));
    (void)ml.endCycle(x, p);
  }
  const auto steps = ml.counters().steps;
  ASSERT_GT(steps, 0u);
  const Ml::KVec k = ml.estimate();
  const Ml::KVec kf = ml.filterK();
  const Ml::KMat cov = ml.covariance();
  ASSERT_GT(kf[0], k[0]) << "the test needs the inflation active";
  for (int cycle = 0; cycle < 50; ++cycle) {
    predict(&ml, est.akf().model(), x, u);
    EXPECT_FALSE(ml.endCycle(x, p));
  }
  EXPECT_EQ(ml.counters().idle, 50u);
  EXPECT_EQ(ml.counters().steps, steps);
  EXPECT_EQ(ml.estimate(), k);
  EXPECT_EQ(ml.filterK(), kf) << "the AKF's K grew while nothing was seen";
  EXPECT_EQ(ml.covariance(), cov);
  // The first scan after the stretch is taken as before.
  predict(&ml, est.akf().model(), x, u);
  const Eigen::Matrix<double, N, 3> p3 = p.leftCols<3>();
  ASSERT_TRUE((ml.scan<3, 3>(p3, x.head<3>(), p_post, x)));
  EXPECT_TRUE(ml.endCycle(x, p));
  EXPECT_EQ(ml.counters().steps, steps + 1);
}

// A restart (log K moved by more than reset_log since the last) scales J by reset_keep: the
// same scan and step with reset_keep 0.3 and 1 leave covariances 1/0.3 apart; with 0 there is
// no information left (covariance() reports 100 %).
TEST_F(KMlScan, RestartKeepsItsShareOfTheInformation) {
  auto run = [&](double keep) {
    KMlConfig<double> c;
    c.every = 1;
    c.inflate = 0;
    c.reset_log = 1e-9;  // any step restarts
    c.reset_keep = keep;
    c.heading_scale = false;  // K alone: c's prior, which a restart leaves whole, would enter covariance()
    Ml ml(c);
    ml.init(sim.trueNonSys());
    const Ml::StateVec x = est.akf().state();
    const Ml::StateMat p = est.akf().covariance();
    Ml::StateMat p_post = p;
    p_post.topLeftCorner<3, 3>() *= 0.5;
    predict(&ml, est.akf().model(), x, Model::Input{0.01, 0.011});
    const Eigen::Matrix<double, N, 3> p3 = p.leftCols<3>();
    EXPECT_TRUE((ml.scan<3, 3>(p3, x.head<3>(), p_post, x)));
    EXPECT_TRUE(ml.endCycle(x, p));
    EXPECT_EQ(ml.counters().resets, 1u);
    return std::make_pair(ml.covariance()(0, 0), ml.estimate()[0]);
  };
  const auto [c1, k1] = run(1.0);
  const auto [c3, k3] = run(0.3);
  const auto [c0, k0] = run(0.0);
  EXPECT_EQ(k3, k1) << "the step itself does not depend on reset_keep";
  EXPECT_NEAR(c3 / c1, 1 / 0.3, 1e-9);
  EXPECT_DOUBLE_EQ(c0, k0 * k0);
}

// The heading noise's scale c takes its prior from the AKF's delta_d at every step; where
// that is not usable (delta_d not finite, or P_dd zero) the step keeps the last prior, and
// before any usable one c starts at 1. K, c and the covariance stay finite and positive.
TEST_F(KMlScan, HeadingScaleKeepsItsPriorWhereDeltaDIsUnusable) {
  KMlConfig<double> c;
  c.every = 1;
  c.heading_scale = true;
  const Ml::StateVec x = est.akf().state();
  const Ml::StateMat p = est.akf().covariance();
  constexpr int kD = Model::kDriveOffset + DiffDrive<double>::kDeltaD;
  Ml::StateVec x_bad = x;
  x_bad[kD] = std::numeric_limits<double>::quiet_NaN();
  Ml::StateMat p_zero = p;
  p_zero(kD, kD) = 0;
  Ml::StateMat p_post = p;
  p_post.topLeftCorner<3, 3>() *= 0.5;
  const Model::Input u{0.01, 0.011};
  auto cycle = [&](Ml* ml, const Ml::StateVec& xs, const Ml::StateMat& ps) {
    predict(ml, est.akf().model(), x, u);
    const Eigen::Matrix<double, N, 3> p3 = p.leftCols<3>();
    ASSERT_TRUE((ml->scan<3, 3>(p3, x.head<3>(), p_post, x)));
    (void)ml->endCycle(xs, ps);
  };
  auto finite = [](const Ml& ml) {
    return ml.estimate().allFinite() && ml.estimate().minCoeff() > 0 && ml.covariance().allFinite() &&
           std::isfinite(ml.noiseDeltaD()) && ml.noiseDeltaD() > 0;
  };
  // Unusable from the first step: c starts at 1 (delta_d 1 as the noise sees it).
  Ml first(c);
  first.init(sim.trueNonSys());
  cycle(&first, x_bad, p);
  ASSERT_EQ(first.counters().steps, 1u);
  EXPECT_TRUE(finite(first));
  EXPECT_NEAR(first.noiseDeltaD(), 1.0, 0.5);
  // Usable, then unusable both ways: the steps go on and nothing turns NaN.
  Ml ml(c);
  ml.init(sim.trueNonSys());
  for (int k = 0; k < 3; ++k) cycle(&ml, x, p);
  ASSERT_TRUE(finite(ml));
  for (int k = 0; k < 3; ++k) cycle(&ml, x_bad, p);
  for (int k = 0; k < 3; ++k) cycle(&ml, x, p_zero);
  EXPECT_EQ(ml.counters().steps, 9u);
  EXPECT_EQ(ml.counters().skipped, 0u);
  EXPECT_TRUE(finite(ml));
}
