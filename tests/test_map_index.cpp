// The map's grid index (core/include/odoerr/map.hpp): a ray cast through the index finds
// exactly what testing every wall finds; the index's tables are complete and bounded; a
// view over constant tables casts like the map that owns them. And the laser's beam
// selection (core/include/odoerr/laser.hpp) as the filter uses it.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "odoerr/estimator.hpp"
#include "odoerr/map.hpp"
#include "odoerr/sim/host_map.hpp"
#include "odoerr/sim/random.hpp"

using namespace odoerr;

namespace {

/// A cluttered "building": random segments of 0.1-3 m in a 40 x 30 m box, some axis-aligned,
/// some sharing end points (corners), plus the outer walls.
std::vector<sim::OdologWall> randomBuilding(unsigned seed, int n) {
  std::mt19937 rng(seed);
  odoerr::sim::UniformDist<double> ux(-20, 20), uy(-15, 15), len(0.1, 3.0), ang(-M_PI, M_PI);
  std::vector<sim::OdologWall> w = {{-20, -15, 20, -15}, {20, -15, 20, 15}, {20, 15, -20, 15}, {-20, 15, -20, -15}};
  for (int i = 0; i < n; ++i) {
    const double x = ux(rng), y = uy(rng), l = len(rng);
    double a = ang(rng);
    if (i % 3 == 0) a = std::round(a / (M_PI / 2)) * (M_PI / 2);  // axis-aligned
    w.push_back({x, y, x + l * std::cos(a), y + l * std::sin(a)});
    if (i % 5 == 0) {  // a corner: the next wall starts where this one ends
      const double x2 = w.back().x2, y2 = w.back().y2;
      w.push_back({x2, y2, x2 + l * std::cos(a + M_PI / 2), y2 + l * std::sin(a + M_PI / 2)});
    }
  }
  return w;
}

void expectSameHit(const RayHit<double>& a, const RayHit<double>& b, const std::string& where) {
  ASSERT_EQ(a.hit, b.hit) << where;
  if (!a.hit) return;
  // Two walls can be hit at exactly the same range (a shared corner): then either is right.
  EXPECT_NEAR(a.range, b.range, 1e-12) << where;
  if (a.wall != b.wall) {
    EXPECT_NEAR(a.range, b.range, 1e-12) << where << ": walls " << a.wall << " and " << b.wall;
  } else {
    EXPECT_EQ(a.range, b.range) << where;  // the same wall: the same arithmetic, bit for bit
    EXPECT_EQ(a.n_dot_u, b.n_dot_u) << where;
  }
}

}  // namespace

TEST(MapIndex, GridCastEqualsTestingEveryWall) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const auto walls = randomBuilding(seed, 400);
    for (double cell : {0.25, 0.5, 1.0, 3.0}) {
      sim::HostMap<double> brute, grid;
      std::string err;
      ASSERT_TRUE(brute.build(walls, 0.0, &err)) << err;
      ASSERT_TRUE(grid.build(walls, cell, &err)) << err;
      ASSERT_GT(grid.grid().nx, 0);
      std::mt19937 rng(seed * 100 + unsigned(cell * 8));
      odoerr::sim::UniformDist<double> ux(-25, 25), uy(-19, 19), ang(-M_PI, M_PI);
      for (int r = 0; r < 4000; ++r) {
        // Origins inside and outside the grid's box; a few exactly axis-aligned rays.
        const double x = ux(rng), y = uy(rng);
        double a = ang(rng);
        if (r % 17 == 0) a = (r % 4) * M_PI / 2;
        const double c = std::cos(a), s = std::sin(a);
        const double cx = (r % 17 == 0 && (r % 4) % 2 == 1) ? 0.0 : c;
        const double sy = (r % 17 == 0 && (r % 4) % 2 == 0) ? 0.0 : s;
        const auto want = brute.view().castDir(x, y, cx, sy);
        const auto got = grid.view().castDir(x, y, cx, sy);
        expectSameHit(want, got, "seed " + std::to_string(seed) + " cell " + std::to_string(cell) + " ray " +
                                     std::to_string(r));
        if (HasFatalFailure()) return;
      }
    }
  }
}

// Rays that no wall can stop: a NaN or infinite origin, a NaN or zero direction (an
// infinite one only off the map: castDir's contract asks for a finite unit vector), rays
// from between the map and its fence aimed outwards and at the fence's corners. The walk
// must end with no hit and never leave its tables (AddressSanitizer runs this suite in
// CI: host-asan-ci). A regression test: until commit 064695e a NaN direction walked out of
// the grid.
template <typename S>
void expectBadRaysMiss() {
  const auto walls = randomBuilding(3, 60);
  static SegmentMap<S, 512, 8192, 16384> owned;
  for (const auto& w : walls) ASSERT_TRUE(owned.add({S(w.x1), S(w.y1), S(w.x2), S(w.y2)}));
  ASSERT_EQ(owned.buildIndex(S(0.75)), IndexStatus::kOk);
  const S nan = std::numeric_limits<S>::quiet_NaN(), inf = std::numeric_limits<S>::infinity();
  const S bad[][4] = {
      {nan, 0, 1, 0},    {0, nan, 1, 0},     {0, 0, nan, 0},  {0, 0, 0, nan},  {0, 0, nan, nan},
      {0, 0, 0, 0},      {inf, 0, 1, 0},     {0, -inf, 0, 1}, {1e6, 1e6, nan, 1}, {-1e6, 0, 0, 0},
      {-1e6, 0, nan, 0}, {-1e6, 0, inf, 0},  {0, 1e6, 0, -inf},
  };
  for (const auto& r : bad) {
    const RayHit<S> h = owned.castDir(r[0], r[1], r[2], r[3]);
    EXPECT_FALSE(h.hit) << r[0] << " " << r[1] << " " << r[2] << " " << r[3];
  }
  // From the margin between the building's outer walls (+-20, +-15) and the fence, outwards
  // and at the fence box's four corners (exactly, in S): only the fence is there.
  const GridSpec<S> g = owned.tables().grid;
  const S h2 = S(0.5) * g.cell;
  const S cx[2] = {g.x0 + h2, g.x0 + S(g.nx) * g.cell - h2}, cy[2] = {g.y0 + h2, g.y0 + S(g.ny) * g.cell - h2};
  int rays = 0;
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) {
      const S sx = i ? S(20.1) : S(-20.1), sy = j ? S(15.1) : S(-15.1);
      for (int k = 0; k <= 8; ++k) {  // towards the corner, and fanned out around it
        const S dx = cx[i] - sx, dy = cy[j] - sy;
        const S a = std::atan2(dy, dx) + S(k - 4) * S(0.2);
        const S ux = k == 4 ? dx / std::sqrt(dx * dx + dy * dy) : std::cos(a);
        const S uy = k == 4 ? dy / std::sqrt(dx * dx + dy * dy) : std::sin(a);
        if (ux * (sx > 0 ? 1 : -1) < S(0) || uy * (sy > 0 ? 1 : -1) < S(0)) continue;  // outwards only
        EXPECT_FALSE(owned.castDir(sx, sy, ux, uy).hit) << sx << " " << sy << " k " << k;
        ++rays;
      }
    }
  }
  EXPECT_GE(rays, 4 * 3);
  // A good ray from the same map still hits (the bad ones above are refused, not all rays).
  EXPECT_TRUE(owned.castDir(S(0.1), S(0.2), S(1), S(0)).hit);
}

TEST(MapIndex, BadRaysEndWithoutAHit) {
  expectBadRaysMiss<double>();
  expectBadRaysMiss<float>();
}

TEST(MapIndex, MaxRangeCutsTheRay) {
  sim::HostMap<double> m;
  std::string err;
  std::vector<sim::OdologWall> walls;
  for (int i = 0; i < 40; ++i) walls.push_back({double(i), 5.0, double(i) + 0.9, 5.0});  // a dashed wall at y = 5
  ASSERT_TRUE(m.build(walls, 0.5, &err)) << err;
  const auto near = m.view().castDir(3.5, 0.0, 0.0, 1.0, 1e-6, 6.0);
  ASSERT_TRUE(near.hit);
  EXPECT_NEAR(near.range, 5.0, 1e-12);
  EXPECT_FALSE(m.view().castDir(3.5, 0.0, 0.0, 1.0, 1e-6, 4.9).hit);  // beyond the laser's reach
  EXPECT_FALSE(m.view().castDir(3.95, 0.0, 0.0, 1.0).hit);             // through a gap
  EXPECT_FALSE(m.view().castDir(3.5, 6.0, 0.0, 1.0).hit);              // beyond the wall, away from it
  EXPECT_FALSE(m.view().castDir(-30.0, 100.0, 1.0, 0.0).hit);          // misses the grid's box
  const auto from_outside = m.view().castDir(3.5, -50.0, 0.0, 1.0);    // enters the box from below
  ASSERT_TRUE(from_outside.hit);
  EXPECT_NEAR(from_outside.range, 55.0, 1e-9);
}

TEST(MapIndex, TablesAreCompleteAndOrdered) {
  const auto walls = randomBuilding(7, 200);
  sim::HostMap<double> m;
  std::string err;
  ASSERT_TRUE(m.build(walls, 0.5, &err)) << err;
  const auto& g = m.grid();
  const auto& cells = m.cells();
  const auto& it = m.cellItems();
  ASSERT_EQ(cells.size(), std::size_t(g.nx * g.ny));
  // The cells' lists tile the items in cell order, with no gap and no overlap; an empty
  // cell is 0.
  std::size_t next = 0;
  for (int c = 0; c < g.nx * g.ny; ++c) {
    if (cellCount(cells[c]) == 0) {
      EXPECT_EQ(cells[c], 0u) << "cell " << c;
      continue;
    }
    ASSERT_EQ(std::size_t(cellStart(cells[c])), next) << "cell " << c;
    next += std::size_t(cellCount(cells[c]));
    for (int k = cellStart(cells[c]) + 1; k < cellStart(cells[c]) + cellCount(cells[c]); ++k) {
      EXPECT_LT(it[k - 1], it[k]) << "cell " << c;  // wall order
    }
  }
  EXPECT_EQ(next, it.size());
  // Every wall is listed in the cells of its two end points and its mid point.
  for (std::size_t i = 0; i < walls.size(); ++i) {
    for (double f : {0.0, 0.5, 1.0}) {
      const double x = walls[i].x1 + f * (walls[i].x2 - walls[i].x1), y = walls[i].y1 + f * (walls[i].y2 - walls[i].y1);
      const int ix = int((x - g.x0) / g.cell), iy = int((y - g.y0) / g.cell);
      const int c = iy * g.nx + ix;
      bool found = false;
      for (int k = cellStart(cells[c]); k < cellStart(cells[c]) + cellCount(cells[c]); ++k) found = found || it[k] == i;
      EXPECT_TRUE(found) << "wall " << i << " at fraction " << f << " missing from cell " << c;
    }
  }
}

TEST(MapIndex, FixedCapacityMapRefusesWhatDoesNotFit) {
  SegmentMap<double, 8, 16, 32> small;
  for (int i = 0; i < 8; ++i) ASSERT_TRUE(small.add({double(i), 0, double(i), 1}));
  EXPECT_FALSE(small.add({9, 0, 9, 1}));                                // walls full
  EXPECT_EQ(small.buildIndex(0.1), IndexStatus::kTooManyCells);        // 100 cells > 16
  EXPECT_EQ(small.buildIndex(0.0), IndexStatus::kBadCell);
  EXPECT_EQ(small.buildIndex(std::nan("")), IndexStatus::kBadCell);
  SegmentMap<double, 8, 64, 4> few_items;
  for (int i = 0; i < 8; ++i) ASSERT_TRUE(few_items.add({double(i), 0, double(i), 1}));
  EXPECT_EQ(few_items.buildIndex(1.0), IndexStatus::kTooManyItems);     // 8 walls need >= 8 items
  // After a failure the map still casts, testing every wall.
  const auto h = few_items.castDir(-1, 0.5, 1, 0);
  ASSERT_TRUE(h.hit);
  EXPECT_EQ(h.wall, 0);
  EXPECT_NEAR(h.range, 1.0, 1e-12);
  // Degenerate and non-finite walls are refused.
  SegmentMap<double, 8> m;
  EXPECT_FALSE(m.add({1, 1, 1, 1}));
  EXPECT_FALSE(m.add({0, 0, std::nan(""), 1}));
  sim::HostMap<double> hm;
  std::string err;
  EXPECT_FALSE(hm.build({{0, 0, 1, 0}, {2, 2, 2, 2}}, -1, &err));
  EXPECT_NE(err.find("wall 1"), std::string::npos) << err;
}

TEST(MapIndex, OwnedIndexAndConstantTablesCastAlike) {
  // A fixed-capacity float map with its index, and a view over copies of its tables held
  // in constant arrays (as a generated flash table would be).
  const auto walls = randomBuilding(11, 60);
  static SegmentMap<float, 512, 8192, 16384> owned;
  for (const auto& w : walls) ASSERT_TRUE(owned.add({float(w.x1), float(w.y1), float(w.x2), float(w.y2)}));
  ASSERT_EQ(owned.buildIndex(1.0f), IndexStatus::kOk);
  ASSERT_GT(owned.indexItems(), 0);
  const MapTables<float> t = owned.tables();
  const int cells = t.grid.nx * t.grid.ny;
  const std::vector<WallRec<float>> w(t.walls, t.walls + t.n_walls);
  const std::vector<MapCell> st(t.cells, t.cells + cells);
  const std::vector<MapIndex> it(t.cell_items, t.cell_items + owned.indexItems());
  const MapView<float> view(MapTables<float>{w.data(), int(w.size()), t.grid, st.data(), it.data()});
  SegmentMap<float, 512> brute;
  for (const auto& s : walls) ASSERT_TRUE(brute.add({float(s.x1), float(s.y1), float(s.x2), float(s.y2)}));
  std::mt19937 rng(5);
  odoerr::sim::UniformDist<float> ux(-19.f, 19.f), uy(-14.f, 14.f), ang(-3.14f, 3.14f);
  int hits = 0;
  for (int r = 0; r < 2000; ++r) {
    const float x = ux(rng), y = uy(rng), a = ang(rng);
    const auto a1 = owned.castDir(x, y, std::cos(a), std::sin(a));
    const auto a2 = view.castDir(x, y, std::cos(a), std::sin(a));
    const auto a3 = brute.castDir(x, y, std::cos(a), std::sin(a));
    ASSERT_EQ(a1.hit, a2.hit);
    ASSERT_EQ(a1.wall, a2.wall);
    ASSERT_EQ(a1.range, a2.range);  // the same tables, the same function: bit for bit
    ASSERT_EQ(a1.hit, a3.hit);
    if (a1.hit) {
      ++hits;
      EXPECT_NEAR(a1.range, a3.range, 1e-5f * (1.f + a3.range));
    }
  }
  EXPECT_GT(hits, 1900);  // inside a closed box nearly every ray hits
  // The copy of an owning map casts with its own tables.
  const SegmentMap<float, 512, 8192, 16384>* copy = new SegmentMap<float, 512, 8192, 16384>(owned);
  const auto c1 = copy->castDir(0.5f, 0.5f, 1.0f, 0.0f);
  const auto c2 = owned.castDir(0.5f, 0.5f, 1.0f, 0.0f);
  delete copy;
  EXPECT_EQ(c1.range, c2.range);
  EXPECT_EQ(c1.wall, c2.wall);
}

// --- Beam selection ---------------------------------------------------------------------

TEST(BeamSelection, SlotsSpreadEvenlyAndPhasesCoverEveryBeam) {
  LaserGeometry<double, 400> g;
  LaserConfig<double> lc;
  lc.beams = 361;
  lc.angle_min = -M_PI / 2;
  lc.angle_inc = M_PI / 360;
  ASSERT_TRUE(g.init(lc, 24));
  EXPECT_EQ(g.beams(), 361);
  EXPECT_EQ(g.used(), 24);
  EXPECT_EQ(g.stride(), 15);
  std::vector<int> seen(361, 0);
  for (int phase = 0; phase < g.stride(); ++phase)
    for (int k = 0; k < g.used(); ++k) {
      const int b = g.slotBeam(k, phase);
      ASSERT_GE(b, 0);
      ASSERT_LT(b, 361);
      ++seen[b];
    }
  for (int b = 0; b < 24 * 15; ++b) EXPECT_EQ(seen[b], 1) << "beam " << b;  // each once per cycle of phases
  ASSERT_TRUE(g.init(lc, 0));
  EXPECT_EQ(g.used(), 361);
  EXPECT_EQ(g.stride(), 1);
  ASSERT_TRUE(g.init(lc, 500));
  EXPECT_EQ(g.used(), 361);
  EXPECT_FALSE(g.init(lc, -1));
  lc.beams = 401;
  EXPECT_FALSE(g.init(lc, 24));  // more beams than the table holds
}

TEST(BeamSelection, TheFilterFusesOneBeamPerSlotAndSkipsMissingReturns) {
  using M = Model<DiffDrive<double>>;
  SegmentMap<double, 16> map;
  for (const Segment<double>& w : {Segment<double>{0, 0, 10, 0}, Segment<double>{10, 0, 10, 10},
                                   Segment<double>{10, 10, 0, 10}, Segment<double>{0, 10, 0, 0}})
    ASSERT_TRUE(map.add(w));
  LaserConfig<double> lc;
  lc.beams = 180;
  lc.angle_min = -M_PI;
  lc.angle_inc = 2 * M_PI / 180;
  LaserGeometry<double, 400> laser;
  ASSERT_TRUE(laser.init(lc, 30));  // stride 6
  DiffDrive<double> drive;
  Estimator<M, SegmentMap<double, 16>, 32, 400> est(M(drive), map, laser);
  M::StateVec x0 = M::StateVec::Zero();
  x0[0] = 5;
  x0[1] = 5;
  M::setNominal(x0);
  M::StateVec sig = M::StateVec::Constant(0.01);
  est.init(x0, sig.cwiseAbs2().asDiagonal(), Eigen::Matrix<double, 1, 1>(1e-4), Eigen::Matrix<double, 1, 1>(1e-8));
  // True ranges from the true pose (5, 5, 0), exact; beams 0..5 (slot 0) have no return
  // except beam 4, and every beam of slot 1 has none.
  std::vector<double> r(180);
  for (int i = 0; i < 180; ++i) r[i] = map.cast(5, 5, lc.angle_min + i * lc.angle_inc).range;
  for (int i = 0; i < 6; ++i)
    if (i != 4) r[i] = std::nan("");
  for (int i = 6; i < 12; ++i) r[i] = std::nan("");
  std::vector<int> fused;
  for (int scan = 0; scan < 2; ++scan) {
    fused.clear();
    (void)est.cycle({0.0, 0.0}, r.data(), [&](const auto& rec) { fused.push_back(rec.beam); });
    ASSERT_EQ(fused.size(), 30u);
    EXPECT_EQ(fused[0], 4);                 // slot 0: the beam with a return
    EXPECT_GE(fused[1], 6);                 // slot 1: none has one; its beam is reported without a return
    EXPECT_LT(fused[1], 12);
    for (int k = 2; k < 30; ++k) EXPECT_EQ(fused[k], 6 * k + scan) << "slot " << k << " scan " << scan;  // phase
  }
  EXPECT_EQ(est.akf().counters().no_return, 2u);  // slot 1 in each scan
}
