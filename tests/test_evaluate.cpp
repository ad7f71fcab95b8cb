// odoerr evaluate's measures: the RPE against hand-computed cases, dead reckoning, the
// growth K_w predicts against a Monte Carlo of the same noise, and UMBmark on squares of a
// robot with known errors.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "odoerr/effects/features.hpp"
#include "odoerr/sim/evaluate.hpp"
#include "odoerr/sim/random.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

/// A straight reference along x every 1/16 m up to 2 m (exact in binary).
std::vector<Pose2> straight() {
  std::vector<Pose2> v;
  for (int k = 0; k <= 32; ++k) v.push_back({double(k), k / 16.0, 0, 0});
  return v;
}

// The starts every 0.1 m of path on the 1/16 m grid whose 1 m segment fits in 2 m:
// 0, 0.125, 0.25, 0.3125, 0.4375, 0.5, 0.625, 0.75, 0.8125, 0.9375, 1.0.
const double kStarts[] = {0, 0.125, 0.25, 0.3125, 0.4375, 0.5, 0.625, 0.75, 0.8125, 0.9375, 1.0};

}  // namespace

TEST(EvaluateRpe, ScaleErrorByHand) {
  const auto ref = straight();
  auto est = ref;
  for (auto& p : est) p.x *= 1.1;  // 10 % long: 0.1 m over every metre
  const auto segs = rpeSegments(ref, est, 1.0, 0.1);
  ASSERT_EQ(segs.size(), 11u);
  for (std::size_t k = 0; k < segs.size(); ++k) {
    EXPECT_DOUBLE_EQ(ref[segs[k].i].x, kStarts[k]);
    EXPECT_DOUBLE_EQ(ref[segs[k].j].x - ref[segs[k].i].x, 1.0);
    EXPECT_NEAR(segs[k].trans, 0.1, 1e-12);
    EXPECT_NEAR(segs[k].rot, 0.0, 1e-12);
  }
  const auto j = rpeJson(segs);
  EXPECT_NEAR(j["trans_m"].get<double>(), 0.1, 1e-12);
  EXPECT_NEAR(j["trans_rmse_m"].get<double>(), 0.1, 1e-12);
  EXPECT_EQ(j["segments"].get<int>(), 11);
}

TEST(EvaluateRpe, HeadingDriftByHand) {
  // The estimate's heading drifts by 0.1 rad per metre, its positions exact: over a segment
  // from s the estimate moved (cos a, -sin a) in its own frame, a = 0.1 s, and turned
  // 0.1 rad, so trans = |(cos a - 1, -sin a)| = 2 sin(a / 2) and rot = 0.1.
  const auto ref = straight();
  auto est = ref;
  for (auto& p : est) p.th = 0.1 * p.x;
  const auto segs = rpeSegments(ref, est, 1.0, 0.1);
  ASSERT_EQ(segs.size(), 11u);
  double mean = 0, sq = 0;
  for (std::size_t k = 0; k < segs.size(); ++k) {
    const double want = 2 * std::sin(0.05 * kStarts[k]);
    EXPECT_NEAR(segs[k].trans, want, 1e-12) << k;
    EXPECT_NEAR(segs[k].rot, 0.1, 1e-12);
    mean += want / 11;
    sq += want * want / 11;
  }
  const auto j = rpeJson(segs);
  EXPECT_NEAR(j["trans_m"].get<double>(), mean, 1e-12);
  EXPECT_NEAR(j["trans_rmse_m"].get<double>(), std::sqrt(sq), 1e-12);
  EXPECT_NEAR(j["rot_rad"].get<double>(), 0.1, 1e-12);
}

TEST(EvaluateRpe, EmptyIsNullWithANote) {
  const auto ref = straight();
  const auto j = rpeJson(rpeSegments(ref, ref, 5.0, 0.1));  // 2 m of path: no 5 m segment
  EXPECT_TRUE(j["trans_m"].is_null());
  EXPECT_EQ(j["segments"].get<int>(), 0);
  EXPECT_FALSE(j["note"].get<std::string>().empty());
}

namespace {

constexpr double kTicksPerRev = 20000, kRadius = 0.05, kBase = 0.4;
const double kTicksPerM = kTicksPerRev / (2 * kPi<double> * kRadius);

/// A robot whose true wheels are delta_R, delta_L times nominal and whose wheelbase is
/// delta_d times nominal, driving `moves` (straight length in m, or turn in place in rad)
/// with the truth exact and the encoders counting its true wheel travel.
struct Robot {
  double dr, dl, dd;
  double crab = 0;  ///< a sideways drift per metre of travel (side += crab * rho)
  Odolog log;
  double x = 0, y = 0, th = 0, ta = 0, tb = 0, t = 0;
  Robot(double dr_, double dl_, double dd_) : dr(dr_), dl(dl_), dd(dd_) {
    log.path = "synthetic";
    log.drive = "diff";
    log.params = {{"wheel_radius_m", kRadius}, {"ticks_per_rev", kTicksPerRev}, {"wheelbase_m", kBase}};
    log.has_init = true;
    log.init = {0, 0, 0, 0, 0.001, 0.001, 0.001};
    record();
  }
  void record() {
    log.enc.push_back({t, std::llround(ta), std::llround(tb)});
    log.truth.push_back({t, x, y, th});
  }
  void wheels(double r, double l) {  // true wheel travel of one step
    const double rho = 0.5 * (r + l), dth = (r - l) / (kBase * dd), m = th + 0.5 * dth;
    x += rho * std::cos(m) - crab * rho * std::sin(m);
    y += rho * std::sin(m) + crab * rho * std::cos(m);
    th += dth;
    ta += r / dr * kTicksPerM;
    tb += l / dl * kTicksPerM;
    t += 0.05;
    record();
  }
  void straight(double len) {
    for (int k = 0; k < 100; ++k) wheels(len / 100, len / 100);
  }
  void turn(double ang) {
    const double w = ang * kBase * dd / 2;
    for (int k = 0; k < 50; ++k) wheels(w / 50, -w / 50);
  }
};

Odolog square(double dr, double dl, double dd, bool cw, double side) {
  Robot r(dr, dl, dd);
  for (int k = 0; k < 4; ++k) {
    r.straight(side);
    r.turn(cw ? -kPi<double> / 2 : kPi<double> / 2);
  }
  return r.log;
}

}  // namespace

TEST(EvaluateOdometry, DeadReckoningWithTheTrueConstantsFollowsTheTruth) {
  const Odolog log = square(1.004, 0.996, 1.02, true, 1.0);
  std::vector<double> times;
  for (const auto& r : log.truth) times.push_back(r.t);
  std::vector<Pose2> odo, nom;
  std::string err;
  ASSERT_TRUE(integrateOdometry(log, {1.004, 0.996, 1.02, {}}, times, &odo, &err)) << err;
  ASSERT_TRUE(integrateOdometry(log, {}, times, &nom, &err)) << err;
  EXPECT_NEAR(odo.back().x, log.truth.back().x, 1e-4);
  EXPECT_NEAR(odo.back().y, log.truth.back().y, 1e-4);
  EXPECT_GT(std::hypot(nom.back().x - log.truth.back().x, nom.back().y - log.truth.back().y), 0.01);
}

TEST(EvaluateUmbmark, RecoversKnownWheelAndWheelbaseErrors) {
  // Borenstein's first-order formulas: E_d and E_b of a robot with 0.4 % unequal wheels
  // and a 2 % wide wheelbase, from 2 + 2 squares of 1 m.
  const double dr = 1.002, dl = 0.998, dd = 1.02;
  std::vector<Odolog> runs = {square(dr, dl, dd, true, 1.0), square(dr, dl, dd, true, 1.0),
                              square(dr, dl, dd, false, 1.0), square(dr, dl, dd, false, 1.0)};
  UmbmarkResult u;
  std::string err;
  ASSERT_TRUE(umbmark(runs, 1.0, &u, &err)) << err;
  EXPECT_EQ(u.n_cw, 2);
  EXPECT_EQ(u.n_ccw, 2);
  EXPECT_NEAR(u.ed, dr / dl, 0.1 * (dr / dl - 1));
  EXPECT_NEAR(u.eb, dd, 0.1 * (dd - 1));
  EXPECT_NEAR(u.c.delta_R / u.c.delta_L, dr / dl, 0.1 * (dr / dl - 1));
  // and it refuses squares of one direction
  EXPECT_FALSE(umbmark({runs[0], runs[1]}, 1.0, &u, &err));
  EXPECT_NE(err.find("both directions"), std::string::npos);
}

TEST(EvaluateGrowth, PredictedSigmaMatchesMonteCarloOfTheSameNoise) {
  // Odometry on a 6 m path (straights and turns) whose wheel travel has variance
  // K_w |travel| per step: the predicted position sigma after 5 m against the spread of
  // 400 noisy runs' 5 m RPE.
  const double k_w = 1e-4;
  Robot base(1, 1, 1);
  for (int k = 0; k < 3; ++k) {
    base.straight(1.5);
    base.turn(1.0);
    base.straight(0.5);
    base.turn(-0.5);
  }
  const Odolog& clean = base.log;
  std::vector<Pose2> ref;
  std::vector<double> times;
  for (const auto& r : clean.truth) {
    ref.push_back({r.t, r.x, r.y, r.theta});
    times.push_back(r.t);
  }
  const double pred = predictedRpeSigma(clean, {}, k_w, ref, 5.0, 0.1);
  ASSERT_GT(pred, 0);
  std::mt19937 rng(9);
  odoerr::sim::NormalDist<double> g(0, 1);
  double sq = 0;
  long n = 0;
  for (int run = 0; run < 400; ++run) {
    Odolog noisy = clean;  // the encoders count the true travel plus noise
    double na = 0, nb = 0;
    for (std::size_t k = 1; k < noisy.enc.size(); ++k) {
      const double ua = double(clean.enc[k].a - clean.enc[k - 1].a) / kTicksPerM;
      const double ub = double(clean.enc[k].b - clean.enc[k - 1].b) / kTicksPerM;
      na += std::sqrt(k_w * std::abs(ua)) * g(rng) * kTicksPerM;
      nb += std::sqrt(k_w * std::abs(ub)) * g(rng) * kTicksPerM;
      noisy.enc[k].a = clean.enc[k].a + std::llround(na);
      noisy.enc[k].b = clean.enc[k].b + std::llround(nb);
    }
    std::vector<Pose2> odo;
    std::string err;
    ASSERT_TRUE(integrateOdometry(noisy, {}, times, &odo, &err));
    for (const auto& s : rpeSegments(ref, odo, 5.0, 0.1)) {
      sq += s.trans * s.trans;
      ++n;
    }
  }
  const double observed = std::sqrt(sq / double(n));
  EXPECT_NEAR(observed / pred, 1.0, 0.1) << "predicted " << pred << " observed " << observed;
}

TEST(EvaluateOdometry, AFeatureTermCarriesACrabDrift) {
  // A robot drifting 8 mm to its left per metre: dead reckoning with the term
  // feature:ds@cross = 0.008 follows it; without, it ends centimetres off.
  Robot r(1, 1, 1);
  r.crab = 0.008;
  r.straight(2.0);  // two sides of a square (over a closed square the drift cancels)
  r.turn(kPi<double> / 2);
  r.straight(2.0);
  std::vector<double> times;
  for (const auto& p : r.log.truth) times.push_back(p.t);
  OdoConstants c;
  c.terms.push_back({static_cast<int>(effects::MotionFeature::kDs), static_cast<int>(effects::MotionTarget::kCross),
                     0.008, "feature:ds@cross"});
  std::vector<Pose2> with, without;
  std::string err;
  ASSERT_TRUE(integrateOdometry(r.log, c, times, &with, &err)) << err;
  ASSERT_TRUE(integrateOdometry(r.log, {}, times, &without, &err)) << err;
  const auto& t = r.log.truth.back();
  EXPECT_LT(std::hypot(with.back().x - t.x, with.back().y - t.y), 1e-4);
  EXPECT_GT(std::hypot(without.back().x - t.x, without.back().y - t.y), 0.02);
}

TEST(EvaluateFixNoise, MeasuresTheFixesNoiseNotTheOdometrysDrift) {
  // `odoerr evaluate`'s default (--fix-sigma measured): a robot with wheel and wheelbase
  // errors (nominal dead reckoning drifts by metres' worth of heading over the drive),
  // fixes about every second (unevenly spaced) with Gaussian noise of 2 mm / 5 mrad that
  // declare ten times it: the measured sigmas are the fixes' noise, within 15 %.
  Robot r(1.004, 0.996, 1.01);
  for (int k = 0; k < 30; ++k) {
    r.straight(1.0);
    r.turn(1.0);
    r.straight(0.5);
    r.turn(-0.7);
  }
  const double sxy = 0.002, sth = 0.005;
  std::mt19937 rng(3);
  odoerr::sim::NormalDist<double> g(0, 1);
  std::uniform_int_distribution<int> step(16, 24);  // 0.8-1.2 s at 20 Hz
  Odolog log = r.log;
  for (std::size_t k = 20; k < log.truth.size(); k += static_cast<std::size_t>(step(rng))) {
    const auto& q = log.truth[k];
    log.poses.push_back({q.t, q.x + sxy * g(rng), q.y + sxy * g(rng), q.theta + sth * g(rng), 10 * sxy, 10 * sxy,
                         10 * sth});
  }
  const FixNoise n = measureFixNoise(log);
  ASSERT_TRUE(n.measured) << n.note;
  EXPECT_GT(n.samples, 300);
  EXPECT_NEAR(n.sigma_xy / sxy, 1.0, 0.15) << n.sigma_xy;
  EXPECT_NEAR(n.sigma_theta / sth, 1.0, 0.15) << n.sigma_theta;
  EXPECT_DOUBLE_EQ(n.declared_xy, 10 * sxy);
  EXPECT_DOUBLE_EQ(n.declared_theta, 10 * sth);
  setFixSigma(&log, n);
  EXPECT_DOUBLE_EQ(log.poses.back().sy, n.sigma_xy);
  EXPECT_DOUBLE_EQ(log.poses.back().stheta, n.sigma_theta);

  // too few fixes to measure on: the declared sigmas are kept, with a note
  Odolog few = log;
  few.poses.resize(FixNoise::kMinSamples + 2);  // kMinSamples + 2 fixes: kMinSamples - 1 windows of four
  const FixNoise f = measureFixNoise(few);
  EXPECT_FALSE(f.measured);
  EXPECT_DOUBLE_EQ(f.sigma_xy, f.declared_xy);
  EXPECT_FALSE(f.note.empty());
}
