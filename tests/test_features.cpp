// The feature library of residual discovery (core/include/odoerr/effects/features.hpp):
// hand-computed values, the parsers, the derivatives against finite differences, the
// targets against the pose they move, and angle_sens against a ray cast on a wall.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "odoerr/akf.hpp"
#include "odoerr/effects/catalogue.hpp"
#include "odoerr/effects/features.hpp"

namespace odoerr {
namespace {

using namespace effects;
using D = double;

constexpr D kD = 0.5;  // wheelbase
constexpr D kXc = 5.0, kYc = 5.0;

MotionContext<D> context() {
  MotionContext<D> ctx;
  ctx.dt = 0.02;
  ctx.s_abs = 37.0;
  ctx.x = 4.2;
  ctx.y = 5.1;
  ctx.setHeading(0.7);
  return ctx;
}

D value(MotionFeature f, D rho, D th, const MotionContext<D>& ctx = context()) {
  return motionFeature(f, rho, th, ctx, kD, kXc, kYc).f;
}

TEST(Features, NamesRoundTripThroughTheParsers) {
  for (int i = 0; i < kMotionFeatureCount; ++i) {
    const auto f = static_cast<MotionFeature>(i);
    MotionFeature g = MotionFeature::kCount;
    ASSERT_TRUE(parseMotionFeature(motionFeatureName(f), &g)) << motionFeatureName(f);
    EXPECT_EQ(g, f);
    EXPECT_STRNE(motionFeatureUnit(f), "?");
  }
  for (int i = 0; i < kMotionTargetCount; ++i) {
    const auto t = static_cast<MotionTarget>(i);
    MotionTarget g = MotionTarget::kCount;
    ASSERT_TRUE(parseMotionTarget(motionTargetName(t), &g)) << motionTargetName(t);
    EXPECT_EQ(g, t);
  }
  for (int i = 0; i < kBeamFeatureCount; ++i) {
    const auto f = static_cast<BeamFeature>(i);
    BeamFeature g = BeamFeature::kCount;
    ASSERT_TRUE(parseBeamFeature(beamFeatureName(f), &g)) << beamFeatureName(f);
    EXPECT_EQ(g, f);
    EXPECT_STRNE(beamFeatureUnit(f), "?");
  }
  // the documented spellings
  MotionFeature f = MotionFeature::kNone;
  EXPECT_TRUE(parseMotionFeature("ds_R_speed", &f));
  EXPECT_EQ(f, MotionFeature::kDsRSpeed);
  EXPECT_TRUE(parseMotionFeature("cos_heading_ds", &f));
  EXPECT_EQ(f, MotionFeature::kCosHeadingDs);
  MotionTarget t = MotionTarget::kAlong;
  EXPECT_TRUE(parseMotionTarget("wheel_L", &t));
  EXPECT_EQ(t, MotionTarget::kWheelL);
  BeamFeature b = BeamFeature::kNone;
  EXPECT_TRUE(parseBeamFeature("inv_cos_inc", &b));
  EXPECT_EQ(b, BeamFeature::kInvCosInc);
  // unknown, wrong case, nullptr: refused, output untouched
  f = MotionFeature::kDt;
  EXPECT_FALSE(parseMotionFeature("ds_r_speed", &f));
  EXPECT_FALSE(parseMotionFeature("", &f));
  EXPECT_FALSE(parseMotionFeature(nullptr, &f));
  EXPECT_EQ(f, MotionFeature::kDt);
  EXPECT_FALSE(parseMotionTarget("wheel", &t));
  EXPECT_FALSE(parseBeamFeature("t", &b));  // time is not in the library (the hook cannot know it)
  EXPECT_STREQ(motionFeatureName(MotionFeature::kCount), "?");
}

TEST(Features, MotionValuesMatchHandComputation) {
  const D rho = 0.012, th = 0.02;
  // R = rho + th d/2 = 0.017, L = 0.007; dt = 0.02
  EXPECT_DOUBLE_EQ(value(MotionFeature::kNone, rho, th), 0);
  EXPECT_DOUBLE_EQ(value(MotionFeature::kDs, rho, th), 0.012);
  EXPECT_DOUBLE_EQ(value(MotionFeature::kAbsDs, -rho, th), 0.012);
  EXPECT_DOUBLE_EQ(value(MotionFeature::kDth, rho, th), 0.02);
  EXPECT_DOUBLE_EQ(value(MotionFeature::kAbsDth, rho, -th), 0.02);
  EXPECT_NEAR(value(MotionFeature::kDsR, rho, th), 0.017, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kDsL, rho, th), 0.007, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kDsRSpeed, rho, th), 0.017 * 0.017 / 0.02, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kDsLSpeed, rho, th), 0.007 * 0.007 / 0.02, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kDsLSpeed, rho, 0.1), -0.013 * 0.013 / 0.02, 1e-15);  // L < 0: signed
  EXPECT_NEAR(value(MotionFeature::kVW, rho, th), 0.012 * 0.02 / 0.02, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kV2, -rho, th), -0.012 * 0.012 / 0.02, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kW2, rho, -th), -0.02 * 0.02 / 0.02, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kCosHeadingDs, -rho, th), std::cos(0.7) * 0.012, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kSinHeadingDs, rho, th), std::sin(0.7) * 0.012, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kXDs, rho, th), (4.2 - 5.0) * 0.012, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kYDs, rho, th), (5.1 - 5.0) * 0.012, 1e-15);
  EXPECT_NEAR(value(MotionFeature::kSDs, rho, th), 37 * 0.012, 1e-15);
  EXPECT_DOUBLE_EQ(value(MotionFeature::kDt, rho, th), 0.02);
  // dt unknown: every rate feature (and dt itself) is 0, the others are not
  MotionContext<D> no_dt = context();
  no_dt.dt = 0;
  for (MotionFeature f : {MotionFeature::kDsRSpeed, MotionFeature::kDsLSpeed, MotionFeature::kVW,
                          MotionFeature::kV2, MotionFeature::kW2, MotionFeature::kDt}) {
    const FeatureValue<D> v = motionFeature(f, rho, th, no_dt, kD, kXc, kYc);
    EXPECT_EQ(v.f, 0) << motionFeatureName(f);
    EXPECT_EQ(v.d_rho, 0) << motionFeatureName(f);
    EXPECT_EQ(v.d_th, 0) << motionFeatureName(f);
  }
  EXPECT_NEAR(value(MotionFeature::kDsR, rho, th, no_dt), 0.017, 1e-15);
}

TEST(Features, MotionDerivativesMatchFiniteDifferences) {
  const MotionContext<D> ctx = context();
  // points where every branch is active: both wheels forwards, one backwards, reversing
  const D points[][2] = {{0.012, 0.02}, {0.012, -0.07}, {-0.009, 0.013}, {-0.011, -0.004}, {0.002, 0.05}};
  for (const auto& pt : points) {
    for (int i = 1; i < kMotionFeatureCount; ++i) {
      const auto f = static_cast<MotionFeature>(i);
      const FeatureValue<D> v = motionFeature(f, pt[0], pt[1], ctx, kD, kXc, kYc);
      const D h = 1e-7;
      const D fd_rho = (value(f, pt[0] + h, pt[1]) - value(f, pt[0] - h, pt[1])) / (2 * h);
      const D fd_th = (value(f, pt[0], pt[1] + h) - value(f, pt[0], pt[1] - h)) / (2 * h);
      EXPECT_NEAR(v.d_rho, fd_rho, 1e-7 * (1 + std::abs(fd_rho))) << motionFeatureName(f) << " at " << pt[0];
      EXPECT_NEAR(v.d_th, fd_th, 1e-7 * (1 + std::abs(fd_th))) << motionFeatureName(f) << " at " << pt[1];
    }
  }
}

TEST(Features, TargetsMoveThePoseAsDocumented) {
  const MotionContext<D> ctx = context();  // heading 0.7
  const D cf = 0.003;
  D dir[3];
  // world_x / world_y: a cycle without rotation moves the pose by exactly (cf, 0) / (0, cf)
  for (const auto& [t, ex, ey] : {std::tuple{MotionTarget::kWorldX, cf, 0.0}, std::tuple{MotionTarget::kWorldY, 0.0, cf}}) {
    motionTargetDirection(t, ctx, kD, dir);
    const Pose<D> p0{1, 2, 0.7};
    const Pose<D> p1 = applyIncrement(p0, Increment<D>{cf * dir[0], cf * dir[1], cf * dir[2]});
    EXPECT_NEAR(p1.x - p0.x, ex, 1e-15) << motionTargetName(t);
    EXPECT_NEAR(p1.y - p0.y, ey, 1e-15) << motionTargetName(t);
    EXPECT_NEAR(p1.theta, p0.theta, 1e-15);
  }
  // wheel_R / wheel_L: the same as the drive model with that wheel travelling cf further
  DiffDrive<D> drive;
  drive.wheelbase = kD;
  const DiffDrive<D>::NoiseVec zero = DiffDrive<D>::NoiseVec::Zero();
  const Increment<D> base = drive.increment({0.011, 0.009}, DiffDrive<D>::nominal(), zero);
  for (const auto& [t, dr, dl] : {std::tuple{MotionTarget::kWheelR, cf, 0.0}, std::tuple{MotionTarget::kWheelL, 0.0, cf}}) {
    motionTargetDirection(t, ctx, kD, dir);
    const Increment<D> moved = drive.increment({0.011 + dr, 0.009 + dl}, DiffDrive<D>::nominal(), zero);
    EXPECT_NEAR(base.rho + cf * dir[0], moved.rho, 1e-15) << motionTargetName(t);
    EXPECT_NEAR(base.theta + cf * dir[1], moved.theta, 1e-15) << motionTargetName(t);
    EXPECT_EQ(dir[2], 0);
  }
  motionTargetDirection(MotionTarget::kAlong, ctx, kD, dir);
  EXPECT_EQ(dir[0], 1);
  motionTargetDirection(MotionTarget::kCross, ctx, kD, dir);
  EXPECT_EQ(dir[2], 1);
  motionTargetDirection(MotionTarget::kHeading, ctx, kD, dir);
  EXPECT_EQ(dir[1], 1);
}

TEST(Features, AngleSensIsTheRangeChangeOfARotatedBeam) {
  // walls at several orientations, beams hitting them from both sides at several
  // incidences: r(alpha + h) - r(alpha - h) over 2h against r tan(inc)
  const Segment<D> walls[] = {{10, -20, 10, 20}, {-20, 7, 20, 7}, {-3, -20, 12, 20}, {15, 3, -15, -6}};
  int checked = 0;
  for (const Segment<D>& wall : walls) {
    SegmentMap<D, 4> map;
    ASSERT_TRUE(map.add(wall));
    for (const D px : {0.0, 3.0}) {
      for (D a = -3.1; a < 3.1; a += 0.37) {
        const RayHit<D> hit = map.cast(px, 1.0, a);
        if (!hit.hit || std::abs(hit.n_dot_u) < 0.2) continue;
        BeamFeatureInputs<D> in;
        ASSERT_TRUE(beamFeatureInputs(px, 1.0, std::cos(a), std::sin(a), wall, 0.25, 0.0, 0.0, &in));
        EXPECT_NEAR(in.range, hit.range, 1e-9);
        EXPECT_NEAR(in.cos_inc, std::abs(hit.n_dot_u), 1e-12);
        EXPECT_NEAR(std::cos(in.inc), in.cos_inc, 1e-12);
        EXPECT_NEAR(std::tan(in.inc), in.tan_inc, 1e-9);
        const D h = 1e-6;
        const RayHit<D> plus = map.cast(px, 1.0, a + h), minus = map.cast(px, 1.0, a - h);
        ASSERT_TRUE(plus.hit && minus.hit);
        const D fd = (plus.range - minus.range) / (2 * h);
        EXPECT_NEAR(beamFeature(BeamFeature::kAngleSens, in), fd, 1e-5 * (1 + std::abs(fd))) << "angle " << a;
        EXPECT_NEAR(beamFeature(BeamFeature::kAlphaAngleSens, in), 0.25 * fd, 1e-5 * (1 + std::abs(fd)));
        ++checked;
      }
    }
  }
  EXPECT_GE(checked, 30);
  // the sign convention by hand: a wall at x = 10, a ray at +0.3 rad hits at incidence +0.3
  BeamFeatureInputs<D> in;
  ASSERT_TRUE(beamFeatureInputs(0.0, 0.0, std::cos(0.3), std::sin(0.3), Segment<D>{10, 20, 10, -20}, -0.4, 0.5,
                                -0.2, &in));
  EXPECT_NEAR(in.inc, 0.3, 1e-12);
  EXPECT_NEAR(in.range, 10 / std::cos(0.3), 1e-12);
  EXPECT_DOUBLE_EQ(beamFeature(BeamFeature::kNone, in), 0);
  EXPECT_DOUBLE_EQ(beamFeature(BeamFeature::kOne, in), 1);
  EXPECT_NEAR(beamFeature(BeamFeature::kRange, in), 10 / std::cos(0.3), 1e-12);
  EXPECT_NEAR(beamFeature(BeamFeature::kAbsInc, in), 0.3, 1e-12);
  EXPECT_NEAR(beamFeature(BeamFeature::kInc2, in), 0.09, 1e-12);
  EXPECT_NEAR(beamFeature(BeamFeature::kInvCosInc, in), 1 / std::cos(0.3) - 1, 1e-12);
  EXPECT_DOUBLE_EQ(beamFeature(BeamFeature::kAlpha, in), -0.4);
  EXPECT_NEAR(beamFeature(BeamFeature::kAlpha2, in), 0.16, 1e-15);
  EXPECT_NEAR(beamFeature(BeamFeature::kAngleSens, in), 10 * std::sin(0.3) / (std::cos(0.3) * std::cos(0.3)), 1e-12);
  EXPECT_DOUBLE_EQ(beamFeature(BeamFeature::kV, in), 0.5);
  EXPECT_DOUBLE_EQ(beamFeature(BeamFeature::kW, in), -0.2);
  EXPECT_NEAR(beamFeature(BeamFeature::kWAngleSens, in), -0.2 * beamFeature(BeamFeature::kAngleSens, in), 1e-15);
  // the ray at -0.3 rad: incidence -0.3 (the sign follows the rotation, not the wall side)
  ASSERT_TRUE(beamFeatureInputs(0.0, 0.0, std::cos(-0.3), std::sin(-0.3), Segment<D>{10, 20, 10, -20}, 0.0, 0.0,
                                0.0, &in));
  EXPECT_NEAR(in.inc, -0.3, 1e-12);
  // parallel or behind: refused
  EXPECT_FALSE(beamFeatureInputs(0.0, 0.0, 0.0, 1.0, Segment<D>{10, 20, 10, -20}, 0.0, 0.0, 0.0, &in));
  EXPECT_FALSE(beamFeatureInputs(0.0, 0.0, -1.0, 0.0, Segment<D>{10, 20, 10, -20}, 0.0, 0.0, 0.0, &in));
}

TEST(Features, TheFilterHookAndAPosteriorPoseGiveTheSameBeamFeatures) {
  // The filter computes the features from its BeamContext; the host's discovery code from
  // a pose, the laser and the map. Both must agree, beam by beam.
  using M = Model<DiffDrive<D>, RangeBias>;
  SegmentMap<D, 8> map;
  ASSERT_TRUE(map.add({0, 0, 10, 0}) && map.add({10, 0, 10, 10}) && map.add({10, 10, 0, 10}) &&
              map.add({0, 10, 0, 0}) && map.add({2, 3, 4, 8}));
  LaserConfig<D> lc;
  lc.mount_x = 0.1;
  lc.mount_y = 0.02;
  lc.mount_yaw = 0.05;
  LaserGeometry<D, 64> laser;
  ASSERT_TRUE(laser.init(lc));
  const D x = 6.3, y = 4.4, th = 2.1, vx = 0.3, vy = 0.4, w = 0.6;
  const D c = std::cos(th), sn = std::sin(th);
  int checked = 0;
  for (int i = 0; i < laser.beams(); ++i) {
    D r;
    Eigen::Matrix<D, 1, 3> h;
    BeamContext<D> geo;
    if (Akf<M>::expectedRange(map, laser, x, y, c, sn, i, 0.1, &r, &h, &geo) != Status::kOk) continue;
    geo.vx = vx;
    geo.vy = vy;
    geo.w = w;
    const BeamFeatureInputs<D> hook = beamFeatureInputs(geo);
    BeamFeatureInputs<D> host;
    ASSERT_TRUE(beamFeatureInputs(map, laser, x, y, th, i, c * vx + sn * vy, w, &host));
    EXPECT_NEAR(hook.alpha, lc.angle_min + i * lc.angle_inc, 1e-12);
    for (int k = 1; k < kBeamFeatureCount; ++k) {
      const auto f = static_cast<BeamFeature>(k);
      EXPECT_NEAR(beamFeature(f, hook), beamFeature(f, host), 1e-9 * (1 + std::abs(beamFeature(f, host))))
          << beamFeatureName(f) << " beam " << i;
    }
    ++checked;
  }
  EXPECT_GE(checked, 30);
}

TEST(Features, FloatGivesTheSameNumbers) {
  // the target's scalar: compiles under -Wdouble-promotion and agrees with double
  MotionContext<float> cf;
  cf.dt = 0.02f;
  cf.s_abs = 37.0f;
  cf.x = 4.2f;
  cf.y = 5.1f;
  cf.setHeading(0.7f);
  for (int i = 0; i < kMotionFeatureCount; ++i) {
    const auto f = static_cast<MotionFeature>(i);
    const FeatureValue<float> v = motionFeature(f, 0.012f, -0.02f, cf, 0.5f, 5.0f, 5.0f);
    EXPECT_NEAR(double(v.f), value(f, 0.012, -0.02), 1e-6 * (1 + std::abs(value(f, 0.012, -0.02))))
        << motionFeatureName(f);
  }
  BeamFeatureInputs<float> in;
  ASSERT_TRUE(beamFeatureInputs(0.0f, 0.0f, std::cos(0.3f), std::sin(0.3f), Segment<float>{10, 20, 10, -20}, 0.1f,
                                0.5f, 0.2f, &in));
  EXPECT_NEAR(double(beamFeature(BeamFeature::kAngleSens, in)), 10 * std::sin(0.3) / std::pow(std::cos(0.3), 2), 1e-5);
}

}  // namespace
}  // namespace odoerr
