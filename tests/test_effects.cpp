// The effect catalogue: every effect's Jacobians against central finite differences, the
// physics of the contract (docs/effect-catalogue.md) at a few points, and composition; the
// tutorial's worked example (docs/writing-an-effect.md). The feature effects:
// test_feature_effects.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <tuple>

#include "effects_support.hpp"
#include "odoerr/akf.hpp"
#include "odoerr/effects/catalogue.hpp"
#include "odoerr/estimator.hpp"
#include "reverse_scale.hpp"  // docs/examples: the tutorial's worked example
#include "odoerr/sim/random.hpp"

namespace odoerr {
namespace {

using namespace effects_test;

TEST(Effects, MotionJacobiansMatchFiniteDifferences) {
  checkMotionJacobians(TurnSlip{}, {0.03});
  checkMotionJacobians(RotationSlip{}, {0.04});
  checkMotionJacobians(SpeedScale{}, {0.05});
  checkMotionJacobians(WheelEccentricity{}, {0.02, -0.01});
  checkMotionJacobians(Backlash{}, {0.004});
  checkMotionJacobians(Backlash{}, {0.004}, Increment<D>{0.035, 0.004, 0.0003});  // leaves the span mid-cycle
  RegionScale reg;
  reg.x_max = 10;
  reg.y_max = 10;
  checkMotionJacobians(reg, {0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09});
  checkMotionJacobians(RadiusDrift{}, {0.02});
}

// The per-wheel effects configured for a wheelbase of 0.5 (R = rho + 0.25 dtheta,
// L = rho - 0.25 dtheta).
template <typename E>
E onWheels(E e = E{}) {
  e.wheelbase = 0.5;
  return e;
}

// The per-wheel effects' Jacobians at points where each wheel's part is active.
TEST(Effects, PerWheelJacobiansMatchFiniteDifferences) {
  // wheel_speed_scale: both wheels forwards at different speeds; a turn in place (R > 0 > L)
  checkMotionJacobians(onWheels<WheelSpeedScale>(), {0.03, -0.02});
  checkMotionJacobians(onWheels<WheelSpeedScale>(), {0.03, -0.02}, Increment<D>{0.0005, 0.06, 0.0002});
  checkMotionJacobians(onWheels<WheelSpeedScale>(), {0.03, -0.02}, Increment<D>{-0.011, -0.01, 0});  // backwards
  // wheel_backlash, both wheels inside their spans (R 0.013, L 0.011)
  checkMotionJacobians(onWheels<WheelBacklash>(), {0.008, 0.002});
  // the right wheel leaves its span mid-cycle (R 0.0325 > 0.03), the left stays in (L 0.0175 < 0.02)
  checkMotionJacobians(onWheels<WheelBacklash>(), {0.008, 0.002}, Increment<D>{0.025, 0.03, 0.0001});
  // both leave their spans mid-cycle (R 0.036, L 0.034)
  checkMotionJacobians(onWheels<WheelBacklash>(), {0.008, 0.002}, Increment<D>{0.035, 0.004, 0.0003});
  // far from any reversal, a turn while driving forwards reverses only the left wheel
  WheelMotionContext<D> far = testContext();
  far.wheel_r.s_rev = far.wheel_l.s_rev = 0.4;
  checkMotionJacobians(onWheels<WheelBacklash>(), {0.008, 0.002}, Increment<D>{0.002, 0.04, 0}, far);  // R 0.012, L -0.008
  // a turn in place that changes direction reverses both wheels
  WheelMotionContext<D> ccw = far;
  ccw.wheel_r.last_sign = -1;
  ccw.wheel_l.last_sign = 1;
  checkMotionJacobians(onWheels<WheelBacklash>(), {0.008, 0.002}, Increment<D>{0.0003, 0.06, 0}, ccw);
  // a reversal cycle longer than the span (R 0.07, L -0.07)
  checkMotionJacobians(onWheels<WheelBacklash>(), {0.008, 0.002}, Increment<D>{0, 0.28, 0}, ccw);
}

Increment<D> applyTo(const Increment<D>& in, const D* p, const WheelMotionContext<D>& ctx, const WheelBacklash& e) {
  Eigen::Matrix<D, 3, 3> di;
  Eigen::Matrix<D, 3, 2> dp;
  return e.apply(in, p, ctx, di, dp);
}

TEST(Effects, PerWheelPhysicsFollowsTheContract) {
  const WheelMotionContext<D> ctx = testContext();
  Eigen::Matrix<D, 3, 3> di;
  Eigen::Matrix<D, 3, 2> dp;
  const D d = 0.5;
  // wheel_speed_scale: R = 0.011, L = 0.009 at dt 0.02: each scaled by 1 + k_X |X| / dt
  const D k[2] = {0.03, -0.02};
  const Increment<D> in{0.01, 0.004, 0.0002};
  const D r = 0.011 * (1 + 0.03 * 0.011 / 0.02), l = 0.009 * (1 - 0.02 * 0.009 / 0.02);
  const Increment<D> o = onWheels<WheelSpeedScale>().apply(in, k, ctx, di, dp);
  EXPECT_NEAR(o.rho, 0.5 * (r + l), 1e-15);
  EXPECT_NEAR(o.theta, (r - l) / d, 1e-15);
  EXPECT_DOUBLE_EQ(o.side, 0.0002);
  // equal parameters on a straight run: the robot-level speed_scale
  const D kk[2] = {0.03, 0.03};
  Eigen::Matrix<D, 3, 1> dp1;
  EXPECT_NEAR(onWheels<WheelSpeedScale>().apply(Increment<D>{0.01, 0, 0}, kk, ctx, di, dp).rho,
              SpeedScale{}.apply(Increment<D>{0.01, 0, 0}, kk, ctx, di, dp1).rho, 1e-15);
  // wheel_backlash: R = 0.011 inside its span loses b_R / 0.05 of it, L = 0.009 likewise
  const D b[2] = {0.008, 0.002};
  const Increment<D> ob = applyTo(in, b, ctx, onWheels<WheelBacklash>());
  const D rb = 0.011 * (1 - 0.008 / 0.05), lb = 0.009 * (1 - 0.002 / 0.05);
  EXPECT_NEAR(ob.rho, 0.5 * (rb + lb), 1e-15);
  EXPECT_NEAR(ob.theta, (rb - lb) / d, 1e-15);
  // only the wheel inside its span loses
  WheelMotionContext<D> right_only = ctx;
  right_only.wheel_l.s_rev = 0.3;
  const Increment<D> orr = applyTo(in, b, right_only, onWheels<WheelBacklash>());
  EXPECT_NEAR(orr.rho, 0.5 * (rb + 0.009), 1e-15);
  EXPECT_NEAR(orr.theta, (rb - 0.009) / d, 1e-15);
  // a wheel's reversal in this very cycle starts its span: a turn while driving forwards
  // (R 0.012, L -0.008) reverses the left wheel only
  WheelMotionContext<D> far = ctx;
  far.wheel_r.s_rev = far.wheel_l.s_rev = 0.4;
  const Increment<D> turn{0.002, 0.04, 0};
  const Increment<D> ot = applyTo(turn, b, far, onWheels<WheelBacklash>());
  EXPECT_NEAR(ot.rho + 0.25 * ot.theta, 0.012, 1e-15);
  EXPECT_NEAR(ot.rho - 0.25 * ot.theta, -0.008 * (1 - 0.002 / 0.05), 1e-15);
  // a cycle that leaves the right wheel's span loses only on its part inside it
  WheelMotionContext<D> edge = far;
  edge.wheel_r.s_rev = 0.045;
  const Increment<D> oe = applyTo(Increment<D>{0.01, 0, 0}, b, edge, onWheels<WheelBacklash>());
  EXPECT_NEAR(oe.rho + 0.25 * oe.theta, 0.01 - 0.008 * 0.005 / 0.05, 1e-15);
  EXPECT_NEAR(oe.rho - 0.25 * oe.theta, 0.01, 1e-15);
  // no wheels (the default, and the sync drive's wheelbase 0): both are no-ops with zero
  // parameter columns
  const WheelBacklash none;
  const WheelSpeedScale none_s;
  const Increment<D> on = none.apply(in, b, ctx, di, dp);
  EXPECT_EQ(on.rho, in.rho);
  EXPECT_EQ(on.theta, in.theta);
  EXPECT_TRUE(dp.isZero(0));
  EXPECT_TRUE(di.isIdentity(0));
  const Increment<D> ons = none_s.apply(in, k, ctx, di, dp);
  EXPECT_EQ(ons.rho, in.rho);
  EXPECT_EQ(ons.theta, in.theta);
  EXPECT_TRUE(dp.isZero(0));
  // setWheelbase configures every per-wheel effect of a composed tuple and no other
  Model<DiffDrive<D>, SpeedScale, WheelSpeedScale, WheelEccentricity, WheelBacklash> mt;
  auto& t = mt.effects;
  EXPECT_EQ(std::get<WheelBacklash>(t).wheelbase, 0.0);  // unconfigured: no wheels
  setWheelbase(t, 0.62);
  EXPECT_EQ(std::get<WheelSpeedScale>(t).wheelbase, 0.62);
  EXPECT_EQ(std::get<WheelBacklash>(t).wheelbase, 0.62);
  EXPECT_EQ(std::get<WheelEccentricity>(t).wheel_radius, 0.05);
  // a composed model keeps its effects' defaults (GCC 12 zeroed them in a value-initialised
  // tuple that starts with an empty effect)
  const Model<DiffDrive<D>, TurnSlip, WheelEccentricity, RegionScale> m;
  EXPECT_EQ(std::get<WheelEccentricity>(m.effects).wheel_radius, 0.05);
  EXPECT_EQ(std::get<RegionScale>(m.effects).x_max, 1.0);
}

TEST(Effects, WheelBacklashLosesExactlyBPerWheelReversalWhateverTheCycleLength) {
  // Drive a curve forwards (both wheels forwards), then turn in place anticlockwise (the
  // left wheel reverses), then clockwise (both reverse), then drive straight forwards (the
  // right wheel reverses): each wheel loses exactly its b at each of its own reversals,
  // however the cycles fall on the 5 cm spans.
  const D b[2] = {0.008, 0.002};
  const WheelBacklash e = onWheels<WheelBacklash>();
  for (const D step : {0.003, 0.01, 0.013, 0.04, 0.07}) {
    WheelMotionContext<D> ctx;
    D lost_r = 0, lost_l = 0;
    auto legs = {std::pair<D, D>{0.4, 0.2}, {0.3, -0.3}, {-0.3, 0.3}, {0.3, 0.3}};  // wheel travel R, L of a leg
    int reversals_r = 0, reversals_l = 0;
    for (const auto& [lr, ll] : legs) {
      const int n = static_cast<int>(std::lround(std::max(std::abs(lr), std::abs(ll)) / step));
      for (int i = 0; i < n; ++i) {
        const D r = lr / n, l = ll / n;
        const Increment<D> in{0.5 * (r + l), (r - l) / 0.5, 0};
        const Increment<D> out = applyTo(in, b, ctx, e);
        lost_r += std::abs(r) - std::abs(out.rho + 0.25 * out.theta);
        lost_l += std::abs(l) - std::abs(out.rho - 0.25 * out.theta);
        const int before_r = ctx.wheel_r.last_sign, before_l = ctx.wheel_l.last_sign;
        ctx.wheel_r.advance(r);
        ctx.wheel_l.advance(l);
        reversals_r += before_r != 0 && before_r != ctx.wheel_r.last_sign;
        reversals_l += before_l != 0 && before_l != ctx.wheel_l.last_sign;
      }
    }
    EXPECT_EQ(reversals_r, 2);  // clockwise turn, straight run
    EXPECT_EQ(reversals_l, 2);  // anticlockwise turn, clockwise turn
    EXPECT_NEAR(lost_r, 2 * b[0], 1e-12) << "cycle length " << step;
    EXPECT_NEAR(lost_l, 2 * b[1], 1e-12) << "cycle length " << step;
  }
}

TEST(Effects, FilterCountsEachWheelsOwnReversals) {
  // The AKF of a model with a per-wheel effect keeps each wheel's reversal odometer on the
  // drive model's wheel travel; a model without one leaves them untouched (compile-time gate).
  using MW = Model<DiffDrive<D>, SpeedScale, WheelBacklash>;
  using MB = Model<DiffDrive<D>, Backlash>;
  static_assert(MW::kHasWheelOdometers && !MB::kHasWheelOdometers);
  static_assert(std::is_same_v<MB::Context, MotionContext<D>>);  // no storage either
  static_assert(std::is_same_v<Model<DiffDrive<float>>::Context, MotionContext<float>>);
  static_assert(!Model<DiffDrive<D>, WheelSpeedScale>::kHasWheelOdometers);  // it needs only the split
  DiffDrive<D> drive;
  drive.wheelbase = 0.5;
  MW mw(drive);
  setWheelbase(mw.effects, drive.wheelbase);
  Akf<MW> akf{mw};
  Akf<MB> akf_b{MB(drive)};
  MW::StateVec x = MW::StateVec::Zero();
  MW::setNominal(x);
  akf.init(x, MW::StateVec::Constant(1e-4).asDiagonal());
  MB::StateVec xb = MB::StateVec::Zero();
  MB::setNominal(xb);
  akf_b.init(xb, MB::StateVec::Constant(1e-4).asDiagonal());
  const Eigen::Matrix<D, 1, 1> k(1e-6);
  auto step = [&](D r, D l) {
    ASSERT_EQ(akf.predict({r, l}, k, 0.02), Status::kOk);
    ASSERT_EQ(akf_b.predict({r, l}, k, 0.02), Status::kOk);
  };
  for (int i = 0; i < 10; ++i) step(0.012, 0.008);  // a curve forwards: no reversal yet
  const auto& c = akf.motionContext();
  EXPECT_TRUE(std::isinf(c.wheel_r.s_rev));
  EXPECT_TRUE(std::isinf(c.wheel_l.s_rev));
  EXPECT_EQ(c.wheel_r.last_sign, 1);
  EXPECT_EQ(c.wheel_l.last_sign, 1);
  for (int i = 0; i < 3; ++i) step(0.011, -0.007);  // turning forwards: the left wheel reverses alone
  EXPECT_TRUE(std::isinf(c.wheel_r.s_rev));
  EXPECT_NEAR(c.wheel_l.s_rev, 0.021, 1e-12);
  EXPECT_EQ(c.wheel_l.last_sign, -1);
  EXPECT_TRUE(std::isinf(c.s_rev));  // the robot never reversed: rho > 0 throughout
  for (int i = 0; i < 4; ++i) step(-0.01, 0.01);  // a turn in place the other way: both reverse
  EXPECT_NEAR(c.wheel_r.s_rev, 0.04, 1e-12);
  EXPECT_NEAR(c.wheel_l.s_rev, 0.04, 1e-12);
  step(0, 0);  // no travel: no reversal
  step(0.01, 0.005);  // forwards again: the right wheel reverses, the left goes on
  EXPECT_NEAR(c.wheel_r.s_rev, 0.01, 1e-12);
  EXPECT_NEAR(c.wheel_l.s_rev, 0.045, 1e-12);
  EXPECT_NEAR(akf_b.motionContext().s_abs, c.s_abs, 1e-15);  // the robot's odometers alike
}

TEST(Effects, MotionPhysicsFollowsTheContract) {
  const WheelMotionContext<D> ctx = testContext();
  const Increment<D> in{0.01, 0.005, 0};
  Eigen::Matrix<D, 3, 3> di;
  Eigen::Matrix<D, 3, 1> dp1;
  const D k = 0.03;
  // turn_slip: side += k v w rho with v = rho/dt, w = dtheta/dt
  EXPECT_NEAR(TurnSlip{}.apply(in, &k, ctx, di, dp1).side, k * (0.01 / 0.02) * (0.005 / 0.02) * 0.01, 1e-15);
  // rotation_slip: dtheta *= 1 - k |w|
  EXPECT_NEAR(RotationSlip{}.apply(in, &k, ctx, di, dp1).theta, 0.005 * (1 - k * 0.25), 1e-15);
  // backlash: inside the 5 cm span the travel is scaled by 1 - b / 0.05; outside not
  WheelMotionContext<D> far = ctx;
  far.s_rev = 0.2;
  const D b = 0.004;
  EXPECT_NEAR(Backlash{}.apply(in, &b, ctx, di, dp1).rho, 0.01 * (1 - b / 0.05), 1e-15);
  EXPECT_DOUBLE_EQ(Backlash{}.apply(in, &b, far, di, dp1).rho, 0.01);
  // a reversal in this very cycle starts the span
  const Increment<D> back{-0.01, 0, 0};
  EXPECT_NEAR(Backlash{}.apply(back, &b, far, di, dp1).rho, -0.01 * (1 - b / 0.05), 1e-15);
  // a cycle that leaves the span loses only on its part inside it
  WheelMotionContext<D> edge = ctx;
  edge.s_rev = 0.045;
  EXPECT_NEAR(Backlash{}.apply(in, &b, edge, di, dp1).rho, 0.01 - b * 0.005 / 0.05, 1e-15);
  // speed-dependent effects stay inactive when the cycle time is unknown
  WheelMotionContext<D> no_dt = ctx;
  no_dt.dt = 0;
  EXPECT_DOUBLE_EQ(SpeedScale{}.apply(in, &k, no_dt, di, dp1).rho, 0.01);
  // region_scale: the cell of (4.2, 5.1) in a 3x3 grid over [0, 10]^2 is row 1, col 1
  RegionScale reg;
  reg.x_max = 10;
  reg.y_max = 10;
  EXPECT_EQ(reg.cell(4.2, 5.1), 4);
  EXPECT_EQ(reg.cell(-3, 11), 6);  // clamped
  // far beyond int's range after scaling, or not a number: clamped, never converted as is
  EXPECT_EQ(reg.cell(8.05e9, 5.1), 5);
  EXPECT_EQ(reg.cell(-1e300, 1e300), 6);
  EXPECT_EQ(reg.cell(std::nan(""), 5.1), 3);
  // odometers: a reversal resets s_rev; s_enc follows the encoders
  WheelMotionContext<D> m;
  m.advance(0.01, 0.011);
  m.advance(-0.01, -0.0105);
  EXPECT_NEAR(m.s_rev, 0.01, 1e-15);
  EXPECT_NEAR(m.s_enc, 0.0005, 1e-15);
  EXPECT_NEAR(m.s_abs, 0.02, 1e-15);
}

TEST(Effects, BacklashLosesExactlyBPerReversalWhateverTheCycleLength) {
  // Drive 0.3 m forwards, then 0.3 m back, in cycles of a given length: the travel lost
  // after the reversal is b, however the cycles fall on the 5 cm span.
  const D b = 0.01;
  for (const D step : {0.003, 0.01, 0.013, 0.04, 0.07}) {
    WheelMotionContext<D> ctx;
    Eigen::Matrix<D, 3, 3> di;
    Eigen::Matrix<D, 3, 1> dp;
    D lost = 0;
    for (const D dir : {1.0, -1.0}) {
      for (D done = 0; done < 0.3 - 1e-12; done += step) {
        const Increment<D> in{dir * step, 0, 0};
        const Increment<D> out = Backlash{}.apply(in, &b, ctx, di, dp);
        if (dir < 0) lost += std::abs(in.rho) - std::abs(out.rho);
        ctx.advance(in.rho, in.rho);
      }
    }
    EXPECT_NEAR(lost, b, 1e-12) << "cycle length " << step;
  }
}

TEST(Effects, FilterOdometersCountTheDriveTravelBeforeTheEffects) {
  // docs/effect-catalogue.md: s_abs and s_rev count the drive model's increment, not the
  // one the effects changed. With backlash at 0.01 the two differ by 20 % in the span.
  using MB = Model<DiffDrive<D>, Backlash>;
  DiffDrive<D> drive;
  drive.wheelbase = 0.5;
  Akf<MB> akf{MB(drive)};
  MB::StateVec x = MB::StateVec::Zero();
  MB::setNominal(x);
  x[MB::offsetOf<Backlash>()] = 0.01;
  akf.init(x, MB::StateVec::Constant(1e-4).asDiagonal());
  const Eigen::Matrix<D, 1, 1> k(1e-6);
  for (int i = 0; i < 10; ++i) ASSERT_EQ(akf.predict({0.01, 0.01}, k), Status::kOk);   // 10 cm forwards
  for (int i = 0; i < 3; ++i) ASSERT_EQ(akf.predict({-0.01, -0.01}, k), Status::kOk);  // 3 cm back: in the span
  EXPECT_NEAR(akf.motionContext().s_abs, 0.13, 1e-12);
  EXPECT_NEAR(akf.motionContext().s_rev, 0.03, 1e-12);
  EXPECT_NEAR(akf.state()[0], 0.10 - 0.03 * (1 - 0.01 / 0.05), 1e-9);  // the pose did lose the travel
}

TEST(Effects, TurnNoiseAddsHeadingVarianceOnly) {
  const D q = 2e-4;
  const Eigen::Vector3d v = TurnNoise{}.variance(Increment<D>{0.01, -0.02, 0}, &q, testContext());
  EXPECT_DOUBLE_EQ(v[0], 0);
  EXPECT_NEAR(v[1], q * 0.02, 1e-18);
  EXPECT_DOUBLE_EQ(v[2], 0);
}

// Measurement effects: the predicted range as the filter forms it (ray shift, cast,
// correction) against the d range / d p the filter uses.
using MM = Model<DiffDrive<D>, RangeBias, RangeScale, LaserMountXY, LaserMountYaw, ScanLatency, WallOffsetN<4>>;
using AkfM = Akf<MM>;

/// Range of beam i at state x and the filter's H row (first-order model with ray shift).
bool predict(const RoomSetup& s, const MM& m, const MM::StateVec& x, int i, D* r, Eigen::Matrix<D, 1, MM::kStates>* h) {
  const D c = std::cos(x[2]), sn = std::sin(x[2]);
  const auto& lc = s.laser.config();
  const RayContext<D> rc{c, sn, 0.4, -0.3, 0.7, -sn * lc.mount_x - c * lc.mount_y, c * lc.mount_x - sn * lc.mount_y};
  const RayShift<D> shift = m.shiftRay(x, rc);
  Eigen::Matrix<D, 1, 3> hp;
  BeamContext<D> geo;
  if (AkfM::expectedRange(s.map, s.laser, x[0], x[1], c, sn, i, 0.1, r, &hp, &geo, &shift) != Status::kOk) return false;
  geo.vx = rc.vx;
  geo.vy = rc.vy;
  geo.w = rc.w;
  D hf[MM::kStates] = {};
  hf[0] = hp(0);
  hf[1] = hp(1);
  hf[2] = hp(2);
  m.measure(x, geo, r, hf);
  for (int k = 0; k < MM::kStates; ++k) (*h)(k) = hf[k];
  return true;
}

TEST(Effects, MeasurementJacobiansMatchFiniteDifferences) {
  const RoomSetup s;
  const MM m;
  MM::StateVec x = MM::StateVec::Zero();
  x << 3.7, 4.4, 0.6, 1, 1, 1, 0.01, 0.002, 0.01, -0.005, 0.004, 0.015, 0.02, -0.01, 0.03, 0.0;
  int checked = 0;
  for (int i = 0; i < s.laser.beams(); i += 5) {
    D r0;
    Eigen::Matrix<D, 1, MM::kStates> h;
    if (!predict(s, m, x, i, &r0, &h)) continue;
    for (int k : {0, 1, 2}) {  // pose columns too
      const D e = 1e-6;
      MM::StateVec a = x, b = x;
      a[k] += e;
      b[k] -= e;
      D ra, rb;
      Eigen::Matrix<D, 1, MM::kStates> dummy;
      ASSERT_TRUE(predict(s, m, a, i, &ra, &dummy) && predict(s, m, b, i, &rb, &dummy));
      EXPECT_NEAR(h(k), (ra - rb) / (2 * e), 2e-2 * (1 + std::abs(h(k)))) << "beam " << i << " state " << k;
    }
    for (int k = MM::kDriveOffset + 3; k < MM::kStates; ++k) {
      const D e = 1e-7;
      MM::StateVec a = x, b = x;
      a[k] += e;
      b[k] -= e;
      D ra, rb;
      Eigen::Matrix<D, 1, MM::kStates> dummy;
      ASSERT_TRUE(predict(s, m, a, i, &ra, &dummy) && predict(s, m, b, i, &rb, &dummy));
      // first-order effects: the analytic derivative is taken at the ray as cast and
      // drops products of two effect parameters (here range_scale 0.002 times the others)
      EXPECT_NEAR(h(k), (ra - rb) / (2 * e), 5e-3 * (1 + std::abs(h(k)))) << "beam " << i << " state " << k;
    }
    ++checked;
  }
  EXPECT_GE(checked, 5);
}

TEST(Effects, ShiftedRayEqualsTheMovedLaser) {
  // laser_mount_yaw by a ray shift gives exactly the range of a laser set up with that yaw
  const RoomSetup s;
  const MM m;
  MM::StateVec x = MM::StateVec::Zero();
  x[0] = 3.7;
  x[1] = 4.4;
  x[2] = 0.6;
  MM::setNominal(x);
  const int yaw_at = MM::offsetOf<LaserMountYaw>();
  x[yaw_at] = 0.02;
  LaserConfig<D> lc = s.laser.config();
  lc.mount_yaw = 0.02;
  LaserGeometry<D, 64> moved;
  ASSERT_TRUE(moved.init(lc));
  for (int i = 0; i < 36; i += 7) {
    D r_shift, r_moved;
    Eigen::Matrix<D, 1, MM::kStates> h;
    Eigen::Matrix<D, 1, 3> hp;
    if (!predict(s, m, x, i, &r_shift, &h)) continue;
    ASSERT_EQ(AkfM::expectedRange(s.map, moved, x[0], x[1], std::cos(x[2]), std::sin(x[2]), i, 0.1, &r_moved, &hp),
              Status::kOk);
    EXPECT_NEAR(r_shift, r_moved, 1e-9);
  }
}

TEST(Effects, HeldParameterStaysExactlyConstant) {
  // A parameter with zero variance (a diagnosis holds it) is never touched by an update.
  const RoomSetup s;
  AkfM akf(MM{});
  MM::StateVec x = MM::StateVec::Zero();
  x[0] = 3;
  x[1] = 4;
  MM::setNominal(x);
  x[MM::offsetOf<RangeBias>()] = 0.01;
  MM::StateVec sig = MM::StateVec::Constant(0.01);
  sig[MM::offsetOf<RangeBias>()] = 0;
  akf.init(x, sig.cwiseAbs2().asDiagonal());
  std::vector<D> ranges(36, 4.0);
  const auto st = akf.updateScan(s.map, s.laser, ranges.data());
  EXPECT_GT(st.used, 0);
  EXPECT_EQ(akf.state()[MM::offsetOf<RangeBias>()], 0.01);
  EXPECT_EQ(akf.covariance()(MM::offsetOf<RangeBias>(), MM::offsetOf<RangeBias>()), 0.0);
  EXPECT_EQ(akf.counters().bad_covariance, 0u);
}

// docs/writing-an-effect.md: the worked example is right (its Jacobians, backwards and
// forwards) and, composed into an estimator at compile time, is estimated from a drive
// that reverses.
TEST(EffectTutorial, ReverseScaleJacobians) {
  checkMotionJacobians(examples::ReverseScale{}, {0.03}, Increment<D>{-0.012, 0.004, 0.0003});
  checkMotionJacobians(examples::ReverseScale{}, {0.03}, Increment<D>{0.012, 0.004, 0.0003});
  Eigen::Matrix<D, 3, 3> di;
  Eigen::Matrix<D, 3, 1> dp;
  const D k = 0.03;
  EXPECT_DOUBLE_EQ(examples::ReverseScale{}.apply(Increment<D>{-0.01, 0, 0}, &k, testContext(), di, dp).rho, -0.0103);
  EXPECT_DOUBLE_EQ(examples::ReverseScale{}.apply(Increment<D>{0.01, 0, 0}, &k, testContext(), di, dp).rho, 0.01);
}

TEST(EffectTutorial, ReverseScaleIsEstimatedFromADriveThatReverses) {
  using M = Model<DiffDrive<D>, examples::ReverseScale>;
  using Est = Estimator<M>;
  static_assert(M::kStates == 7, "the pose, three drive parameters and the effect's one");
  constexpr int kK = M::offsetOf<examples::ReverseScale>();
  SquareRoom<Est> room;
  ASSERT_TRUE(room.ok);
  const auto& [map, laser, drive] = std::tie(room.map, room.laser, room.drive);
  Est est(M(drive), map, laser);
  M::StateVec x0 = M::StateVec::Zero();
  x0 << 5, 5, 0.3, 0, 0, 0, 0;
  M::setNominal(x0);  // the drive parameters at 1, the effect at 0
  M::StateVec sig = M::StateVec::Constant(1e-3);
  sig[kK] = examples::ReverseScale::kPriorSigma[0];
  typename Est::OfT::KVec k0 = Est::OfT::KVec::Constant(1e-6);
  est.init(x0, sig.cwiseAbs2().asDiagonal(), k0, (k0 * 0.1).cwiseAbs2().asDiagonal());
  est.freezeNonSystematic(true);

  // The truth: 1 m forwards, 1 m back, 15 times, travelling 4 % further backwards.
  const D k_true = 0.04;
  D x = 5, y = 5, th = 0.3;
  std::mt19937 rng(7);
  odoerr::sim::NormalDist<D> noise(0, 0.03);
  std::vector<D> ranges(36);
  const auto& lc = laser.config();
  for (int i = 0; i < 3000; ++i) {
    const D dir = (i / 100) % 2 == 0 ? 1 : -1;
    const D rho = 0.01 * dir * (dir < 0 ? 1 + k_true : 1);
    x += rho * std::cos(th);
    y += rho * std::sin(th);
    const bool scan = i % 10 == 9;
    for (int b = 0; scan && b < 36; ++b) {
      const RayHit<D> hit = map.cast(x, y, th + lc.angle_min + b * lc.angle_inc);
      ASSERT_TRUE(hit.hit);
      ranges[b] = hit.range + noise(rng);
    }
    (void)est.cycle(typename M::Input{0.01 * dir, 0.01 * dir}, scan ? ranges.data() : nullptr);
  }
  const D k_est = est.akf().state()[kK], k_sig = std::sqrt(est.akf().covariance()(kK, kK));
  std::printf("reverse_scale: estimate %.4f +- %.4f (truth %.2f)\n", k_est, k_sig, k_true);
  EXPECT_LT(k_sig, 0.005) << "the drive determines the effect";
  EXPECT_NEAR(k_est, k_true, 3 * k_sig);
  EXPECT_NEAR(est.akf().state()[0], x, 0.02);
  EXPECT_NEAR(est.akf().state()[1], y, 0.02);
}

}  // namespace
}  // namespace odoerr
