// diagnose's pose-fix statistics: the 3-dof NIS and its chi-square band against a Monte
// Carlo simulation of consistent fixes, the empty case (null and a note, never 0), and
// the physical bounds on named estimates.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Dense>

#include "diagnose/physical.hpp"
#include "odoerr/sim/stats.hpp"
#include "odoerr/sim/random.hpp"

using namespace odoerr::sim;
using json = nlohmann::ordered_json;

namespace {

/// n fixes whose innovations are drawn from N(0, S) with a random SPD S each (scale
/// `cov_scale` on the S the filter reports: 1 = consistent).
std::vector<PoseFixRec> drawFixes(std::mt19937& rng, int n, double cov_scale) {
  odoerr::sim::NormalDist<double> g(0, 1);
  odoerr::sim::UniformDist<double> u(-3.14, 3.14), sd(0.002, 0.05);
  std::vector<PoseFixRec> v;
  for (int k = 0; k < n; ++k) {
    Eigen::Matrix3d a;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a(i, j) = (i == j ? sd(rng) : 0.3 * sd(rng) * g(rng));
    const Eigen::Matrix3d s = a * a.transpose();
    const Eigen::Matrix3d l = s.llt().matrixL();
    const Eigen::Vector3d nu = std::sqrt(cov_scale) * (l * Eigen::Vector3d(g(rng), g(rng), g(rng)));
    PoseFixRec f{};
    f.t = k;
    f.th = u(rng);
    for (int i = 0; i < 3; ++i) f.nu[i] = nu[i];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) f.s[3 * i + j] = s(i, j);
    f.nis = nu.dot(s.ldlt().solve(nu));
    f.v = 0.2;
    f.w = g(rng);
    v.push_back(f);
  }
  return v;
}

}  // namespace

TEST(DiagnosePoseFix, ChiSquareQuantileMatchesMonteCarlo) {
  // 200000 3-dof NIS values: their empirical 2.5 % and 97.5 % quantiles against the exact ones.
  std::mt19937 rng(7);
  const std::vector<PoseFixRec> f = drawFixes(rng, 200000, 1.0);
  std::vector<double> nis;
  for (const auto& r : f) nis.push_back(r.nis);
  std::sort(nis.begin(), nis.end());
  const double q025 = nis[nis.size() * 25 / 1000], q975 = nis[nis.size() * 975 / 1000];
  EXPECT_NEAR(q025, chiSquareQuantile(0.025, 3), 0.01);  // 0.2158
  EXPECT_NEAR(q975, chiSquareQuantile(0.975, 3), 0.08);  // 9.348
  EXPECT_NEAR(chiSquareQuantile(0.975, 3), 9.3484, 1e-3);
}

TEST(DiagnoseStats, ChiSquareSurvivalAndBandMatchReferenceValues) {
  // Reference values from scipy.stats.chi2 (sf, ppf), an implementation independent of Boost.
  EXPECT_NEAR(chiSquareSf(3.841458820694124, 1), 0.05, 1e-12);
  EXPECT_NEAR(chiSquareSf(0.5, 3), 0.9188914116546758, 1e-12);
  EXPECT_NEAR(chiSquareSf(40, 20), 0.0049954123083075785, 1e-14);
  EXPECT_NEAR(chiSquareSf(1e-3, 2), 0.9995001249791693, 1e-12);
  EXPECT_NEAR(chiSquareSf(120, 60) / 6.876264968732136e-06, 1.0, 1e-9);
  EXPECT_EQ(chiSquareSf(0, 4), 1.0);
  EXPECT_EQ(chiSquareSf(-1, 4), 1.0);
  ChiSquareBand95 band;
  const auto b30 = band(30), b1 = band(1);
  EXPECT_NEAR(b30[0], 16.79077226556663, 1e-9);
  EXPECT_NEAR(b30[1], 46.97924224367115, 1e-9);
  EXPECT_NEAR(b1[0], 0.0009820691171752555, 1e-12);
  EXPECT_NEAR(b1[1], 5.023886187314888, 1e-9);
  EXPECT_EQ(band(30), b30);  // the cached value is the value
}

TEST(DiagnoseStats, NoncentralityForPowerMatchesTheNormalFormAndAMonteCarlo) {
  // k = 1: chi2_1(lambda) is (Z + sqrt(lambda))^2, so the power at threshold tau has a closed
  // form in the normal distribution, independent of Boost's non-central chi-square.
  for (const double tau : {10.83, 11.5, 20.0}) {
    for (const double power : {0.5, 0.8, 0.95}) {
      const double mu = std::sqrt(noncentralityForPower(1, tau, power)), r = std::sqrt(tau);
      const double p = 0.5 * std::erfc((r - mu) / std::sqrt(2.0)) + 0.5 * std::erfc((r + mu) / std::sqrt(2.0));
      EXPECT_NEAR(p, power, 1e-8) << "tau " << tau << " power " << power;
    }
  }
  // k = 3 at the ranking's threshold: 200,000 draws of |N(mean, I)|^2 with |mean|^2 = lambda.
  const double tau = chiSquareQuantile(1.0 - 1e-3, 3);
  const double lambda = noncentralityForPower(3, tau, 0.8);
  std::mt19937 rng(11);
  odoerr::sim::NormalDist<double> g(0, 1);
  int pass = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double a = g(rng) + std::sqrt(lambda), b = g(rng), c = g(rng);
    pass += a * a + b * b + c * c > tau ? 1 : 0;
  }
  EXPECT_NEAR(double(pass) / n, 0.8, 0.005);  // 3.5 standard errors of the fraction
  EXPECT_GT(noncentralityForPower(3, tau, 0.9), lambda);  // more power needs a larger effect
}

TEST(DiagnosePoseFix, MeanNisBandCoversConsistentRunsAtItsLevel) {
  // 2000 runs of 40 consistent fixes: the mean NIS falls outside its 95 % band on 5 % of
  // them (binomial sd 0.49 %), and a filter whose covariance is half the truth's fails.
  std::mt19937 rng(11);
  int outside = 0, consistent = 0;
  const int runs = 2000;
  for (int r = 0; r < runs; ++r) {
    bool ok = false;
    const json t = poseFixTests(drawFixes(rng, 40, 1.0), &ok);
    const double m = t["nis_mean"].get<double>();
    if (m < t["nis_band"][0].get<double>() || m > t["nis_band"][1].get<double>()) ++outside;
    consistent += ok;
  }
  EXPECT_NEAR(double(outside) / runs, 0.05, 0.015);
  EXPECT_GT(consistent, runs * 9 / 10);
  bool ok = true;
  const json bad = poseFixTests(drawFixes(rng, 40, 2.0), &ok);
  EXPECT_FALSE(ok) << bad.dump();
  EXPECT_GT(bad["nis_mean"].get<double>(), bad["nis_band"][1].get<double>());
}

TEST(DiagnosePoseFix, ComponentsAndWhitenessOfConsistentFixes) {
  std::mt19937 rng(3);
  bool ok = false;
  const json t = poseFixTests(drawFixes(rng, 400, 1.0), &ok);
  for (const char* k : {"along_m", "cross_m", "heading_rad"}) {
    EXPECT_NEAR(t["innovation"][k]["rms_norm"].get<double>(), 1.0, 0.15) << k;
    EXPECT_NEAR(t["innovation"][k]["mean_norm"].get<double>(), 0.0, 0.2) << k;
  }
  EXPECT_GT(t["whiteness"]["p_min"].get<double>(), 0.001);
  EXPECT_EQ(t["bins"]["turn_rate"].size(), 5u);
  EXPECT_TRUE(t["nees_pose"].is_null());
}

TEST(DiagnosePoseFix, EmptyDataIsNullWithANoteNeverZero) {
  bool ok = true;
  const json t = poseFixTests({}, &ok);
  EXPECT_FALSE(ok);
  EXPECT_TRUE(t["nis_mean"].is_null());
  EXPECT_TRUE(t["nis_band"].is_null());
  EXPECT_TRUE(t["whiteness"].is_null());
  EXPECT_FALSE(t["note"].get<std::string>().empty());
  // A laser-free log's laser tests: null with a note, the verdict on the fixes alone.
  std::mt19937 rng(5);
  const DriveStats st = computeStats({}, {}, {}, 0.05, drawFixes(rng, 50, 1.0), false, true);
  EXPECT_TRUE(st.tests["nis_mean"].is_null());
  EXPECT_TRUE(st.tests["ljung_box"].is_null());
  EXPECT_TRUE(st.has_data);
  EXPECT_EQ(st.tests["verdict_rests_on"], json::array({"pose_fixes"}));
  const DriveStats none = computeStats({}, {}, {}, 0.05, {}, false, true);
  EXPECT_FALSE(none.has_data);
  EXPECT_TRUE(none.tests["nis_consistent"].is_null());
}

TEST(DiagnosePoseFix, PhysicalBoundsOnNamedEstimates) {
  using odoerr::sim::diag::physicalViolation;
  EXPECT_FALSE(physicalViolation("turn_slip", 0, -0.08, 0.002).empty());
  EXPECT_TRUE(physicalViolation("turn_slip", 0, 0.05, 0.001).empty());
  EXPECT_TRUE(physicalViolation("turn_slip", 0, -0.04, 0.001).empty());
  EXPECT_FALSE(physicalViolation("rotation_slip", 0, -0.05, 0.005).empty());
  EXPECT_TRUE(physicalViolation("rotation_slip", 0, 0.15, 0.005).empty());
  EXPECT_FALSE(physicalViolation("wheel_backlash", 1, -0.0014, 0.0002).empty());
  EXPECT_TRUE(physicalViolation("backlash", 0, -0.0001, 0.001).empty());  // within 2 sigma of 0
}
