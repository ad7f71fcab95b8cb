// AKF and OF behaviour: covariance hygiene and counted rejections, float against double,
// and short Monte Carlo runs of both drives (convergence and pose error).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "odoerr/effects/catalogue.hpp"
#include "odoerr/sim/paper_experiment.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

using SyncModel = Model<SyncDrive<double>>;

LaserGeometry<double> geometry(const LaserConfig<double>& cfg) {
  LaserGeometry<double> g;
  EXPECT_TRUE(g.init(cfg));
  return g;
}

Akf<SyncModel> makeRoomAkf(SegmentMap<double, 8>& map) {
  EXPECT_TRUE(map.add({0, 0, 10, 0}));
  EXPECT_TRUE(map.add({10, 0, 10, 10}));
  EXPECT_TRUE(map.add({10, 10, 0, 10}));
  EXPECT_TRUE(map.add({0, 10, 0, 0}));
  Akf<SyncModel> akf;
  SyncModel::StateVec x;
  SyncModel::setNominal(x);
  x.head<3>() << 5.0, 5.0, 0.0;
  SyncModel::StateVec sig;
  sig << 0.01, 0.01, 0.01, 0.2, 0.03;
  akf.init(x, sig.cwiseAbs2().asDiagonal());
  return akf;
}

}  // namespace

TEST(AkfHygiene, NonFiniteInputIsRejectedAndCounted) {
  SegmentMap<double, 8> map;
  auto akf = makeRoomAkf(map);
  const auto x0 = akf.state();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(akf.predict({nan, 0.0}, {1e-3, 3e-4}), Status::kBadInput);
  EXPECT_EQ(akf.predict({0.01, 0.0}, {nan, 3e-4}), Status::kBadInput);
  EXPECT_EQ(akf.counters().bad_inputs, 2u);
  EXPECT_EQ(akf.state(), x0) << "a rejected input must not move the state";
  EXPECT_EQ(akf.predict({0.01, 0.0}, {1e-3, 3e-4}), Status::kOk);
  EXPECT_EQ(akf.counters().predictions, 1u);
}

TEST(AkfHygiene, BeamRejectionsAreCountedByReason) {
  SegmentMap<double, 8> map;
  auto akf = makeRoomAkf(map);
  LaserConfig<double> laser;
  // Beam 18 points along +x (angle_min = -pi, 10 deg steps): the wall x = 10 at 5 m.
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, std::numeric_limits<double>::quiet_NaN()), Status::kNoReturn);
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, -1.0), Status::kNoReturn);
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, 25.0), Status::kNoReturn);  // beyond range_max
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, 9.0), Status::kGated);      // 4 m innovation
  EXPECT_EQ(akf.counters().no_return, 3u);
  EXPECT_EQ(akf.counters().gated, 1u);
  double nis = -1;
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, 5.02, &nis), Status::kOk);
  EXPECT_GT(nis, 0.0);
  EXPECT_EQ(akf.counters().beams_used, 1u);
  // From (9.5, 5) a beam at 80 deg hits the wall x = 10 first (2.9 m), at 80 deg incidence:
  // skipped as grazing.
  auto x = akf.state();
  x[0] = 9.5;
  akf.init(x, akf.covariance());
  LaserConfig<double> oblique = laser;
  oblique.angle_min = 80.0 * kPi<double> / 180.0;
  EXPECT_EQ(akf.updateBeam(map, geometry(oblique), 0, 2.9), Status::kGrazing);
  EXPECT_EQ(akf.counters().grazing, 1u);
  oblique.angle_min = 60.0 * kPi<double> / 180.0;  // 60 deg incidence: used
  EXPECT_EQ(akf.updateBeam(map, geometry(oblique), 0, 1.0), Status::kOk);
}

TEST(AkfHygiene, BeamPredictedWithinTwoSigmaOfTheWallIsRefused) {
  // A range finder reports no return at or below zero range, so near a wall its returns are
  // cut off from below: a beam predicted shorter than kNearRangeSigmas sigma is refused
  // (kTooClose) and counted; one just beyond it is fused.
  SegmentMap<double, 8> map;
  auto akf = makeRoomAkf(map);
  LaserConfig<double> laser;  // sigma 3 cm: the limit is 6 cm
  ASSERT_DOUBLE_EQ(kNearRangeSigmas<double> * laser.sigma, 0.06);
  auto x = akf.state();
  x[0] = 10.0 - 0.059;  // beam 18 (+x) hits the wall x = 10 at 5.9 cm
  akf.init(x, akf.covariance());
  const auto x0 = akf.state();
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, 0.059), Status::kTooClose);
  EXPECT_EQ(akf.counters().too_close, 1u);
  EXPECT_EQ(akf.counters().beams_used, 0u);
  EXPECT_EQ(akf.state(), x0) << "a refused beam must not move the state";
  x[0] = 10.0 - 0.061;
  akf.init(x, akf.covariance());
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, 0.061), Status::kOk);
  EXPECT_EQ(akf.counters().too_close, 1u);
  EXPECT_EQ(akf.counters().beams_used, 1u);
}

// scaleParameterCovariance: P <- D P D with D = diag(1, 1, 1, d3, d4): the pose block
// unchanged, the rest scaled, P symmetric.
TEST(AkfHygiene, ScaleParameterCovarianceIsACongruence) {
  SegmentMap<double, 8> map;
  auto akf = makeRoomAkf(map);
  SyncModel::StateMat p;
  p << 4, 1, 0.5, 0.2, 0.1,  //
      1, 3, 0.3, 0.1, 0.2,   //
      0.5, 0.3, 2, 0.4, 0.3,  //
      0.2, 0.1, 0.4, 1, 0.2,  //
      0.1, 0.2, 0.3, 0.2, 1.5;
  akf.init(akf.state(), p * 1e-4);
  const double d[5] = {7, 7, 7, 2, 3};  // the pose's entries are not read
  akf.scaleParameterCovariance(d);
  Eigen::Matrix<double, 5, 5> dd = Eigen::Matrix<double, 5, 5>::Identity();
  dd(3, 3) = 2;
  dd(4, 4) = 3;
  const SyncModel::StateMat want = dd * (p * 1e-4) * dd;
  EXPECT_LT((akf.covariance() - want).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(akf.covariance(), akf.covariance().transpose());
  const Eigen::Matrix3d pose_before = (p * 1e-4).topLeftCorner<3, 3>();
  const Eigen::Matrix3d pose_after = akf.covariance().topLeftCorner<3, 3>();
  EXPECT_EQ(pose_after, pose_before);
}

TEST(AkfHygiene, BeamThatWouldMakeADiagonalNonPositiveIsRefused) {
  // A covariance that has lost positive definiteness (x and delta_rho "correlated" 10x more
  // than their variances allow): fusing beam 18 (+x) would take delta_rho's variance below
  // zero. The beam is refused and counted, and neither the state nor P moves; with the
  // correlation inside its bounds the same beam is fused.
  SegmentMap<double, 8> map;
  auto akf = makeRoomAkf(map);
  SyncModel::StateMat p = akf.covariance();
  p(3, 3) = 1e-6;
  p(0, 3) = p(3, 0) = 10 * std::sqrt(p(0, 0) * p(3, 3));
  akf.init(akf.state(), p);
  LaserConfig<double> laser;
  const auto x0 = akf.state();
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, 5.0), Status::kBadCovariance);
  EXPECT_EQ(akf.counters().bad_covariance, 1u);
  EXPECT_EQ(akf.counters().beams_used, 0u);
  EXPECT_EQ(akf.state(), x0);
  EXPECT_EQ(akf.covariance(), p);
  p(0, 3) = p(3, 0) = 0.5 * std::sqrt(p(0, 0) * p(3, 3));
  akf.init(akf.state(), p);
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, 5.0), Status::kOk);
  EXPECT_GT(akf.covariance()(3, 3), 0.0);
  EXPECT_EQ(akf.counters().bad_covariance, 1u);
}

TEST(AkfHygiene, NoMapHitOutsideTheRoom) {
  SegmentMap<double, 8> map;
  auto akf = makeRoomAkf(map);
  auto x = akf.state();
  x[0] = 12.0;  // outside, looking away from the room along +x
  akf.init(x, akf.covariance());
  LaserConfig<double> laser;
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, 3.0), Status::kNoMapHit);
  EXPECT_EQ(akf.counters().no_map_hit, 1u);
}

TEST(AkfHygiene, UpdateWithoutPoseUncertaintyIsRejected) {
  // Innovation variance equal to the measurement variance (H P H^T = 0): not informative,
  // and a sign of a broken covariance; rejected and counted, the state untouched.
  SegmentMap<double, 8> map;
  auto akf = makeRoomAkf(map);
  SyncModel::StateMat p = akf.covariance();
  p.topLeftCorner<3, 3>().setZero();
  p.block<3, 2>(0, 3).setZero();
  p.block<2, 3>(3, 0).setZero();
  akf.init(akf.state(), p);
  LaserConfig<double> laser;
  const auto x0 = akf.state();
  EXPECT_EQ(akf.updateBeam(map, geometry(laser), 18, 5.01), Status::kBadInnovation);
  EXPECT_EQ(akf.counters().bad_innovation, 1u);
  EXPECT_EQ(akf.state(), x0);
}

TEST(AkfHygiene, CovarianceStaysSymmetricWithPositiveDiagonalInFloat) {
  SimConfig cfg;
  cfg.steps = 1500;
  FilterSetup setup;
  PaperSim<SyncDrive<double>> sim(cfg, 21);
  auto est = makeEstimator<float, SyncDrive>(sim, setup, NonSysStart::kSmall);
  float ranges[kMaxBeams];
  for (int k = 0; k < cfg.steps; ++k) {
    const auto& x = est.akf().state();
    const auto st = sim.step({double(x[0]), double(x[1]), double(x[2])},
                             {double(x[3]), double(x[4])});
    for (int i = 0; i < 36; ++i) ranges[i] = float(st.ranges[i]);
    (void)est.cycle({float(st.input.rho_e), float(st.input.theta_e)}, ranges);
    const auto& p = est.akf().covariance();
    ASSERT_TRUE(p.allFinite()) << "cycle " << k;
    ASSERT_TRUE((p.diagonal().array() > 0.0f).all()) << "cycle " << k;
    ASSERT_EQ(p, p.transpose()) << "cycle " << k;
  }
}

TEST(AkfSparse, HeldStatesLeaveTheFilterAsIfAbsent) {
  // A model of more than 16 states updates only the states with variance (Akf::kSparse).
  // With every wall offset held, it must filter exactly like the small model without them
  // (dense loops), though the held states have non-zero columns in every beam's H.
  using effects::RangeBias;
  using effects::TurnSlip;
  using Small = Model<DiffDrive<double>, TurnSlip, RangeBias>;
  using Large = Model<DiffDrive<double>, TurnSlip, effects::WallOffsetN<16>, RangeBias>;
  static_assert(Small::kStates <= 16 && Large::kStates > 16);
  DiffDrive<double> drive;
  drive.wheelbase = 0.5;
  SegmentMap<double, 8> map;
  ASSERT_TRUE(map.add({0, 0, 10, 0}));
  ASSERT_TRUE(map.add({10, 0, 10, 10}));
  ASSERT_TRUE(map.add({10, 10, 0, 10}));
  ASSERT_TRUE(map.add({0, 10, 0, 0}));
  Akf<Small> small{Small(drive)};
  Akf<Large> large{Large(drive)};
  Small::StateVec xs;
  Small::setNominal(xs);
  xs.head<3>() << 5.0, 4.0, 0.3;
  Small::StateVec sig_s;
  sig_s << 0.02, 0.02, 0.01, 0.01, 0.01, 0.01, 0.05, 0.03;
  Large::StateVec xl;
  Large::setNominal(xl);
  Large::StateVec sig_l = Large::StateVec::Zero();  // the wall offsets held: sigma 0
  constexpr int kTs = Small::offsetOf<TurnSlip>();
  constexpr int kRb = Small::offsetOf<RangeBias>();
  constexpr int kTsL = Large::offsetOf<TurnSlip>();
  constexpr int kRbL = Large::offsetOf<RangeBias>();
  const int map_s[8] = {0, 1, 2, 3, 4, 5, kTsL, kRbL};  // small index -> large index
  for (int i = 0; i < 8; ++i) {
    xl[map_s[i]] = xs[i];
    sig_l[map_s[i]] = sig_s[i];
  }
  static_assert(kTs == 6 && kRb == 7);
  small.init(xs, sig_s.cwiseAbs2().asDiagonal());
  large.init(xl, sig_l.cwiseAbs2().asDiagonal());
  LaserConfig<double> cfg;
  const auto laser = geometry(cfg);
  // A robot whose turns slip and whose laser reads 3 cm long: both filters move.
  double tx = 5.0, ty = 4.0, tth = 0.3;
  double ranges[kMaxBeams];
  const Eigen::Matrix<double, 1, 1> k(1e-6);
  for (int step = 0; step < 400; ++step) {
    const double r = 0.010, l = step % 100 < 50 ? 0.006 : 0.012;
    const double dth = 0.97 * (r - l) / 0.5, ds = 0.5 * (r + l);
    tx += ds * std::cos(tth + 0.5 * dth);
    ty += ds * std::sin(tth + 0.5 * dth);
    tth += dth;
    ASSERT_EQ(small.predict({r, l}, k), Status::kOk);
    ASSERT_EQ(large.predict({r, l}, k), Status::kOk);
    if (step % 10 != 9) continue;
    for (int i = 0; i < laser.beams(); ++i) {
      const double a = tth + cfg.angle_min + i * cfg.angle_inc;
      double best = 1e9;
      const double ca = std::cos(a), sa = std::sin(a);
      if (ca > 1e-9) best = std::min(best, (10 - tx) / ca);
      if (ca < -1e-9) best = std::min(best, -tx / ca);
      if (sa > 1e-9) best = std::min(best, (10 - ty) / sa);
      if (sa < -1e-9) best = std::min(best, -ty / sa);
      ranges[i] = best + 0.03;
    }
    const auto ss = small.updateScan(map, laser, ranges);
    const auto sl = large.updateScan(map, laser, ranges);
    ASSERT_EQ(ss.used, sl.used) << "scan at step " << step;
    ASSERT_GT(ss.used, 0);
  }
  for (int i = 0; i < 8; ++i) {
    EXPECT_NEAR(large.state()[map_s[i]], small.state()[i], 1e-12 * (1 + std::abs(small.state()[i]))) << i;
    for (int j = 0; j < 8; ++j) {
      const double ps = small.covariance()(i, j);
      EXPECT_NEAR(large.covariance()(map_s[i], map_s[j]), ps, 1e-12 * std::sqrt(small.covariance()(i, i) * small.covariance()(j, j)))
          << i << "," << j;
    }
  }
  for (int i = 0; i < Large::kStates; ++i) {
    if (sig_l[i] == 0) {
      EXPECT_EQ(large.covariance().row(i).cwiseAbs().maxCoeff(), 0.0) << "held state " << i;
    }
  }
  EXPECT_GT(std::abs(small.state()[kRb]), 0.01) << "the range bias was estimated";
}

namespace {

/// Records a closed-loop drive with the double filter, then replays the same inputs
/// through a float and a double estimator; returns the worst |x_f - x_d| / sigma_d.
template <template <typename> class DriveT>
double floatDoubleWorstSigma(std::uint64_t seed, int steps) {
  SimConfig cfg;
  cfg.steps = steps;
  FilterSetup setup;
  std::vector<SimStep<DriveT<double>>> rec;
  (void)runDrive<double, DriveT>(cfg, seed, NonSysStart::kLarge, setup, steps,
                                 [&rec](const SimStep<DriveT<double>>& s) { rec.push_back(s); });
  PaperSim<DriveT<double>> sim(cfg, seed);
  auto ed = makeEstimator<double, DriveT>(sim, setup, NonSysStart::kLarge);
  auto ef = makeEstimator<float, DriveT>(sim, setup, NonSysStart::kLarge);
  double worst = 0;
  double rf[kMaxBeams];
  float rff[kMaxBeams];
  for (const auto& s : rec) {
    for (int i = 0; i < 36; ++i) {
      rf[i] = s.ranges[i];
      rff[i] = float(s.ranges[i]);
    }
    (void)ed.cycle(s.input, rf);
    (void)ef.cycle(convertInput<typename DriveT<float>::Input>(s.input), rff);
    const auto& xd = ed.akf().state();
    const auto& xf = ef.akf().state();
    const auto& pd = ed.akf().covariance();
    for (int i = 0; i < xd.size(); ++i) {
      double diff = double(xf[i]) - xd[i];
      if (i == 2) diff = wrapAngle(diff);
      worst = std::max(worst, std::abs(diff) / std::sqrt(pd(i, i)));
    }
  }
  // The OF estimates agree too (relative), at the end.
  for (int i = 0; i < ed.of().estimate().size(); ++i) {
    EXPECT_NEAR(double(ef.of().estimate()[i]), ed.of().estimate()[i], 0.05 * ed.of().estimate()[i]);
  }
  return worst;
}

}  // namespace

TEST(FloatDouble, SyncAgreesInUnitsOfSigma) {
  EXPECT_LT(floatDoubleWorstSigma<SyncDrive>(5, 3000), 0.25);
}

TEST(FloatDouble, DiffAgreesInUnitsOfSigma) {
  EXPECT_LT(floatDoubleWorstSigma<DiffDrive>(6, 3000), 0.25);
}

namespace {
const Stat& at30(const CaseResult& c, int q) { return c.params.back()[q]; }
}  // namespace

TEST(MonteCarlo, SyncConvergesWithSmallPoseError) {
  PaperOptions opt;
  opt.drive = DriveKind::kSync;
  opt.runs = 10;
  opt.seed = 1000;
  const PaperResult r = runPaperExperiment(opt);
  const double deg = kPi<double> / 180.0;
  for (const CaseResult& c : r.cases) {
    EXPECT_NEAR(at30(c, 0).mean, 1.1, 0.006) << toString(c.start);
    EXPECT_LT(at30(c, 0).accuracy_pct, 1.5);
    EXPECT_NEAR(at30(c, 1).mean, 1.0 * deg, 0.25 * deg);
    EXPECT_LT(c.pos_rms_m.back(), 0.007);
    EXPECT_LT(c.heading_rms_rad.back(), 0.12 * deg);
    for (int q = 2; q < 4; ++q) {
      const double ratio = at30(c, q).mean / at30(c, q).truth;
      EXPECT_GT(ratio, 0.1) << c.names[q];
      EXPECT_LT(ratio, 3.0) << c.names[q];
    }
    EXPECT_EQ(c.rejected, 0u);
  }
}

TEST(MonteCarlo, DiffConvergesWithSmallPoseError) {
  PaperOptions opt;
  opt.drive = DriveKind::kDiff;
  opt.runs = 10;
  opt.seed = 2000;
  const PaperResult r = runPaperExperiment(opt);
  for (const CaseResult& c : r.cases) {
    EXPECT_NEAR(at30(c, 0).mean, 1.1, 0.011) << toString(c.start);
    EXPECT_NEAR(at30(c, 1).mean, 0.9, 0.009);
    EXPECT_LT(at30(c, 0).accuracy_pct, 2.5);
    EXPECT_LT(at30(c, 1).accuracy_pct, 2.5);
    EXPECT_LT(c.pos_rms_m.back(), 0.006);
    EXPECT_LT(c.heading_rms_rad.back(), 0.12 * kPi<double> / 180.0);
    const double ratio = at30(c, 3).mean / at30(c, 3).truth;
    EXPECT_GT(ratio, 0.2);
    EXPECT_LT(ratio, 2.0);
  }
}

namespace {
PaperResult runWithPoseTerm(DriveKind d, PoseErrorTerm term) {
  PaperOptions opt;
  opt.drive = d;
  opt.runs = 6;
  opt.seed = 3000;
  opt.setup.of.pose_term = term;
  return runPaperExperiment(opt);
}
}  // namespace

TEST(LiteralPoseTerm, SyncCollapsesAndTheAkfDiverges) {
  const PaperResult lit = runWithPoseTerm(DriveKind::kSync, PoseErrorTerm::kLiteral);
  const PaperResult exp = runWithPoseTerm(DriveKind::kSync, PoseErrorTerm::kExpected);
  for (int s = 0; s < 2; ++s) {
    for (int q = 2; q < 4; ++q) {
      const double lit_ratio = at30(lit.cases[s], q).mean / at30(lit.cases[s], q).truth;
      const double exp_ratio = at30(exp.cases[s], q).mean / at30(exp.cases[s], q).truth;
      EXPECT_LT(lit_ratio, 0.05) << "literal R should drive " << lit.cases[s].names[q] << " to 0";
      EXPECT_GT(exp_ratio, 0.2) << "expected R keeps " << exp.cases[s].names[q];
    }
    EXPECT_GT(lit.cases[s].pos_rms_m.back(), 0.02) << "the AKF diverges once K collapses";
    EXPECT_GT(lit.cases[s].pos_rms_m.back(), 4 * exp.cases[s].pos_rms_m.back());
    EXPECT_LT(exp.cases[s].pos_rms_m.back(), 0.008);
  }
}

TEST(LiteralPoseTerm, DiffCollapsesTowardsZero) {
  const PaperResult lit = runWithPoseTerm(DriveKind::kDiff, PoseErrorTerm::kLiteral);
  const PaperResult exp = runWithPoseTerm(DriveKind::kDiff, PoseErrorTerm::kExpected);
  for (int s = 0; s < 2; ++s) {
    const double lit_ratio = at30(lit.cases[s], 3).mean / at30(lit.cases[s], 3).truth;
    const double exp_ratio = at30(exp.cases[s], 3).mean / at30(exp.cases[s], 3).truth;
    EXPECT_LT(lit_ratio, 0.5 * exp_ratio) << toString(lit.cases[s].start);
    EXPECT_GT(exp_ratio, 0.4);
  }
}

TEST(ObservableFilter, RecoversAfterAWindowOverflow) {
  SegmentMap<double, 8> map;
  auto akf = makeRoomAkf(map);
  ObservableFilter<SyncModel> of;
  of.init(SyncDrive<double>::NonSysVec(1e-3, 3e-4), SyncDrive<double>::NonSysVec(1e-6, 1e-7).asDiagonal());
  of.begin(akf);
  const SyncDrive<double>::Input u{0.01, 0.002};
  // More inputs than the window holds, without a step in between: the window overflows.
  for (int i = 0; i < 40; ++i) of.addInput(u);
  EXPECT_GE(of.counters().broken_windows, 1u);
  EXPECT_FALSE(of.step(akf, true)) << "an overflowed window is discarded, not fused";
  // The next window works again.
  ASSERT_EQ(akf.predict(u, of.estimate()), Status::kOk);
  of.addInput(u);
  EXPECT_TRUE(of.step(akf, true));
  EXPECT_EQ(of.counters().updates, 1u);
}
