// Relocalisation's searches (sim_host relocalise.hpp): the whole-map branch and bound finds a
// scan's pose anywhere on an asymmetric map, its pruning loses nothing (the same answer as
// with nothing pruned, for a fraction of the work), and it says "nothing" rather than a pose
// when no place reaches its floor. The scans are cast here, ray against segment, not by the
// estimator's code.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "odoerr/sim/relocalise.hpp"

using namespace odoerr::sim;

namespace {

// An L-shaped building with two pillars and a short wall: no symmetry.
std::vector<OdologWall> building() {
  const double w[][4] = {{0, 0, 12, 0},     {12, 0, 12, 6},     {12, 6, 6, 6},   {6, 6, 6, 10},
                         {6, 10, 0, 10},    {0, 10, 0, 0},      {4, 0, 4, 2.5},  {8.5, 3, 9.1, 3},
                         {9.1, 3, 9.1, 3.6}, {9.1, 3.6, 8.5, 3.6}, {8.5, 3.6, 8.5, 3}, {2, 7, 2.4, 7},
                         {2.4, 7, 2.4, 7.4}, {2.4, 7.4, 2, 7.4}, {2, 7.4, 2, 7}};
  std::vector<OdologWall> out;
  for (const auto& s : w) out.push_back({s[0], s[1], s[2], s[3]});
  return out;
}

// The end points, in the robot frame, of 180 beams over 360 deg cast from (x, y, theta)
// against the walls (the nearest crossing; none beyond 10 m).
std::vector<ScanPoint> castScan(const std::vector<OdologWall>& walls, double x, double y, double theta) {
  std::vector<ScanPoint> pts;
  for (int b = 0; b < 180; ++b) {
    const double a = -M_PI + b * (2 * M_PI / 180);
    const double dx = std::cos(theta + a), dy = std::sin(theta + a);
    double best = std::numeric_limits<double>::infinity();
    for (const OdologWall& w : walls) {
      const double ex = w.x2 - w.x1, ey = w.y2 - w.y1;
      const double den = dx * ey - dy * ex;
      if (std::fabs(den) < 1e-12) continue;
      const double t = ((w.x1 - x) * ey - (w.y1 - y) * ex) / den;  // along the ray
      const double u = ((w.x1 - x) * dy - (w.y1 - y) * dx) / den;  // along the wall
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    if (best < 10) pts.push_back({best * std::cos(a), best * std::sin(a)});
  }
  return pts;
}

LikelihoodField fieldOf(const std::vector<OdologWall>& walls) {
  LikelihoodField f;
  std::string error;
  EXPECT_TRUE(f.build(walls, 0.05, 1.0, &error)) << error;
  return f;
}

}  // namespace

TEST(MatchGlobal, FindsTheScanAnywhereOnTheMap) {
  const auto walls = building();
  const LikelihoodField field = fieldOf(walls);
  struct Truth {
    double x, y, th;
  };
  for (const Truth& t : {Truth{2.0, 3.0, 0.4}, Truth{10.3, 1.7, -2.5}, Truth{3.1, 8.6, 1.9}}) {
    const std::vector<ScanPoint> pts = castScan(walls, t.x, t.y, t.th);
    ASSERT_GT(pts.size(), 100u);
    std::size_t work = 0;
    const ScanMatch m = matchGlobal(field, pts, 0.10, 0.5, &work);
    EXPECT_NEAR(m.x, t.x, 0.05) << t.x << "," << t.y;
    EXPECT_NEAR(m.y, t.y, 0.05) << t.x << "," << t.y;
    EXPECT_NEAR(std::remainder(m.theta - t.th, 2 * M_PI), 0.0, 0.02) << t.x << "," << t.y;
    EXPECT_GT(m.fit, 0.9);
    EXPECT_GT(m.fit - m.runner_up, 0.1) << "a distinct rival fits about as well: " << m.runner_up;
    EXPECT_GT(work, 0u);
  }
}

TEST(MatchGlobal, PruningLosesNothingAndSavesWork) {
  const auto walls = building();
  const LikelihoodField field = fieldOf(walls);
  const std::vector<ScanPoint> pts = castScan(walls, 7.2, 4.4, 2.8);
  std::size_t work_all = 0, work_pruned = 0;
  const ScanMatch all = matchGlobal(field, pts, 0.10, 0.0, &work_all);
  const ScanMatch pruned = matchGlobal(field, pts, 0.10, 0.6, &work_pruned);
  EXPECT_DOUBLE_EQ(all.x, pruned.x);
  EXPECT_DOUBLE_EQ(all.y, pruned.y);
  EXPECT_DOUBLE_EQ(all.theta, pruned.theta);
  EXPECT_DOUBLE_EQ(all.fit, pruned.fit);
  EXPECT_LT(work_pruned * 10, work_all) << work_pruned << " of " << work_all;
}

TEST(MatchGlobal, NothingReachingTheFloorIsNoAnswer) {
  const auto walls = building();
  const LikelihoodField field = fieldOf(walls);
  const std::vector<ScanPoint> pts = castScan(walls, 2.0, 3.0, 0.4);
  EXPECT_EQ(matchGlobal(field, pts, 0.10, 1.01).fit, 0.0);
  EXPECT_EQ(matchGlobal(field, {}, 0.10, 0.5).fit, 0.0);
  EXPECT_EQ(matchGlobal(LikelihoodField{}, pts, 0.10, 0.5).fit, 0.0);
}
