// The effect tests' shared pieces (test_effects.cpp, test_feature_effects.cpp): a motion
// context at a mid-drive operating point, the check of a motion effect's Jacobians against
// central finite differences, a 10 m square room with a laser mounted off-centre, and the
// room, laser and drive of the estimation tests.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "odoerr/akf.hpp"
#include "odoerr/effects/catalogue.hpp"
#include "odoerr/estimator.hpp"

namespace odoerr::effects_test {

using namespace effects;
using D = double;

inline HistoryMotionContext<D> testContext() {
  HistoryMotionContext<D> ctx;
  ctx.v_prev = 0.5;  // the previous cycle (the feature effects' history features)
  ctx.w_prev = 0.3;
  ctx.a_prev = 2.0;
  ctx.t = 12.5;
  ctx.cycles = 3;
  ctx.dt = 0.02;
  ctx.s_abs = 37.0;
  ctx.s_signed = 12.0;
  ctx.s_enc = 11.7;
  ctx.s_rev = 0.02;  // inside the backlash span
  ctx.last_sign = 1;
  ctx.wheel_r.s_rev = 0.02;  // each wheel inside its own backlash span
  ctx.wheel_r.last_sign = 1;
  ctx.wheel_l.s_rev = 0.03;
  ctx.wheel_l.last_sign = 1;
  ctx.x = 4.2;
  ctx.y = 5.1;
  ctx.setHeading(0.7);  // read by the feature effects' heading features and world targets
  return ctx;
}

template <typename E, typename Ctx = HistoryMotionContext<D>>
void checkMotionJacobians(const E& eff, const std::vector<D>& p0, const Increment<D>& in = {0.012, 0.004, 0.0003},
                          const Ctx& ctx = testContext()) {
  Eigen::Matrix<D, 3, 3> d_in;
  Eigen::Matrix<D, 3, E::kParams> d_p;
  (void)eff.apply(in, p0.data(), ctx, d_in, d_p);
  auto vec = [](const Increment<D>& i) { return Eigen::Vector3d(i.rho, i.theta, i.side); };
  Eigen::Matrix<D, 3, 3> dummy_in;
  Eigen::Matrix<D, 3, E::kParams> dummy_p;
  for (int k = 0; k < 3; ++k) {
    const D h = 1e-7;
    Increment<D> a = in, b = in;
    (k == 0 ? a.rho : k == 1 ? a.theta : a.side) += h;
    (k == 0 ? b.rho : k == 1 ? b.theta : b.side) -= h;
    const Eigen::Vector3d fd = (vec(eff.apply(a, p0.data(), ctx, dummy_in, dummy_p)) -
                                vec(eff.apply(b, p0.data(), ctx, dummy_in, dummy_p))) /
                               (2 * h);
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(d_in(r, k), fd[r], 1e-6 * (1 + std::abs(fd[r]))) << E::kName << " d_in(" << r << "," << k << ")";
  }
  for (int k = 0; k < E::kParams; ++k) {
    const D h = 1e-6;
    std::vector<D> a = p0, b = p0;
    a[k] += h;
    b[k] -= h;
    const Eigen::Vector3d fd =
        (vec(eff.apply(in, a.data(), ctx, dummy_in, dummy_p)) - vec(eff.apply(in, b.data(), ctx, dummy_in, dummy_p))) /
        (2 * h);
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(d_p(r, k), fd[r], 1e-8 * (1 + std::abs(fd[r]))) << E::kName << " d_p(" << r << "," << k << ")";
  }
}

struct RoomSetup {
  SegmentMap<D, 16> map;
  LaserGeometry<D, 64> laser;
  RoomSetup() {
    EXPECT_TRUE(map.add({0, 0, 10, 0}));
    EXPECT_TRUE(map.add({10, 0, 10, 10}));
    EXPECT_TRUE(map.add({10, 10, 0, 10}));
    EXPECT_TRUE(map.add({0, 10, 0, 0}));
    LaserConfig<D> lc;
    lc.mount_x = 0.1;
    lc.mount_y = 0.02;
    EXPECT_TRUE(laser.init(lc));
  }
};

/// The estimation tests' world: a 10 m square room, the default laser, a diff drive with a
/// 0.5 m wheelbase. `ok` is false when the room or the laser could not be built.
template <typename Est>
struct SquareRoom {
  typename Est::MapT map;
  typename Est::LaserT laser;
  DiffDrive<D> drive;
  bool ok = false;
  SquareRoom() {
    drive.wheelbase = 0.5;
    ok = map.add({0, 0, 10, 0}) && map.add({10, 0, 10, 10}) && map.add({10, 10, 0, 10}) && map.add({0, 10, 0, 0}) &&
         laser.init(LaserConfig<D>{});
  }
};

}  // namespace odoerr::effects_test
