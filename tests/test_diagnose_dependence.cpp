// The non-parametric step of diagnose (diagnose/dependence.hpp): on tables whose truth is
// known, it finds the variable the misfit depends on, in a form no feature holds, and on
// pure noise it finds nothing at its stated rate.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>

#include "diagnose/dependence.hpp"
#include "odoerr/sim/random.hpp"

using odoerr::sim::diag::dependenceJson;
using odoerr::sim::diag::featuresInVariable;
using odoerr::sim::diag::kDependenceAlpha;
using odoerr::sim::diag::SegmentState;
using odoerr::sim::diag::stateVariables;
using odoerr::sim::diag::StateTable;
using odoerr::sim::diag::targetMoves;

namespace {

/// n segments of 0.5 s with smooth random states (AR(1) over segments, as a drive's are),
/// travel 0.1..0.4 m, residuals of AR(1) noise (phi 0.3) per metre plus `signal`(state).
template <typename F>
StateTable makeTable(int n, unsigned seed, F signal) {
  std::mt19937_64 rng(seed);
  odoerr::sim::NormalDist<double> g;
  StateTable t;
  stateVariables(true, &t.names, &t.units);
  const auto nv = static_cast<Eigen::Index>(t.names.size());
  t.state.resize(n, nv);
  t.response.resize(n, 3);
  t.weight.resize(n);
  Eigen::VectorXd s = Eigen::VectorXd::Zero(nv);
  double e[3] = {0, 0, 0};
  for (int i = 0; i < n; ++i) {
    for (Eigen::Index v = 0; v < nv; ++v) s[v] = 0.8 * s[v] + 0.6 * g(rng);
    t.state.row(i) = s.transpose();
    t.weight[i] = 0.1 + 0.3 * std::abs(std::sin(0.37 * i));
    for (int c = 0; c < 3; ++c) {
      e[c] = 0.3 * e[c] + g(rng) * 0.01 / std::sqrt(t.weight[i]);  // per metre: noise falls with travel
      t.response(i, c) = e[c];
    }
    t.response(i, 0) += signal(t.state.row(i));
    t.fold.push_back((i / 4) % t.folds);  // 2 s blocks of 4 segments
  }
  return t;
}

}  // namespace

TEST(DiagnoseDependence, FindsAThresholdFormInItsVariable) {
  // Travel lost only while the robot speeds up hard: along -= 0.02 per metre where a_along > 1
  // (a threshold no feature of the library writes; about 8 % of the misfit, as on a drive of
  // the independent simulator with acceleration slip).
  int found = 0;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    StateTable t = makeTable(450, seed, [](const Eigen::RowVectorXd& st) { return st[4] > 1.0 ? -0.02 : 0.0; });
    const auto j = dependenceJson(t);
    ASSERT_TRUE(j["found"].is_array());
    EXPECT_EQ(j["segments"], 450);
    for (const auto& f : j["found"]) {
      if (f["component"] != "along" || f["variable"] != "a_along") continue;
      ++found;
      EXPECT_LE(f["p_adjusted"].get<double>(), kDependenceAlpha);
      EXPECT_LT(f["explained_next"].get<double>(), f["explained"].get<double>());  // it acts in its own segment
      // the leaves: the top one (a_along > 1) carries the loss
      EXPECT_LT(f["leaves"].back()["mean"].get<double>(), -0.01);
      EXPECT_GT(f["leaves"].back()["from"].get<double>(), 0.5);
    }
  }
  EXPECT_GE(found, 6);  // its power at this size, measured: 7 of 10
}

TEST(DiagnoseDependence, AVariableThatAnswersTheMisfitIsNotALead) {
  // A steering controller that sees the heading error: the turn rate's change (alpha) of a
  // segment answers the error of the one before and, in part, its own. The misfit explains
  // alpha, not the reverse: the next segment's alpha explains it better than its own, and the
  // pair goes to follows_misfit, never to found (the leads).
  int follows = 0;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    StateTable t = makeTable(450, seed, [](const Eigen::RowVectorXd&) { return 0.0; });
    for (Eigen::Index i = 0; i < t.state.rows(); ++i)
      t.state(i, 5) = 0.3 * t.state(i, 5) - 40.0 * (0.5 * t.response(i, 2) + (i > 0 ? t.response(i - 1, 2) : 0.0));
    const auto j = dependenceJson(t);
    ASSERT_TRUE(j["found"].is_array());
    for (const auto& f : j["found"]) EXPECT_FALSE(f["variable"] == "alpha") << "seed " << seed;
    for (const auto& f : j["follows_misfit"]) {
      if (f["component"] != "heading" || f["variable"] != "alpha") continue;
      ++follows;
      EXPECT_GE(f["explained_next"].get<double>(), f["explained"].get<double>());
    }
  }
  EXPECT_GE(follows, 8);  // the same-segment share alone reaches the test's level on most tables
}

TEST(DiagnoseDependence, PureNoiseFindsNothingAtItsRate) {
  // The family's level is 1 % per table: of 20 tables of noise, at most 1 with a finding
  // (a binomial 20 x 1 % exceeds 1 with probability 1.7 %).
  int with_finding = 0;
  for (unsigned seed = 100; seed < 120; ++seed) {
    StateTable t = makeTable(300, seed, [](const Eigen::RowVectorXd&) { return 0.0; });
    const auto j = dependenceJson(t);
    ASSERT_TRUE(j["found"].is_array());
    with_finding += !j["found"].empty();
  }
  EXPECT_LE(with_finding, 1);
}

TEST(DiagnoseDependence, AFormIsSelectedForTheComponentsItsTargetMoves) {
  // The geometry, derived here: a small error on each target of a robot heading 0.3 rad with
  // a 0.5 m wheelbase, as a world residual, into the segment's robot frame; a finding's
  // component is moved by a target when that component is not zero.
  const double th = 0.3, d = 0.5, e = 1e-3;
  SegmentState seg;
  seg.open(0.0, 0.0, std::numeric_limits<double>::infinity());
  seg.cycle(0.01, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, th);  // one metre at heading th
  const double c = std::cos(th), s = std::sin(th);
  const std::pair<const char*, Eigen::Vector3d> errors[] = {
      {"along", {e * c, e * s, 0}},
      {"cross", {-e * s, e * c, 0}},
      {"heading", {0, 0, e}},
      {"world_x", {e, 0, 0}},
      {"world_y", {0, e, 0}},
      {"wheel_R", {0.5 * e * c, 0.5 * e * s, e / d}},    // the right wheel a little further
      {"wheel_L", {0.5 * e * c, 0.5 * e * s, -e / d}}};  // the left one
  const char* const components[] = {"along", "cross", "heading"};
  for (const auto& [target, world] : errors) {
    const Eigen::Vector3d r = seg.perMetre(world);
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(targetMoves(target, components[k]), std::abs(r[k]) > 1e-9)
          << target << " on " << components[k] << ": " << r[k];
  }
  EXPECT_FALSE(targetMoves("range", "along"));
}

TEST(DiagnoseDependence, TooFewSegmentsIsNoFinding) {
  StateTable t = makeTable(450, 7, [](const Eigen::RowVectorXd& st) { return st[4] > 1.0 ? -0.01 : 0.0; });
  t.weight.setZero();
  t.weight.head(20).setConstant(0.2);  // 20 segments with travel: below the 40 the step needs
  const auto j = dependenceJson(t);
  EXPECT_TRUE(j["found"].is_null());
  EXPECT_EQ(j["segments"], 20);
  EXPECT_NE(j["note"].get<std::string>().find("too few segments"), std::string::npos);
  // a NaN state leaves its segment out, never the analysis
  StateTable u = makeTable(450, 8, [](const Eigen::RowVectorXd&) { return 0.0; });
  u.state(3, 2) = std::nan("");
  EXPECT_EQ(dependenceJson(u)["segments"], 449);
}

TEST(DiagnoseDependence, SegmentStateSummarisesTheCycles) {
  // 50 cycles of 10 ms speeding up from 0.2 m/s at 1 m/s^2, turning at 0.1 rad/s, heading 0.3
  SegmentState s;
  s.open(12.0, 30.0, std::numeric_limits<double>::infinity());
  double v = 0.2;
  for (int k = 0; k < 50; ++k) {
    const double rho = v * 0.01;
    s.cycle(0.01, rho, 0.001, rho + 0.00025, rho - 0.00025, 1.0 + k * 0.001, 2.0, 0.3);
    v += 0.01;
  }
  Eigen::VectorXd row;
  ASSERT_TRUE(s.row(true, &row));
  std::vector<std::string> names, units;
  stateVariables(true, &names, &units);
  ASSERT_EQ(row.size(), static_cast<Eigen::Index>(names.size()));
  auto at = [&](const char* n) { return row[std::find(names.begin(), names.end(), n) - names.begin()]; };
  EXPECT_NEAR(at("a_along"), 1.0, 1e-9);
  EXPECT_NEAR(at("w"), 0.1, 1e-12);
  EXPECT_NEAR(at("heading"), 0.3, 1e-12);
  EXPECT_NEAR(at("t"), 12.25, 1e-12);
  EXPECT_EQ(at("s_abs"), 30.0);
  EXPECT_EQ(at("s_rev"), 20.0);  // no reversal yet: the cap
  EXPECT_NEAR(s.travel(), 0.01 * (0.2 * 50 + 0.01 * 49 * 50 / 2), 1e-12);
  // a residual 1 cm along the heading, per metre of travel
  const Eigen::Vector3d pm = s.perMetre(Eigen::Vector3d(0.01 * std::cos(0.3), 0.01 * std::sin(0.3), 0.0));
  EXPECT_NEAR(pm[0], 0.01 / s.travel(), 1e-12);
  EXPECT_NEAR(pm[1], 0.0, 1e-12);
  // the library's forms in a variable
  EXPECT_EQ(featuresInVariable("a_along").front(), "acc_pos_ds");
  EXPECT_TRUE(featuresInVariable("no such variable").empty());
}
