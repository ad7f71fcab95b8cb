// The feature effects (odoerr/effects/feature_effects.hpp): a discovery's finding enters
// the model as a configured slot, with exact Jacobians, configured priors, and is
// estimated by the filter. The catalogue's own effects: test_effects.cpp.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <tuple>
#include <type_traits>

#include "effects_support.hpp"
#include "odoerr/akf.hpp"
#include "odoerr/effects/catalogue.hpp"
#include "odoerr/effects/feature_effects.hpp"
#include "odoerr/estimator.hpp"
#include "odoerr/sim/random.hpp"

namespace odoerr {
namespace {

using namespace effects_test;

using MF = FeatureMotion<4>;
using MT = MotionTarget;
using FM = MotionFeature;

MF featureMotion(std::initializer_list<std::pair<FM, MT>> slots) {
  MF e;
  e.wheelbase = 0.5;
  e.xc = 5;
  e.yc = 5;
  int i = 0;
  for (const auto& [f, t] : slots) EXPECT_TRUE(e.configure(i++, f, t, 0.1, 0.01));
  return e;
}

TEST(FeatureEffects, MotionJacobiansMatchFiniteDifferences) {
  // every target and every feature, each in some slot, forwards and reversing, turning
  // both ways (both wheels forwards, one wheel backwards)
  const MF configs[] = {
      featureMotion({{FM::kDsRSpeed, MT::kWheelR}, {FM::kAbsDs, MT::kWorldY}, {FM::kVW, MT::kCross}, {FM::kAbsDth, MT::kHeading}}),
      featureMotion({{FM::kDsLSpeed, MT::kWheelL}, {FM::kCosHeadingDs, MT::kWorldX}, {FM::kXDs, MT::kAlong}, {FM::kW2, MT::kHeading}}),
      featureMotion({{FM::kV2, MT::kAlong}, {FM::kSDs, MT::kCross}, {FM::kDth, MT::kWorldX}, {FM::kDsL, MT::kWorldY}}),
      featureMotion({{FM::kDs, MT::kWheelR}, {FM::kSinHeadingDs, MT::kWheelL}, {FM::kYDs, MT::kAlong}, {FM::kDt, MT::kCross}}),
      featureMotion({{FM::kDsR, MT::kHeading}, {FM::kDsRSpeed, MT::kWorldX}, {FM::kDsLSpeed, MT::kCross}, {FM::kVW, MT::kWheelL}}),
      // the features without a rate (the rate-held history features: below)
      featureMotion({{FM::kRevNearDs, MT::kAlong}, {FM::kTDs, MT::kWorldX}, {FM::kRevNearDs, MT::kWheelL}, {FM::kTDs, MT::kHeading}}),
  };
  for (const MF& e : configs) {
    for (const Increment<D>& in : {Increment<D>{0.012, 0.004, 0.0003}, Increment<D>{-0.012, 0.03, 0.0003},
                                   Increment<D>{0.004, -0.05, -0.0002}}) {
      checkMotionJacobians(e, {0.03, -0.02, 0.05, 0.04}, in);
    }
  }
}

TEST(FeatureEffects, MotionFollowsTheLibraryAndAnEmptySlotDoesNothing) {
  const HistoryMotionContext<D> ctx = testContext();  // dt 0.02, heading 0.7
  const Increment<D> in{0.012, 0.02, 0.0003};
  Eigen::Matrix<D, 3, 3> di;
  Eigen::Matrix<D, 3, 4> dp;
  // nothing configured: identity, zero columns
  const D c[4] = {0.03, -0.01, 0.2, 0.4};
  const Increment<D> same = MF{}.apply(in, c, ctx, di, dp);
  EXPECT_EQ(same.rho, in.rho);
  EXPECT_EQ(same.theta, in.theta);
  EXPECT_EQ(same.side, in.side);
  EXPECT_TRUE(di.isIdentity(0));
  EXPECT_TRUE(dp.isZero(0));
  // wheel_R += 0.03 ds_R_speed (slot 0) and world_y += -0.01 abs_ds (slot 1), by hand
  const MF e = featureMotion({{FM::kDsRSpeed, MT::kWheelR}, {FM::kAbsDs, MT::kWorldY}});
  const D r = 0.012 + 0.02 * 0.25, a = 0.03 * r * r / 0.02, b = -0.01 * 0.012;
  const Increment<D> out = e.apply(in, c, ctx, di, dp);
  EXPECT_NEAR(out.rho, 0.012 + a / 2 + b * std::sin(0.7), 1e-15);
  EXPECT_NEAR(out.theta, 0.02 + a / 0.5, 1e-15);
  EXPECT_NEAR(out.side, 0.0003 + b * std::cos(0.7), 1e-15);
  EXPECT_TRUE(dp.col(2).isZero(0));  // slots 2, 3 unconfigured
  EXPECT_TRUE(dp.col(3).isZero(0));
  EXPECT_NEAR(e.feature(0, in, ctx).f, r * r / 0.02, 1e-15);
  // configure refuses what it cannot hold, and changes nothing then
  MF g;
  EXPECT_FALSE(g.configure(4, FM::kDs, MT::kAlong, 0.1, 0.01));
  EXPECT_FALSE(g.configure(0, FM::kCount, MT::kAlong, 0.1, 0.01));
  EXPECT_FALSE(g.configure(0, FM::kDs, MT::kCount, 0.1, 0.01));
  EXPECT_FALSE(g.configure(0, FM::kDs, MT::kAlong, -0.1, 0.01));
  EXPECT_FALSE(g.configure(0, FM::kDs, MT::kAlong, std::nan(""), 0.01));
  EXPECT_EQ(g.slots[0].feature, FM::kNone);
}

TEST(FeatureEffects, HistoryFeaturesFromThePreviousCycles) {
  // A history by hand: cycles of 20 ms at 0.5 then 0.6 m/s, turning at 0.3 then 0.5 rad/s.
  HistoryMotionContext<D> h;
  h.dt = 0.02;
  h.advanceHistory(0.010, 0.006, 0.02);  // v 0.5, w 0.3: no acceleration yet (one cycle)
  EXPECT_EQ(h.cycles, 1);
  EXPECT_DOUBLE_EQ(h.a_prev, 0.0);
  EXPECT_NEAR(h.v_prev, 0.5, 1e-15);
  const D rho = 0.012, th = 0.010, d = 0.5;  // this cycle: v 0.6, w 0.5
  const D a = (0.6 - 0.5) / 0.02, alpha = (0.5 - 0.3) / 0.02;
  auto f = [&](FM m) { return motionFeature(m, rho, th, h, d, 0.0, 0.0).f; };
  EXPECT_NEAR(f(FM::kAccDs), a * rho, 1e-12);
  EXPECT_NEAR(f(FM::kAccPosDs), a * rho, 1e-12);
  EXPECT_EQ(f(FM::kAccNegDs), 0.0);
  EXPECT_NEAR(f(FM::kAccRDs), (a + alpha * d / 2) * (rho + th * d / 2), 1e-12);
  EXPECT_NEAR(f(FM::kAccLDs), (a - alpha * d / 2) * (rho - th * d / 2), 1e-12);
  EXPECT_NEAR(f(FM::kDwDs), alpha * rho, 1e-12);
  EXPECT_EQ(f(FM::kJerkDs), 0.0);  // needs two earlier cycles
  EXPECT_NEAR(f(FM::kTDs), 0.02 * rho, 1e-15);
  EXPECT_EQ(f(FM::kRevNearDs), 0.0);  // no reversal yet: s_rev is infinite
  h.advanceHistory(rho, th, 0.02);
  EXPECT_NEAR(h.a_prev, a, 1e-9);
  EXPECT_NEAR(motionFeature(FM::kJerkDs, 0.012, 0.0, h, d, 0.0, 0.0).f, (0.0 - a) / 0.02 * 0.012, 1e-9);
  // braking: only acc_neg_ds
  EXPECT_LT(motionFeature(FM::kAccNegDs, 0.008, 0.0, h, d, 0.0, 0.0).f, 0.0);
  EXPECT_EQ(motionFeature(FM::kAccPosDs, 0.008, 0.0, h, d, 0.0, 0.0).f, 0.0);
  // Partial derivatives with the rates held (features.hpp, historyFeature): against central
  // differences of the feature in a history shifted so that a, alpha and the jerk stay fixed.
  for (const FM m : {FM::kAccDs, FM::kAccPosDs, FM::kAccNegDs, FM::kAccRDs, FM::kAccLDs, FM::kJerkDs, FM::kDwDs,
                     FM::kTDs}) {
    for (const std::pair<D, D>& inc : {std::pair<D, D>{0.012, 0.010}, {0.004, -0.02}, {-0.009, 0.015}}) {
      const D r0 = inc.first, t0 = inc.second;  // plain names: a lambda cannot capture a structured binding
      const FeatureValue<D> v = motionFeature(m, r0, t0, h, d, 0.0, 0.0);
      const D e = 1e-7;
      auto held = [&](D dr, D dth) {  // the history moved with the increment: the rates unchanged
        HistoryMotionContext<D> g = h;
        g.v_prev += dr / g.dt;
        g.w_prev += dth / g.dt;
        return motionFeature(m, r0 + dr, t0 + dth, g, d, 0.0, 0.0).f;
      };
      EXPECT_NEAR(v.d_rho, (held(e, 0) - held(-e, 0)) / (2 * e), 1e-6 * (1 + std::abs(v.d_rho))) << static_cast<int>(m);
      EXPECT_NEAR(v.d_th, (held(0, e) - held(0, -e)) / (2 * e), 1e-6 * (1 + std::abs(v.d_th))) << static_cast<int>(m);
    }
  }
  // an unknown duration restarts the history; a context without history gives 0
  h.advanceHistory(0.01, 0.0, 0.0);
  EXPECT_EQ(motionFeature(FM::kAccDs, 0.012, 0.0, h, d, 0.0, 0.0).f, 0.0);
  const MotionContext<D> plain = h;
  EXPECT_EQ(motionFeature(FM::kAccDs, rho, th, plain, d, 0.0, 0.0).f, 0.0);
  // the model with a feature effect keeps the history and advances it
  using M = Model<DiffDrive<D>, MF>;
  static_assert(std::is_same_v<M::Context, HistoryMotionContext<D>>, "FeatureMotion reads the history");
  static_assert(std::is_same_v<Model<DiffDrive<D>>::Context, MotionContext<D>>, "the plain model does not");
  M m;
  M::Context c;
  c.dt = 0.02;
  Increment<D> di{0.01, 0.006, 0};
  m.advanceContext(c, di, 0.01);
  m.advanceContext(c, Increment<D>{0.012, 0.01, 0}, 0.012);
  EXPECT_NEAR(c.a_prev, a, 1e-9);
  EXPECT_NEAR(c.t, 0.04, 1e-15);
}

TEST(FeatureEffects, StepFeaturesActFromTheirTimeOn) {
  // ds_after, ds_R_after, ds_L_after, dth_after: the drive's own terms from t >= t_c on.
  HistoryMotionContext<D> h;
  h.dt = 0.01;
  const D rho = 0.006, th = 0.004, d = 0.5, tc = 0.03;
  auto val = [&](FM m, D t_change) { return motionFeature(m, rho, th, h, d, 0.0, 0.0, t_change); };
  for (int k = 0; k < 5; ++k) {  // t = 0, 0.01, ..., 0.04
    const bool after = h.t >= tc;
    EXPECT_EQ(val(FM::kDsAfter, tc).f, after ? rho : 0.0) << h.t;
    EXPECT_EQ(val(FM::kDsRAfter, tc).f, after ? rho + th * d / 2 : 0.0) << h.t;
    EXPECT_EQ(val(FM::kDsLAfter, tc).f, after ? rho - th * d / 2 : 0.0) << h.t;
    EXPECT_EQ(val(FM::kDthAfter, tc).f, after ? th : 0.0) << h.t;
    // without a configured time (the default, infinite) a step feature is 0
    EXPECT_EQ(motionFeature(FM::kDsRAfter, rho, th, h, d, 0.0, 0.0).f, 0.0);
    h.advanceHistory(rho, th, 0.01);
  }
  // after the step: the Jacobians are those of ds, ds_R, ds_L, dth (central differences)
  for (const FM m : {FM::kDsAfter, FM::kDsRAfter, FM::kDsLAfter, FM::kDthAfter}) {
    const FeatureValue<D> v = val(m, tc);
    const D e = 1e-7;
    auto at = [&](D dr, D dth) { return motionFeature(m, rho + dr, th + dth, h, d, 0.0, 0.0, tc).f; };
    EXPECT_NEAR(v.d_rho, (at(e, 0) - at(-e, 0)) / (2 * e), 1e-6) << static_cast<int>(m);
    EXPECT_NEAR(v.d_th, (at(0, e) - at(0, -e)) / (2 * e), 1e-6) << static_cast<int>(m);
  }
  // the effect passes its t_change on: a right wheel 3 % longer from t_c
  MF fm;
  ASSERT_TRUE(fm.configure(0, FM::kDsRAfter, MT::kWheelR, 0.1, 0.005));
  fm.wheelbase = d;
  fm.t_change = 0.5;
  Eigen::Matrix<D, 3, 3> d_in;
  Eigen::Matrix<D, 3, MF::kParams> d_p;
  const D p[MF::kParams] = {0.03, 0, 0, 0};
  const Increment<D> in{rho, th, 0};
  EXPECT_EQ(fm.apply(in, p, h, d_in, d_p).rho, rho);  // t = 0.05 < 0.5: before the step
  fm.t_change = 0.02;
  const Increment<D> out = fm.apply(in, p, h, d_in, d_p);
  const D right = rho + th * d / 2;  // the wheel R travels 3 % more: rho + dR/2, th + dR/d
  EXPECT_NEAR(out.rho, rho + 0.5 * 0.03 * right, 1e-15);
  EXPECT_NEAR(out.theta, th + 0.03 * right / d, 1e-15);
}

TEST(FeatureEffects, PriorsComeFromTheConfiguration) {
  MF e;
  ASSERT_TRUE(e.configure(1, FM::kDsRSpeed, MT::kWheelR, 0.2, 0.02));
  EXPECT_EQ(priorSigma(e, 1), 0.2);
  EXPECT_EQ(referenceSize(e, 1), 0.02);
  EXPECT_EQ(priorSigma(e, 0), 0.0);  // an unconfigured slot: held at 0 if composed
  FeatureRange<2> fr;
  ASSERT_TRUE(fr.configure(0, BeamFeature::kInvCosInc, 0.1, 0.01));
  EXPECT_EQ(priorSigma(fr, 0), 0.1);
  EXPECT_FALSE(fr.configure(2, BeamFeature::kOne, 0.1, 0.01));
  // catalogue effects: the instance form gives the type's values
  EXPECT_EQ(priorSigma(RangeBias{}, 0), priorSigma<RangeBias>(0));
  EXPECT_EQ(referenceSize(WallOffset{}, 7), referenceSize<WallOffset>(7));
  static_assert(HasConfiguredPrior<MF>::value && !HasConfiguredPrior<TurnSlip>::value);
  EXPECT_STREQ(MF::kParamNames[3], "c3");
  EXPECT_STREQ(MF::kName, "feature_motion");
  EXPECT_STREQ(FeatureRange<2>::kName, "feature_range");
}

/// The filter's motion context after one prediction of model M from heading 0.3.
template <typename M>
auto contextAfterOnePrediction() {
  DiffDrive<D> drive;
  drive.wheelbase = 0.5;
  Akf<M> akf{M(drive)};
  typename M::StateVec x = M::StateVec::Zero();
  x[2] = 0.3;
  M::setNominal(x);
  akf.init(x, M::StateVec::Constant(1e-4).asDiagonal());
  EXPECT_EQ(akf.predict({0.012, 0.01}, Eigen::Matrix<D, 1, 1>(1e-6), 0.02), Status::kOk);
  return akf.motionContext();
}

TEST(FeatureEffects, TheFilterGivesTheHeadingOnlyToModelsThatReadIt) {
  static_assert(Model<DiffDrive<D>, MF>::kUsesHeading);
  static_assert(!Model<DiffDrive<D>, TurnSlip, RegionScale, RangeBias>::kUsesHeading);
  static_assert(!Model<DiffDrive<float>>::kUsesHeading);
  const auto ctx = contextAfterOnePrediction<Model<DiffDrive<D>, MF>>();
  EXPECT_DOUBLE_EQ(ctx.heading, 0.3);  // the cycle's start
  EXPECT_NEAR(ctx.cos_heading, std::cos(0.3), 1e-12);
  EXPECT_NEAR(ctx.sin_heading, std::sin(0.3), 1e-12);
  EXPECT_EQ((contextAfterOnePrediction<Model<DiffDrive<D>, RegionScale>>().heading), 0.0);  // not filled
}

// A drive in a 10 m room: a circle of radius 2.25 m around the centre at a speed varying
// between 0.2 and 0.8 m/s, with a scan of 36 beams every 10 cycles (0.02 s each).
struct FeatureDrive {
  static constexpr D kDt = 0.02;
  static DiffDrive<D>::Input input(int i) {
    const D right = 0.004 + 0.012 * (0.5 + 0.5 * std::sin(2 * M_PI * i / 700.0));
    return {right, 0.8 * right};
  }
};

constexpr D kPose0[3] = {5, 2.75, 0};

/// The estimator of a feature-effect test: the room's drive with the feature effect `eff`
/// composed in, started at kPose0 with sigma 1e-3 on the pose and drive and the effect's
/// configured priors on its slots (an unconfigured slot: prior 0, held at 0).
template <typename Est, typename E>
Est featureEstimator(const SquareRoom<Est>& room, const E& eff) {
  using M = typename Est::Model;
  M model(room.drive);
  std::get<E>(model.effects) = eff;
  Est est(model, room.map, room.laser);
  constexpr int kC = M::template offsetOf<E>();
  typename M::StateVec sig = M::StateVec::Constant(1e-3);
  for (int i = 0; i < E::kParams; ++i) sig[kC + i] = priorSigma(eff, i);
  typename M::StateVec x0 = M::StateVec::Zero();
  x0[0] = kPose0[0];
  x0[1] = kPose0[1];
  x0[2] = kPose0[2];
  M::setNominal(x0);
  typename Est::OfT::KVec k0 = Est::OfT::KVec::Constant(1e-6);
  est.init(x0, sig.cwiseAbs2().asDiagonal(), k0, (k0 * 0.1).cwiseAbs2().asDiagonal());
  est.freezeNonSystematic(true);
  return est;
}

/// A drive of varying speed in the room whose truth has `c_true` x feature f on target t,
/// applied with the same feature code; the estimator with that one slot free estimates c.
/// Returns the estimate and its sigma, and checks that the pose follows the truth.
std::pair<D, D> recoverMotionFeature(FM f, MT t, D c_true, D prior_sigma) {
  using M = Model<DiffDrive<D>, MF>;
  using Est = Estimator<M>;
  constexpr int kC = M::offsetOf<MF>();
  SquareRoom<Est> room;
  EXPECT_TRUE(room.ok);
  const auto& [map, laser, drive] = std::tie(room.map, room.laser, room.drive);
  MF eff;
  eff.wheelbase = drive.wheelbase;
  eff.xc = 5;
  eff.yc = 5;
  EXPECT_TRUE(eff.configure(0, f, t, prior_sigma, std::abs(c_true)));
  Est est = featureEstimator(room, eff);  // slots 1..3: prior 0, held at 0

  const D c[4] = {c_true, 0, 0, 0};
  Pose<D> truth{kPose0[0], kPose0[1], kPose0[2]};
  HistoryMotionContext<D> ctx;
  ctx.dt = FeatureDrive::kDt;
  std::mt19937 rng(3);
  odoerr::sim::NormalDist<D> noise(0, 0.03);
  std::vector<D> ranges(36);
  const auto& lc = laser.config();
  for (int i = 0; i < 3000; ++i) {
    const DiffDrive<D>::Input u = FeatureDrive::input(i);
    ctx.x = truth.x;
    ctx.y = truth.y;
    ctx.setHeading(truth.theta);
    const Increment<D> inc0 = drive.increment(u, DiffDrive<D>::nominal(), DiffDrive<D>::NoiseVec::Zero());
    Eigen::Matrix3d di;
    Eigen::Matrix<D, 3, 4> dp;
    truth = applyIncrement(truth, eff.apply(inc0, c, ctx, di, dp));
    ctx.advance(inc0.rho, DiffDrive<D>::encoderTravel(u));
    ctx.advanceHistory(inc0.rho, inc0.theta, FeatureDrive::kDt);
    const bool scan = i % 10 == 9;
    for (int b = 0; scan && b < 36; ++b) {
      const RayHit<D> hit = map.cast(truth.x, truth.y, truth.theta + lc.angle_min + b * lc.angle_inc);
      EXPECT_TRUE(hit.hit);
      ranges[b] = hit.hit ? hit.range + noise(rng) : 0.0;
    }
    (void)est.cycle(u, FeatureDrive::kDt, scan ? ranges.data() : nullptr, typename Est::AkfT::NoObserver{});
  }
  EXPECT_EQ(est.akf().state()[kC + 1], 0.0);  // held slots stay exactly 0
  EXPECT_NEAR(est.akf().state()[0], truth.x, 0.02);
  EXPECT_NEAR(est.akf().state()[1], truth.y, 0.02);
  return {est.akf().state()[kC], std::sqrt(est.akf().covariance()(kC, kC))};
}

TEST(FeatureEffects, WheelSpeedErrorIsEstimatedFromADriveOfVaryingSpeed) {
  const auto [c_est, c_sig] = recoverMotionFeature(FM::kDsRSpeed, MT::kWheelR, 0.03, 0.1);
  std::printf("feature_motion wheel_R += c ds_R_speed: estimate %.4f +- %.4f (truth 0.03)\n", c_est, c_sig);
  EXPECT_LT(c_sig, 0.01) << "the drive determines the coefficient";
  EXPECT_NEAR(c_est, 0.03, 3 * c_sig);
}

TEST(FeatureEffects, AccelerationSlipIsEstimatedFromADriveThatSpeedsUpAndSlowsDown) {
  // Travel lost while speeding up (wheels that spin): along += c acc_pos_ds, c = -0.1 s^2/m.
  // The drive's speed swings between 0.2 and 0.8 m/s every 14 s (about 0.13 m/s^2).
  const auto [c_est, c_sig] = recoverMotionFeature(FM::kAccPosDs, MT::kAlong, -0.1, 0.3);
  std::printf("feature_motion along += c acc_pos_ds: estimate %.4f +- %.4f (truth -0.1)\n", c_est, c_sig);
  EXPECT_LT(c_sig, 0.1 / 3) << "the drive determines the coefficient";
  EXPECT_NEAR(c_est, -0.1, 3 * c_sig);
}

TEST(FeatureEffects, RangeJacobiansAndTheHookAgreeWithTheHostFeatures) {
  using M = Model<DiffDrive<D>, FeatureRange<4>>;
  const RoomSetup s;
  M m;
  auto& fr = std::get<FeatureRange<4>>(m.effects);
  ASSERT_TRUE(fr.configure(0, BeamFeature::kOne, 0.05, 0.01));
  ASSERT_TRUE(fr.configure(1, BeamFeature::kInvCosInc, 0.05, 0.01));
  ASSERT_TRUE(fr.configure(2, BeamFeature::kAlphaAngleSens, 0.05, 0.01));
  ASSERT_TRUE(fr.configure(3, BeamFeature::kWAngleSens, 0.05, 0.01));
  M::StateVec x = M::StateVec::Zero();
  x << 3.7, 4.4, 0.6, 1, 1, 1, 0.01, 0.02, -0.01, 0.005;
  const D c = std::cos(x[2]), sn = std::sin(x[2]), vx = 0.4, vy = -0.3, w = 0.7;
  auto predicted = [&](const M::StateVec& xs, int i, D* r, D* hf) {
    Eigen::Matrix<D, 1, 3> hp;
    BeamContext<D> geo;
    if (Akf<M>::expectedRange(s.map, s.laser, xs[0], xs[1], c, sn, i, 0.1, r, &hp, &geo) != Status::kOk) return false;
    geo.vx = vx;
    geo.vy = vy;
    geo.w = w;
    m.measure(xs, geo, r, hf);
    return true;
  };
  int checked = 0;
  for (int i = 0; i < s.laser.beams(); i += 3) {
    D r0 = 0, r_nominal = 0;
    D hf[M::kStates] = {};
    if (!predicted(x, i, &r0, hf)) continue;
    Eigen::Matrix<D, 1, 3> hp;
    ASSERT_EQ(Akf<M>::expectedRange(s.map, s.laser, x[0], x[1], c, sn, i, 0.1, &r_nominal, &hp), Status::kOk);
    // the correction is the sum of c_i g_i with g_i as the host computes it from the pose
    BeamFeatureInputs<D> in;
    ASSERT_TRUE(beamFeatureInputs(s.map, s.laser, x[0], x[1], x[2], i, c * vx + sn * vy, w, &in));
    D expected = r_nominal;
    for (int k = 0; k < 4; ++k) expected += x[M::offsetOf<FeatureRange<4>>() + k] * beamFeature(fr.slots[k].feature, in);
    EXPECT_NEAR(r0, expected, 1e-9) << "beam " << i;
    for (int k = M::offsetOf<FeatureRange<4>>(); k < M::kStates; ++k) {
      const D e = 1e-6;
      M::StateVec a = x, b = x;
      a[k] += e;
      b[k] -= e;
      D ra, rb, dummy[M::kStates] = {};
      ASSERT_TRUE(predicted(a, i, &ra, dummy) && predicted(b, i, &rb, dummy));
      EXPECT_NEAR(hf[k], (ra - rb) / (2 * e), 1e-7 * (1 + std::abs(hf[k]))) << "beam " << i << " state " << k;
    }
    ++checked;
  }
  EXPECT_GE(checked, 6);
}

TEST(FeatureEffects, IncidenceRangeErrorIsEstimated) {
  // truth: every range += 0.05 x (1/cos(inc) - 1), from the same feature code
  using M = Model<DiffDrive<D>, FeatureRange<4>>;
  using FR = FeatureRange<4>;
  using Est = Estimator<M>;
  constexpr int kC = M::offsetOf<FR>();
  SquareRoom<Est> room;
  ASSERT_TRUE(room.ok);
  const auto& [map, laser, drive] = std::tie(room.map, room.laser, room.drive);
  FR eff;
  ASSERT_TRUE(eff.configure(0, BeamFeature::kInvCosInc, 0.1, 0.01));
  Est est = featureEstimator(room, eff);

  const D c_true = 0.05;
  Pose<D> truth{kPose0[0], kPose0[1], kPose0[2]};
  std::mt19937 rng(5);
  odoerr::sim::NormalDist<D> noise(0, 0.03);
  std::vector<D> ranges(36);
  for (int i = 0; i < 3000; ++i) {
    const DiffDrive<D>::Input u = FeatureDrive::input(i);
    truth = applyIncrement(truth, drive.increment(u, DiffDrive<D>::nominal(), DiffDrive<D>::NoiseVec::Zero()));
    const bool scan = i % 10 == 9;
    for (int b = 0; scan && b < 36; ++b) {
      BeamFeatureInputs<D> in;
      ASSERT_TRUE(beamFeatureInputs(map, laser, truth.x, truth.y, truth.theta, b, 0.0, 0.0, &in));
      ranges[b] = in.range + c_true * beamFeature(BeamFeature::kInvCosInc, in) + noise(rng);
    }
    (void)est.cycle(u, FeatureDrive::kDt, scan ? ranges.data() : nullptr, typename Est::AkfT::NoObserver{});
  }
  const D c_est = est.akf().state()[kC], c_sig = std::sqrt(est.akf().covariance()(kC, kC));
  std::printf("feature_range inv_cos_inc: estimate %.4f +- %.4f (truth %.2f)\n", c_est, c_sig, c_true);
  EXPECT_LT(c_sig, 0.01) << "the drive determines the coefficient";
  EXPECT_NEAR(c_est, c_true, 3 * c_sig);
  EXPECT_NEAR(est.akf().state()[0], truth.x, 0.02);
  EXPECT_NEAR(est.akf().state()[1], truth.y, 0.02);
}

}  // namespace
}  // namespace odoerr
