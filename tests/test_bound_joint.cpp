// odoerr bound, K with the systematic parameters unknown (docs/nonsystematic.md, "K with the
// systematic parameters unknown"). The joint recursion (bound_joint.hpp) is a second,
// separate implementation of the pose model: with the prior on delta shrunk towards zero
// (delta known) its K bound must meet the existing recursion's (which carries delta as a
// state), and with the filter's prior it must not fall below the same model's bound with
// delta given. The dense check of the
// joint information itself is tests/bound/dense_check.py (ctest bound.dense_*).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "odoerr/sim/bound.hpp"

using namespace odoerr;
using namespace odoerr::sim;

namespace {

BoundResult boundWith(DriveKind kind, bool eight, double prior_scale) {
  SimConfig cfg;
  cfg.steps = 300;  // 3 m
  if (eight) {
    cfg.figure_eight = true;
    cfg.radius = 2.0;
  }
  BoundOptions opt;
  opt.systematic_prior_scale = prior_scale;
  BoundResult br;
  std::string err;
  EXPECT_TRUE(boundOfSimulatedDrive(kind, cfg, 1, FilterSetup{}, opt, &br, &err)) << err;
  return br;
}

void checkLimitAndOrder(DriveKind kind, bool eight) {
  // delta's prior sigma 1e-5 of the filter's: its variance 1e-10 of the prior's, far below
  // what 3 m of data can add; the two recursions then describe the same model (pose only).
  const BoundResult known = boundWith(kind, eight, 1e-5);
  const BoundResult filt = boundWith(kind, eight, 1.0);
  const auto& kn = known.final_point;
  const auto& fi = filt.final_point;
  ASSERT_EQ(kn.nonsystematic.size(), kn.nonsystematic_delta_unknown.size());
  for (std::size_t i = 0; i < kn.nonsystematic.size(); ++i) {
    const double a = kn.nonsystematic[i].sigma, b = kn.nonsystematic_delta_unknown[i].sigma;
    const double c = kn.nonsystematic_delta_given[i].sigma;
    std::printf("%s prior 1e-5: existing %.8g, joint %.8g, joint KK alone %.8g (rel %.2e)\n",
                kn.nonsystematic[i].name.c_str(), a, b, c, std::abs(b / a - 1));
    ASSERT_GT(a, 0);
    ASSERT_GT(b, 0);
    EXPECT_LT(std::abs(b / a - 1), 1e-4) << kn.nonsystematic[i].name;
    EXPECT_LT(std::abs(c / a - 1), 1e-4) << kn.nonsystematic[i].name;
    const double e = fi.nonsystematic[i].sigma, j = fi.nonsystematic_delta_unknown[i].sigma;
    const double g = fi.nonsystematic_delta_given[i].sigma;
    std::printf("%s filter's prior: existing %.6g (%.3g %%), joint %.6g (%.3g %%), joint KK alone %.6g\n",
                fi.nonsystematic[i].name.c_str(), e, fi.nonsystematic[i].bound_pct, j,
                fi.nonsystematic_delta_unknown[i].bound_pct, g);
    // Not below the same model's bound with delta given (K's Schur complement of a positive
    // definite joint information). The existing recursion is a different model (delta a
    // random state with the prior in the data's covariance) and is not ordered with it.
    EXPECT_GE(j, g * (1 - 1e-12)) << fi.nonsystematic[i].name;
  }
  // delta's own bound from the joint information (K known would be the posterior CRB):
  // with K unknown it cannot be below the existing recursion's by more than the covariance
  // term's information on delta allows; printed for the record.
  for (std::size_t i = 0; i < fi.systematic.size(); ++i)
    std::printf("%s: posterior CRB %.4g, joint (K unknown) %.4g\n", fi.systematic[i].name.c_str(),
                fi.systematic[i].sigma, fi.systematic_joint[i].sigma);
}

TEST(BoundJoint, SyncCircleLimitAndOrder) { checkLimitAndOrder(DriveKind::kSync, false); }
TEST(BoundJoint, DiffCircleLimitAndOrder) { checkLimitAndOrder(DriveKind::kDiff, false); }
TEST(BoundJoint, DiffEightLimitAndOrder) { checkLimitAndOrder(DriveKind::kDiff, true); }

}  // namespace
