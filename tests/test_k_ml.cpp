// The recursive maximum-likelihood estimator of K (core/include/odoerr/k_ml.hpp): how it
// behaves on closed-loop drives (Monte Carlo from both starts, the inflation, the discount and
// the credit, the heading noise's scale). Its whole-scan update: test_k_ml_scan.cpp; its score
// against the likelihood's finite differences: test_k_ml_score.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <utility>
#include <vector>

#include "odoerr/sim/runner.hpp"
#include "odoerr/sim/random.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

/// The sync model the paper estimator uses.
using SyncEst = decltype(makeEstimator<double, SyncDrive>(std::declval<const PaperSim<SyncDrive<double>>&>(),
                                                          std::declval<const FilterSetup&>(), NonSysStart::kSmall));
using SyncModel = SyncEst::Model;

struct McStats {
  double k_ratio[2] = {0, 0};   ///< mean K / truth (first two K components at most)
  double k_spread[2] = {0, 0};  ///< population std of K / truth
  double k_sigma[2] = {0, 0};   ///< mean reported sigma / truth
  double sys_spread = 0;        ///< population std of the first systematic parameter / truth
  double sys_sigma = 0;         ///< its mean reported sigma / truth
  double sys_end[64] = {};      ///< its end value / truth, run by run (the first 64 runs)
  double sys2_spread = 0;       ///< the same for the second one (E_theta on sync)
  double sys2_sigma = 0;        ///< its mean reported sigma / truth
};

/// A small Monte Carlo of `runs` closed-loop drives of `metres` with --of ml from `start`
/// (on the circle, or the figure-eight when `eight`).
template <template <typename> class DriveT>
McStats monteCarlo(int runs, int metres, NonSysStart start, const KMlConfig<double>& mc,
                   OfKind of = OfKind::kMl, bool eight = false) {
  using D = DriveT<double>;
  using L = TraceLayout<D>;
  SimConfig cfg;
  cfg.steps = metres * 100;
  if (eight) {  // as odoerr paper --path eight
    cfg.figure_eight = true;
    cfg.radius = 2.0;
  }
  FilterSetup setup;
  PaperSim<D> sim(cfg, 0);
  const auto kt = sim.trueNonSys();
  const double p0 = sim.trueParams()[0];
  const int m = D::kNonSys < 2 ? D::kNonSys : 2;
  std::vector<double> k[2], sg[2], sys, sys_sigma, sys2, sys2_sigma;
  const double p1 = D::kParams > 1 ? sim.trueParams()[1] : 1.0;
  for (int r = 0; r < runs; ++r) {
    const Trace t = runDrive<double, DriveT>(cfg, 1 + std::uint64_t(r), start, setup, cfg.steps, nullptr, of, mc);
    const double* row = &t.values[(t.distance_m.size() - 1) * std::size_t(t.width)];
    for (int i = 0; i < m; ++i) {
      k[i].push_back(row[L::kValue + L::kP + i] / kt[i]);
      sg[i].push_back(row[L::kSigma + L::kP + i] / kt[i]);
    }
    sys.push_back(row[L::kValue] / p0);
    sys_sigma.push_back(row[L::kSigma] / p0);
    if (D::kParams > 1) {
      sys2.push_back(row[L::kValue + 1] / p1);
      sys2_sigma.push_back(row[L::kSigma + 1] / p1);
    }
  }
  auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return s / double(v.size());
  };
  auto spread = [&](const std::vector<double>& v) {
    const double mu = mean(v);
    double s = 0;
    for (double x : v) s += (x - mu) * (x - mu);
    return std::sqrt(s / double(v.size()));
  };
  McStats st;
  for (int i = 0; i < m; ++i) {
    st.k_ratio[i] = mean(k[i]);
    st.k_spread[i] = spread(k[i]);
    st.k_sigma[i] = mean(sg[i]);
  }
  st.sys_spread = spread(sys);
  st.sys_sigma = mean(sys_sigma);
  for (std::size_t r = 0; r < sys.size() && r < 64; ++r) st.sys_end[r] = sys[r];
  if (!sys2.empty()) {
    st.sys2_spread = spread(sys2);
    st.sys2_sigma = mean(sys2_sigma);
  }
  return st;
}

void print(const char* what, const McStats& s) {
  std::printf("%s: K0 %.3fx spread %.3f sigma %.3f | K1 %.3fx spread %.3f sigma %.3f | sys spread %.4f\n", what,
              s.k_ratio[0], s.k_spread[0], s.k_sigma[0], s.k_ratio[1], s.k_spread[1], s.k_sigma[1], s.sys_spread);
}

}  // namespace

// Before any step, J is empty: the AKF's K is the estimate times the smaller of the two caps
// (inflate on), or the estimate itself (inflate off).
TEST(KMl, FilterKInflatedWhileNoInformation) {
  KMlConfig<double> c;
  c.inflate = 2;
  c.max_inflate_log = std::log(100.0);
  KMaxLikelihood<SyncModel>::KVec k0(1e-5, 3e-6);
  {
    KMaxLikelihood<SyncModel> ml(c);  // the start's cap, 10x by default
    ml.init(k0);
    EXPECT_NEAR(ml.filterK()[0], 1e-4, 1e-12);
    EXPECT_NEAR(ml.filterK()[1], 3e-5, 1e-12);
    EXPECT_EQ(ml.estimate(), k0);
  }
  c.max_start_inflate_log = std::log(1000.0);  // then max_inflate_log caps it
  KMaxLikelihood<SyncModel> ml(c);
  ml.init(k0);
  EXPECT_NEAR(ml.filterK()[0], 1e-3, 1e-12);
  EXPECT_NEAR(ml.filterK()[1], 3e-4, 1e-12);
  EXPECT_EQ(ml.estimate(), k0);
  c.inflate = 0;
  KMaxLikelihood<SyncModel> plain(c);
  plain.init(k0);
  EXPECT_EQ(plain.filterK(), k0);
}

// From 100x below the truth, 100 runs of 10 m on the sync drive: with the restarts and the
// inflated filter K (the defaults) K reaches the truth's neighbourhood, the reported sigma
// follows the spread, and delta_rho keeps its spread near the plain recursion's (no restart,
// no inflation, printed beside them) and under the paper OF's.
TEST(KMl, ConvergesFromBelowSync) {
  const KMlConfig<double> def;
  KMlConfig<double> old = def;
  old.reset_log = 0;
  old.inflate = 0;
  const McStats below = monteCarlo<SyncDrive>(100, 10, NonSysStart::kSmall, def);
  const McStats above = monteCarlo<SyncDrive>(100, 10, NonSysStart::kLarge, def);
  const McStats below_old = monteCarlo<SyncDrive>(100, 10, NonSysStart::kSmall, old);
  const McStats below_of = monteCarlo<SyncDrive>(100, 10, NonSysStart::kSmall, def, OfKind::kPaper);
  print("below (defaults)", below);
  print("below (the paper's OF)", below_of);
  print("above (defaults)", above);
  print("below (no restart, no inflation)", below_old);
  for (int i = 0; i < 2; ++i) {
    EXPECT_GT(below.k_ratio[i], 0.8) << "K" << i;
    EXPECT_LT(below.k_ratio[i], 1.35) << "K" << i;
    const double honesty = below.k_sigma[i] / below.k_spread[i];
    EXPECT_GT(honesty, 0.5) << "K" << i << " sigma too small against the spread";
    EXPECT_LT(honesty, 2.0) << "K" << i << " sigma too large against the spread";
  }
  // delta_rho's spread from below at 10 m: near the plain recursion's and the paper OF's from
  // the same start (printed: 1.05x and 1.02x; the discount, which reopens delta_rho while K
  // climbs, costs it a little at 10 m; at 30 m it is 0.55 % like the OF's 0.54 %,
  // docs/nonsystematic.md). 20 runs were too few to tell: their ratio to the OF moved
  // between 0.8x and 1.1x with changes that moved 300 runs' by 4 %.
  EXPECT_LT(below.sys_spread, 1.2 * below_old.sys_spread) << "delta_rho damaged from below";
  EXPECT_LT(below.sys_spread, 1.1 * below_of.sys_spread) << "delta_rho damaged from below";
}

// From 100x below, what the AKF learns of the systematic parameters while the K it predicts
// with is still far too small is overconfident; when K rises the driver discounts it
// (MlDriver::discount). 40 runs of 30 m on the sync drive: E_theta's spread with the discount
// is well under the spread without it (printed: 0.78x) and near the paper OF's from the same
// start (1.11x), and its reported sigma is honest (docs/nonsystematic.md, 100 runs: 19.5 %
// against 24.5 %, the OF 19.3 %).
TEST(KMl, DiscountKeepsEThetaFromBelowSync) {
  const KMlConfig<double> def;
  ASSERT_TRUE(def.discount);
  KMlConfig<double> off = def;
  off.discount = false;
  const McStats on = monteCarlo<SyncDrive>(40, 30, NonSysStart::kSmall, def);
  const McStats without = monteCarlo<SyncDrive>(40, 30, NonSysStart::kSmall, off);
  const McStats of = monteCarlo<SyncDrive>(40, 30, NonSysStart::kSmall, def, OfKind::kPaper);
  std::printf("E_theta spread / truth at 30 m: discount %.3f (sigma %.3f), none %.3f (sigma %.3f), paper OF %.3f\n",
              on.sys2_spread, on.sys2_sigma, without.sys2_spread, without.sys2_sigma, of.sys2_spread);
  EXPECT_LT(on.sys2_spread, 0.85 * without.sys2_spread);
  EXPECT_LT(on.sys2_spread, 1.3 * of.sys2_spread);
  const double honesty = on.sys2_sigma / on.sys2_spread;
  EXPECT_GT(honesty, 1 / 1.5);
  EXPECT_LT(honesty, 1.5);
  EXPECT_LT(on.sys_spread, 1.3 * of.sys_spread) << "delta_rho";
}

// The variance-scale model of the score (KMlConfig::scale_shift) against the score computed
// beam by beam: with every beam's share of s from K equal it is exact, whatever the
// innovations; with no innovation (saturated data) it stays at -h while the Gauss-Newton line
// climbs by I d.
TEST(KMl, ScaleShiftedScoreIsExactForEqualShares) {
  std::mt19937 rng(7);
  odoerr::sim::NormalDist<double> n01(0, 1);
  odoerr::sim::UniformDist<double> u(0.2, 3.0);
  const double kf = 2e-3;
  for (const double abar : {0.1, 0.5, 0.9, 1.0}) {
    for (const double d : {0.01, 0.5, 2.0, 4.6}) {
      for (const double nis_scale : {0.0, 0.02, 1.0, 5.0}) {
        // beam j: s_j(K) = c_j (1 - abar) + c_j abar K / kf, so its share at K_f is abar
        double g = 0, h = 0, exact = 0;
        const double k = kf * std::exp(-d);
        for (int j = 0; j < 40; ++j) {
          const double c = u(rng);
          const double nu = std::sqrt(nis_scale * c) * n01(rng);
          const double sf = c;
          g += -0.5 * abar * (1 - nu * nu / sf);
          h += 0.5 * abar;
          const double sk = c * (1 - abar) + c * abar * k / kf;
          const double ak = c * abar * k / kf / sk;
          exact += -0.5 * ak * (1 - nu * nu / sk);
        }
        EXPECT_NEAR(scaleShiftedScore(g, h, abar, d), exact, 1e-9 * (1 + std::abs(exact)))
            << "abar " << abar << " d " << d << " nis " << nis_scale;
      }
    }
  }
  // Saturated (g = -h): the model stays at -h; the line g + I d with I = abar h climbs.
  const double h = 5, abar = 1;
  EXPECT_NEAR(scaleShiftedScore(-h, h, abar, 2.0), -h, 1e-12);
  EXPECT_GT(-h + abar * h * 2.0, 0.0);
  // Near the maximum (g = 0) both agree to first order.
  const double dd = 1e-4;
  EXPECT_NEAR(scaleShiftedScore(0.0, h, 0.4, dd), 0.4 * h * dd, 1e-6);
}

// From 100x above, 20 runs of 1 m on the sync drive: the line (scale_shift off) turns the
// saturated score into a push upwards, so K has come down far less (printed; 100 runs:
// 38x against 8x the truth at 1 m, docs/nonsystematic.md).
TEST(KMl, ScaleShiftDescendsFromAboveSync) {
  const KMlConfig<double> def;
  ASSERT_TRUE(def.scale_shift);
  KMlConfig<double> line = def;
  line.scale_shift = false;
  const McStats s = monteCarlo<SyncDrive>(20, 1, NonSysStart::kLarge, def);
  const McStats l = monteCarlo<SyncDrive>(20, 1, NonSysStart::kLarge, line);
  std::printf("K / truth at 1 m from 100x above: scale shift %.1fx %.1fx, line %.1fx %.1fx\n", s.k_ratio[0],
              s.k_ratio[1], l.k_ratio[0], l.k_ratio[1]);
  for (int i = 0; i < 2; ++i) EXPECT_LT(s.k_ratio[i], 0.5 * l.k_ratio[i]) << "K" << i;
}

// From 100x above, 20 runs of 1 m on the sync drive: the step's solve iterated along the
// variance-scale model (KMlConfig::solve_iters) brings K down far faster than one
// Gauss-Newton step a K step (printed; 100 runs: 2.4x against 8.1x the truth at 1 m).
TEST(KMl, IteratedSolveDescendsFromAboveSync) {
  const KMlConfig<double> def;
  ASSERT_GT(def.solve_iters, 1);
  KMlConfig<double> one = def;
  one.solve_iters = 1;
  const McStats s = monteCarlo<SyncDrive>(20, 1, NonSysStart::kLarge, def);
  const McStats o = monteCarlo<SyncDrive>(20, 1, NonSysStart::kLarge, one);
  std::printf("K / truth at 1 m from 100x above: iterated %.1fx %.1fx, one step %.1fx %.1fx\n", s.k_ratio[0],
              s.k_ratio[1], o.k_ratio[0], o.k_ratio[1]);
  for (int i = 0; i < 2; ++i) EXPECT_LT(s.k_ratio[i], 0.5 * o.k_ratio[i]) << "K" << i;
}

// The credit from above (KMlConfig::credit, synchronous drive): when every K falls from 100x
// above while the AKF predicts with an inflated K, what it gathered on delta_rho since its
// prior came under a Q too large and is credited by the fall. Without it, delta_rho's sigma
// overstates its spread across runs, and the AKF goes on weighing new data too much
// (docs/nonsystematic.md "The credit from above"; these 40 runs at 10 m: sigma / spread 1.23
// with it, 1.40 without). With it sigma is lower and nearer the spread, honest within 1.5x.
TEST(KMl, CreditBringsDeltaRhoSigmaToItsSpreadFromAboveSync) {
  const KMlConfig<double> def;
  ASSERT_TRUE(def.credit);
  KMlConfig<double> off = def;
  off.credit = false;
  const McStats on = monteCarlo<SyncDrive>(40, 10, NonSysStart::kLarge, def);
  const McStats no = monteCarlo<SyncDrive>(40, 10, NonSysStart::kLarge, off);
  const double h_on = on.sys_sigma / on.sys_spread;
  const double h_off = no.sys_sigma / no.sys_spread;
  std::printf("delta_rho at 10 m from above: credit sigma %.4f spread %.4f (%.2fx), none sigma %.4f spread %.4f "
              "(%.2fx)\n",
              on.sys_sigma, on.sys_spread, h_on, no.sys_sigma, no.sys_spread, h_off);
  EXPECT_LT(on.sys_sigma, 0.93 * no.sys_sigma);
  EXPECT_LT(std::abs(std::log(h_on)), std::abs(std::log(h_off)));
  EXPECT_LT(h_on, 1.5);
  EXPECT_GT(h_on, 1 / 1.5);
}

// The credit acts only in runs whose first K step lowered every K, and only on the synchronous
// drive: on the differential drive (whose Q depends on delta_d, where it was harmful) the runs
// are the same, bit for bit, with it on or off, and so are these 8 runs from below (seeds
// 1-8), whose first step raises K. Not every run from below does: 5 of seeds 1-300 at 30 m
// have a first step that lowers every K, and are credited (docs/nonsystematic.md).
TEST(KMl, CreditLeavesBelowAndDiffUntouched) {
  KMlConfig<double> off;
  off.credit = false;
  const McStats sb = monteCarlo<SyncDrive>(8, 5, NonSysStart::kSmall, KMlConfig<double>{});
  const McStats sb_off = monteCarlo<SyncDrive>(8, 5, NonSysStart::kSmall, off);
  const McStats da = monteCarlo<DiffDrive>(8, 5, NonSysStart::kLarge, KMlConfig<double>{});
  const McStats da_off = monteCarlo<DiffDrive>(8, 5, NonSysStart::kLarge, off);
  const McStats sa = monteCarlo<SyncDrive>(8, 5, NonSysStart::kLarge, KMlConfig<double>{});
  const McStats sa_off = monteCarlo<SyncDrive>(8, 5, NonSysStart::kLarge, off);
  int differ_above = 0;
  for (int r = 0; r < 8; ++r) {
    EXPECT_EQ(sb.sys_end[r], sb_off.sys_end[r]) << "sync from below, run " << r;
    EXPECT_EQ(da.sys_end[r], da_off.sys_end[r]) << "diff from above, run " << r;
    differ_above += sa.sys_end[r] != sa_off.sys_end[r] ? 1 : 0;
  }
  EXPECT_EQ(differ_above, 8);  // and from above on sync it acts in every run
}

// The differential drive on the figure-eight from 100x below, 100 runs of 30 m: deflating each
// step's information on K_w by delta_d's uncertainty (KMlConfig::deflate) narrows K_w's spread
// (printed; docs/nonsystematic.md) and keeps its mean and its sigma honest.
TEST(KMl, DeflationNarrowsKwFromBelowOnTheEight) {
  KMlConfig<double> def;
  ASSERT_TRUE(def.deflate);
  def.heading_scale = false;  // the deflation is for K_w alone
  // Measured with the inflation's start cap at the general one (30x), as when the deflation
  // was chosen: with the default 10x start (max_start_inflate_log) both narrow, 0.057
  // against 0.059 (measured at commit ecc54b2).
  def.max_start_inflate_log = def.max_inflate_log;
  KMlConfig<double> whole = def;
  whole.deflate = false;
  const McStats on = monteCarlo<DiffDrive>(100, 30, NonSysStart::kSmall, def, OfKind::kMl, true);
  const McStats off = monteCarlo<DiffDrive>(100, 30, NonSysStart::kSmall, whole, OfKind::kMl, true);
  std::printf("K_w at 30 m from below on the eight: deflated %.3fx spread %.3f sigma %.3f, whole %.3fx spread %.3f "
              "sigma %.3f\n",
              on.k_ratio[0], on.k_spread[0], on.k_sigma[0], off.k_ratio[0], off.k_spread[0], off.k_sigma[0]);
  EXPECT_LT(on.k_spread[0], 0.95 * off.k_spread[0]);
  EXPECT_NEAR(on.k_ratio[0], 1.0, 0.05);
  const double honesty = on.k_sigma[0] / on.k_spread[0];
  EXPECT_GT(honesty, 1 / 1.5);
  EXPECT_LT(honesty, 1.5);
}

namespace {

/// K_w at 30 m, 100 runs of the differential drive from `start` (on the figure-eight when
/// `eight`), with the heading noise's scale estimated (KMlConfig::heading_scale, the default)
/// and with K_w alone, printed; the estimate's sigma must be honest (within 1.5x its spread).
std::pair<McStats, McStats> headingScaleAgainstKwAlone(NonSysStart start, bool eight, const char* what) {
  const KMlConfig<double> def;
  EXPECT_TRUE(def.heading_scale);
  KMlConfig<double> alone = def;
  alone.heading_scale = false;
  const McStats on = monteCarlo<DiffDrive>(100, 30, start, def, OfKind::kMl, eight);
  const McStats off = monteCarlo<DiffDrive>(100, 30, start, alone, OfKind::kMl, eight);
  std::printf("K_w at 30 m %s: with c %.3fx spread %.3f sigma %.3f, alone %.3fx spread %.3f sigma %.3f; "
              "delta_R spread %.4f / %.4f\n",
              what, on.k_ratio[0], on.k_spread[0], on.k_sigma[0], off.k_ratio[0], off.k_spread[0], off.k_sigma[0],
              on.sys_spread, off.sys_spread);
  const double honesty = on.k_sigma[0] / on.k_spread[0];
  EXPECT_GT(honesty, 1 / 1.5);
  EXPECT_LT(honesty, 1.5);
  return {on, off};
}

}  // namespace

// The figure-eight from 100x below: estimating the heading noise's scale beside K_w (c =
// 1 / delta_d^2 as the noise sees it) narrows K_w's spread against deflating by delta_d's
// uncertainty (docs/nonsystematic.md "K_w and delta_d"), its mean within 5 %.
TEST(KMl, HeadingScaleNarrowsKwFromBelowOnTheEight) {
  const auto [on, off] = headingScaleAgainstKwAlone(NonSysStart::kSmall, true, "from below on the eight");
  EXPECT_LT(on.k_spread[0], 0.9 * off.k_spread[0]);
  EXPECT_NEAR(on.k_ratio[0], 1.0, 0.05);
}

// The circle from 100x above: there the AKF does not learn delta_d (it stays near its prior's
// 1.0 against the true 1.1), and K_w read through it was 0.87x the truth; with c estimated it
// is within 5 % (printed: 0.980x against 0.872x).
TEST(KMl, HeadingScaleLiftsKwOnTheCircleFromAbove) {
  const auto [on, off] = headingScaleAgainstKwAlone(NonSysStart::kLarge, false, "from above on the circle");
  EXPECT_NEAR(on.k_ratio[0], 1.0, 0.05);
  EXPECT_LT(off.k_ratio[0], 0.95) << "the bias this removes is gone by itself: the test no longer tests it";
  EXPECT_LT(on.k_spread[0], off.k_spread[0]);
}

// The circle from 100x below: c is held at the AKF's own while the AKF predicts with an
// inflated K (KMaxLikelihood::step). Moved then, c wandered with the score carried down from
// the inflated K, and the AKF's delta_R spread 1.5x the paper OF's (at commit 0320658: 1.18 %
// against 0.8 %); left out of J, K_w came out 0.92x. Held, K_w is within 5 % with a smaller
// spread than K_w alone, and delta_R spreads as with the paper's OF (printed).
TEST(KMl, HeadingScaleHoldsCWhileInflatedFromBelowOnTheCircle) {
  const auto [on, off] = headingScaleAgainstKwAlone(NonSysStart::kSmall, false, "from below on the circle");
  const McStats of = monteCarlo<DiffDrive>(100, 30, NonSysStart::kSmall, KMlConfig<double>{}, OfKind::kPaper);
  std::printf("delta_R spread with the paper's OF %.4f\n", of.sys_spread);
  EXPECT_NEAR(on.k_ratio[0], 1.0, 0.05);
  EXPECT_LT(on.k_spread[0], off.k_spread[0]);
  EXPECT_LT(on.sys_spread, 1.15 * of.sys_spread);
}

// The reported covariance of K_w carries delta_d's uncertainty (the data fix K_w / delta_d^2):
// var(log K_w) gains 4 P_dd / delta_d^2. The sync drive's Q does not depend on its parameters.
TEST(KMl, CovarianceWithSystematicAddsDeltaDOnDiff) {
  using DiffEst = decltype(makeEstimator<double, DiffDrive>(std::declval<const PaperSim<DiffDrive<double>>&>(),
                                                            std::declval<const FilterSetup&>(), NonSysStart::kSmall));
  using DiffModel = DiffEst::Model;
  using D = DiffModel::Drive;
  KMlConfig<double> c;
  c.inflate = 0;
  c.heading_scale = false;  // with c estimated, covariance() holds delta_d's share itself
  KMaxLikelihood<DiffModel> ml(c);
  KMaxLikelihood<DiffModel>::KVec k0;
  k0 << 2.5e-4;
  ml.init(k0);
  KMaxLikelihood<DiffModel>::StateVec x = KMaxLikelihood<DiffModel>::StateVec::Zero();
  KMaxLikelihood<DiffModel>::StateMat p = KMaxLikelihood<DiffModel>::StateMat::Identity() * 1e-6;
  constexpr int kD = DiffModel::kDriveOffset + D::kDeltaD;
  x[kD] = 1.1;
  p(kD, kD) = 0.01;  // sigma(delta_d) 0.1, 9.1 %
  const double base = ml.covariance()(0, 0);
  const double with = ml.covarianceWithSystematic(x, p)(0, 0);
  EXPECT_NEAR(with - base, k0[0] * k0[0] * 4 * 0.01 / (1.1 * 1.1), 1e-18);
  KMaxLikelihood<SyncModel> sml(c);
  sml.init(KMaxLikelihood<SyncModel>::KVec(1e-3, 3e-4));
  KMaxLikelihood<SyncModel>::StateVec xs = KMaxLikelihood<SyncModel>::StateVec::Ones();
  KMaxLikelihood<SyncModel>::StateMat ps = KMaxLikelihood<SyncModel>::StateMat::Identity() * 0.01;
  EXPECT_EQ(sml.covarianceWithSystematic(xs, ps), sml.covariance());
}
