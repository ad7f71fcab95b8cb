// Every analytic Jacobian against central finite differences (in long double where the
// code is templated, so the reference is far more precise than the value checked).
#include <gtest/gtest.h>

#include <random>

#include "odoerr/akf.hpp"
#include "odoerr/observables.hpp"
#include "test_support.hpp"
#include "odoerr/sim/random.hpp"

using namespace odoerr;
using LD = long double;

namespace {

template <typename ModelT>
typename ModelT::StateVec randomState(std::mt19937_64& rng, LD theta) {
  odoerr::sim::UniformDist<double> u(-1.0, 1.0);
  typename ModelT::StateVec x;
  ModelT::setNominal(x);
  x[0] = LD(5.0 + 4.0 * u(rng));
  x[1] = LD(5.0 + 4.0 * u(rng));
  x[2] = theta;
  for (int i = ModelT::kDriveOffset; i < ModelT::kStates; ++i) x[i] += LD(0.2 * u(rng));
  return x;
}


Eigen::Matrix<LD, 3, 1> poseDiff(const Pose<LD>& a, const Pose<LD>& b) {
  return {a.x - b.x, a.y - b.y, wrapAngle(a.theta - b.theta)};
}

/// Checks F_a and G_a of Akf::transition against central differences of the transition.
template <typename ModelT>
void checkTransition(const ModelT& model, const typename ModelT::StateVec& x,
                     const typename ModelT::Input& u, const char* what) {
  using AkfT = Akf<ModelT>;
  constexpr int N = ModelT::kStates;
  Eigen::Matrix<LD, 3, N> f;
  Eigen::Matrix<LD, 3, ModelT::kNoise> g;
  (void)AkfT::transition(model, x, u, &f, &g);
  const LD h = 1e-7L;
  Eigen::Matrix<LD, 3, N> fd_dummy;
  Eigen::Matrix<LD, 3, ModelT::kNoise> gd_dummy;
  for (int j = 0; j < N; ++j) {
    typename ModelT::StateVec xp = x, xm = x;
    xp[j] += h;
    xm[j] -= h;
    const Pose<LD> pp = AkfT::transition(model, xp, u, &fd_dummy, &gd_dummy);
    const Pose<LD> pm = AkfT::transition(model, xm, u, &fd_dummy, &gd_dummy);
    const Eigen::Matrix<LD, 3, 1> fd = poseDiff(pp, pm) / (2 * h);
    for (int r = 0; r < 3; ++r) {
      EXPECT_NEAR(double(f(r, j)), double(fd[r]), 1e-7 * (1.0 + std::abs(double(fd[r]))))
          << what << " F(" << r << "," << j << ") theta=" << double(x[2]);
    }
  }
  for (int j = 0; j < ModelT::kNoise; ++j) {
    typename ModelT::NoiseVec np = ModelT::NoiseVec::Zero(), nm = ModelT::NoiseVec::Zero();
    np[j] = h;
    nm[j] = -h;
    const Pose<LD> p0{x[0], x[1], x[2]};
    const Pose<LD> pp = applyIncrement(p0, model.increment(u, x, np));
    const Pose<LD> pm = applyIncrement(p0, model.increment(u, x, nm));
    const Eigen::Matrix<LD, 3, 1> fd = poseDiff(pp, pm) / (2 * h);
    for (int r = 0; r < 3; ++r) {
      EXPECT_NEAR(double(g(r, j)), double(fd[r]), 1e-7 * (1.0 + std::abs(double(fd[r]))))
          << what << " G(" << r << "," << j << ")";
    }
  }
}

const LD kThetas[] = {-kPi<LD> + 1e-9L, kPi<LD> - 1e-9L, 0.0L, 1.0L, -2.5L, 3.1L};
const LD kSteps[] = {1e-7L, 1e-4L, 0.01L, 0.3L, -0.01L};

}  // namespace

TEST(Jacobians, SyncTransitionManyStates) {
  std::mt19937_64 rng(11);
  using M = Model<SyncDrive<LD>>;
  M model;
  int checked = 0;
  for (LD th : kThetas) {
    for (LD step : kSteps) {
      const M::StateVec x = randomState<M>(rng, th);
      SyncDrive<LD>::Input u{step, LD(0.4) * step + LD(0.002)};
      checkTransition(model, x, u, "sync");
      ++checked;
    }
  }
  EXPECT_EQ(checked, 30);
}

TEST(Jacobians, DiffTransitionManyStates) {
  std::mt19937_64 rng(12);
  using M = Model<DiffDrive<LD>>;
  DiffDrive<LD> d;
  d.wheelbase = 0.5L;
  M model(d);
  for (LD th : kThetas) {
    for (LD step : kSteps) {
      const M::StateVec x = randomState<M>(rng, th);
      DiffDrive<LD>::Input u{step * LD(1.05), step * LD(0.93) - LD(1e-4)};
      checkTransition(model, x, u, "diff");
    }
  }
}

TEST(Jacobians, ComposedEffectsTransition) {
  using M = Model<DiffDrive<LD>, test::TurnSlipForTest, test::ScaleForTest>;
  static_assert(M::kStates == 8, "pose + 3 drive + 1 + 1");
  static_assert(M::offsetOf<test::TurnSlipForTest>() == 6, "first effect after the drive block");
  static_assert(M::offsetOf<test::ScaleForTest>() == 7, "second effect after the first");
  std::mt19937_64 rng(13);
  DiffDrive<LD> d;
  d.wheelbase = 0.45L;
  M model(d);
  M::StateVec x0;
  M::setNominal(x0);
  EXPECT_EQ(double(x0[6]), 0.0);
  EXPECT_EQ(double(x0[7]), 1.0);
  for (LD th : kThetas) {
    M::StateVec x = randomState<M>(rng, th);
    x[6] = 0.3L;  // make the slip active
    checkTransition(model, x, DiffDrive<LD>::Input{0.011L, 0.009L}, "composed");
  }
}

TEST(Jacobians, RangeObservationWithMountOffset) {
  using M = Model<SyncDrive<LD>>;
  using AkfT = Akf<M>;
  SegmentMap<LD, 8> map;
  ASSERT_TRUE(map.add({0, 0, 10, 0}));
  ASSERT_TRUE(map.add({10, 0, 10, 10}));
  ASSERT_TRUE(map.add({10, 10, 0, 10}));
  ASSERT_TRUE(map.add({0, 10, 0, 0}));
  ASSERT_TRUE(map.add({3, 3, 4, 6}));  // an oblique interior wall
  LaserConfig<LD> laser;
  laser.mount_x = 0.12L;
  laser.mount_y = -0.05L;
  laser.mount_yaw = 0.3L;
  LaserGeometry<LD> geom;
  ASSERT_TRUE(geom.init(laser));
  std::mt19937_64 rng(5);
  odoerr::sim::UniformDist<double> u(0.5, 9.5);
  int checked = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const Pose<LD> p{LD(u(rng)), LD(u(rng)), kThetas[trial % 6]};
    for (int i = 0; i < laser.beams; ++i) {
      LD r = 0;
      Eigen::Matrix<LD, 1, 3> h;
      if (AkfT::expectedRange(map, geom, p, i, LD(1.3), &r, &h) != Status::kOk) continue;
      const LD eps = 1e-7L;
      for (int j = 0; j < 3; ++j) {
        Pose<LD> pp = p, pm = p;
        (j == 0 ? pp.x : j == 1 ? pp.y : pp.theta) += eps;
        (j == 0 ? pm.x : j == 1 ? pm.y : pm.theta) -= eps;
        LD rp = 0, rm = 0;
        // Skip the few beams whose ray leaves the wall under the perturbation.
        if (AkfT::expectedRange(map, geom, pp, i, LD(1.3), &rp, nullptr) != Status::kOk) continue;
        if (AkfT::expectedRange(map, geom, pm, i, LD(1.3), &rm, nullptr) != Status::kOk) continue;
        if (std::abs(double(rp - rm)) > 1e-3) continue;  // crossed onto another wall
        const double fd = double((rp - rm) / (2 * eps));
        EXPECT_NEAR(double(h(j)), fd, 1e-6 * (1.0 + std::abs(fd))) << "beam " << i << " d/d" << j;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 2000);
}

TEST(Jacobians, ObservableMeanKThetaDerivative) {
  // dB/dk of the exact mean, on both sides of the series threshold.
  for (double b : {1e-4, 2e-3, 0.1, 0.45, 0.55, 1.0, 2.0}) {
    for (double k : {1e-7, 1.5e-6, 1e-3, 0.05, 0.3}) {
      const auto br = observableBracket<LD>(LD(k), LD(b));
      const LD h = LD(k) * 1e-4L;
      const LD fd =
          (observableBracket<LD>(LD(k) + h, LD(b)).value - observableBracket<LD>(LD(k) - h, LD(b)).value) /
          (2 * h);
      EXPECT_NEAR(double(br.d_dk), double(fd), 1e-8 * (1.0 + std::abs(double(fd)))) << "k=" << k << " b=" << b;
    }
  }
  // And the chain to K_theta in syncObservableMean.
  SyncSegment<LD> seg{LD(2.0), LD(0.4), LD(1.1)};
  const LD kr = 1e-3L, kt = 3e-4L, h = 1e-9L;
  const auto m = syncObservableMean(seg, kr, kt);
  const LD fd = (syncObservableMean(seg, kr, kt + h).z1 - syncObservableMean(seg, kr, kt - h).z1) / (2 * h);
  EXPECT_NEAR(double(m.dz1_dktheta), double(fd), 1e-7 * std::abs(double(fd)));
  const LD fdr = (syncObservableMean(seg, kr + h, kt).z1 - syncObservableMean(seg, kr - h, kt).z1) / (2 * h);
  EXPECT_NEAR(double(m.dz1_dkrho), double(fdr), 1e-7 * std::abs(double(fdr)));
}
