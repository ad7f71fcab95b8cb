// odoerr core: a known map of line segments and the ray cast that predicts a beam's range
// (filter) and simulates it (sim_host).
//
// The map's tables are plain arrays: the walls, and optionally a uniform grid over them
// whose cells list the walls that touch them (cell c owns cellCount(cells[c]) items from
// cellStart(cells[c]) on; an empty cell is 0). A ray walks the grid cell by cell (Amanatides &
// Woo) and stops in the first cell that holds its nearest hit, so a beam tests only the
// walls near its own path, whatever the size of the map. Without a grid every wall is
// tested (small maps, where that is cheaper).
//
// Two holders of the same tables:
// - SegmentMap<S, MaxWalls, MaxCells, MaxItems>: owns fixed-capacity arrays; walls are
//   added at set-up and the index is built once (buildIndex). No heap.
// - MapView<S>: points at tables that live elsewhere, e.g. a constant table generated on
//   the host (`odoerr map compile`) and linked into the firmware's flash: nothing is built
//   at boot. Cheap to copy.
// Both cast rays with the same function (castTables), so they agree bit for bit.
// The tables' layout is in map_tables.hpp, the index's construction in map_index.hpp.
#pragma once

#include <cstdint>
#include <type_traits>

#include "odoerr/laser.hpp"
#include "odoerr/map_index.hpp"
#include "odoerr/map_tables.hpp"
#include "odoerr/scalar.hpp"

namespace odoerr {

namespace map_detail {

/// The nearest hit so far along a ray: its range r (one division per wall taken, none per
/// wall tested). It starts at the ray's far end (max_range, no wall): a hit must be nearer.
template <typename S>
struct Nearest {
  S r;
  int wall = -1;
};

/// The ray p + r u against one wall; takes it when it is hit at min_range < r and nearer
/// than the nearest so far.
template <typename S>
inline void testWall(const WallRec<S>& w, int index, S px, S py, S ux, S uy, S min_range, Nearest<S>* best) {
  // Solve p + r u = a + t e.  denom = u x e. The point along the wall (tn) is tested
  // first: most walls a ray is tested against it passes by.
  const S denom = ux * w.ey - uy * w.ex;
  const S ax = w.x1 - px;
  const S ay = w.y1 - py;
  const S tn = ax * uy - ay * ux;
  S rn;
  S den;
  if (denom > S(0)) {
    if (tn < S(0) || tn > denom) return;
    rn = ax * w.ey - ay * w.ex;
    den = denom;
  } else if (denom < S(0)) {
    if (tn > S(0) || tn < denom) return;
    rn = ay * w.ex - ax * w.ey;
    den = -denom;
  } else {
    return;  // parallel
  }
  if (!(rn > min_range * den)) return;
  if (rn >= best->r * den) return;  // not nearer
  best->wall = index;
  best->r = rn / den;
}

/// Entry distance of the ray into [lo, hi] along one axis, and exit; false when the ray
/// misses the slab.
template <typename S>
inline bool slab(S p, S u, S lo, S hi, S* t_in, S* t_out) {
  if (u == S(0)) return p >= lo && p <= hi;
  S a = (lo - p) / u;
  S b = (hi - p) / u;
  if (a > b) {
    const S t = a;
    a = b;
    b = t;
  }
  if (a > *t_in) *t_in = a;
  if (b < *t_out) *t_out = b;
  return *t_in <= *t_out;
}

}  // namespace map_detail

namespace map_detail {

/// The hit's range, normal and incidence once the nearest wall is known.
template <typename S>
inline RayHit<S> finishHit(const WallRec<S>* walls, const Nearest<S>& best, S ux, S uy) {
  RayHit<S> hit;
  if (best.wall < 0) return hit;
  const WallRec<S>& wr = walls[best.wall];
  hit.hit = true;
  hit.wall = best.wall;
  hit.range = best.r;
  hit.nx = wr.nx;
  hit.ny = wr.ny;
  hit.n_dot_u = wr.nx * ux + wr.ny * uy;
  return hit;
}

}  // namespace map_detail

/// Nearest intersection of the ray p + r u (u a finite unit vector), min_range < r <= max_range,
/// with every one of n walls (small maps: no index).
template <typename S>
inline RayHit<S> castEveryWall(const WallRec<S>* walls, int n, S px, S py, S ux, S uy, S min_range, S max_range) {
  map_detail::Nearest<S> best{max_range};
  for (int i = 0; i < n; ++i) map_detail::testWall(walls[i], i, px, py, ux, uy, min_range, &best);
  return map_detail::finishHit(walls, best, ux, uy);
}

namespace map_detail {

/// The grid walk of castGrid. kFenced: the ray starts inside the fence, which it must hit
/// if nothing else, so the walk needs no other end; otherwise it ends at `far`, short of
/// the grid's edge, and ignores the fence. Returns the nearest wall's index (-1: none) and
/// its range in *range. Out of line, so that its loop has the registers to itself (measured
/// on the Cortex-M4F: inlined into the filter's update, the loop spilled).
template <typename S, bool kFenced>
ODOERR_NOINLINE int walkGrid(const MapTables<S>& m, S px, S py, S ux, S uy, S min_range, S far, S t0, S* range) {
  const GridSpec<S>& g = m.grid;
  Nearest<S> best{far};
  // The start in cell units, its cell, and its place within the cell (0..1). (Inside the
  // fence the walk starts at p: t0 is 0.)
  S sx = px;
  S sy = py;
  if constexpr (!kFenced) {
    sx += t0 * ux;
    sy += t0 * uy;
  }
  const S gx = (sx - g.x0) * g.inv_cell;
  const S gy = (sy - g.y0) * g.inv_cell;
  int ix = static_cast<int>(gx);
  int iy = static_cast<int>(gy);
  if constexpr (!kFenced) {  // inside the fence the start is inside the grid
    ix = ix < 0 ? 0 : (ix >= g.nx ? g.nx - 1 : ix);
    iy = iy < 0 ? 0 : (iy >= g.ny ? g.ny - 1 : iy);
  }
  const S fx = gx - S(ix);
  const S fy = gy - S(iy);
  // Distances along the ray to the next vertical / horizontal cell border, and between
  // borders (infinite along an axis the ray does not move on), and the cell steps.
  const S big = S(1e30);
  S t_max_x = big;
  S t_max_y = big;
  S dt_x = big;
  S dt_y = big;
  int step_x = -1;
  int step_y = -g.nx;
  // A NaN or zero direction is no hit: no wall, not even the fence, would end its walk.
  // (Tested in the branches a unit vector seldom takes; an infinite component is outside
  // castDir's contract.)
  if (ux > S(0)) {
    dt_x = g.cell / ux;
    t_max_x = dt_x * (S(1) - fx);
    step_x = 1;
  } else if (ux < S(0)) {
    dt_x = -g.cell / ux;
    t_max_x = dt_x * fx;
  } else if (!(ux == S(0))) {
    *range = far;
    return -1;
  }
  if (uy > S(0)) {
    dt_y = g.cell / uy;
    t_max_y = dt_y * (S(1) - fy);
    step_y = g.nx;
  } else if (uy < S(0)) {
    dt_y = -g.cell / uy;
    t_max_y = dt_y * fy;
  } else if (!(uy == S(0)) || ux == S(0)) {
    *range = far;
    return -1;
  }
  if constexpr (!kFenced) {
    // The borders' distances are measured from p, as the hits' are: the walk starts at t0.
    // (Measured from the entry point, the walk went on t0 past `far` and out of the grid:
    // the cell table read before its first element, found by AddressSanitizer.)
    t_max_x += t0;
    t_max_y += t0;
  }
  int c = iy * g.nx + ix;
  int last = -1;  // the wall tested last: a wall crossing from one cell into the next is not tested twice
  const MapCell* const cells = m.cells;
  const MapIndex* const items = m.cell_items;
  const WallRec<S>* const walls = m.walls;
  // Tests the walls listed in a cell; with kRepeatCheck, not the wall tested last.
  auto testCell = [&](MapCell w, auto repeat_check) {
    constexpr bool kRepeatCheck = decltype(repeat_check)::value;
    const MapIndex* it = items + cellStart(w);
    const MapIndex* const end = it + cellCount(w);
    for (; it != end; ++it) {
      const int i = *it;
      if constexpr (kRepeatCheck) {
        if (i == last || (!kFenced && i >= m.n_walls)) continue;
        last = i;
      }
      testWall(walls[i], i, px, py, ux, uy, min_range, &best);
    }
  };
  if constexpr (kFenced) {
    // Until a wall is hit the walk needs no end test: the fence, which every ray from
    // inside it hits, ends it. The nearest hit is then sought at any range; one past the
    // far end is no hit (below).
    best.r = S(1e30);
    MapCell w = cells[c];
    for (;;) {
      if (w != 0) {
        // No test for a wall tested in the cell before: a ray seldom meets a wall it
        // missed in the next cell (measured: the test cost more than it saved).
        testCell(w, std::false_type{});
        if (best.wall >= 0) break;
      }
      do {  // on through the empty cells
        if (t_max_x < t_max_y) {
          c += step_x;
          t_max_x += dt_x;
        } else {
          c += step_y;
          t_max_y += dt_y;
        }
        w = cells[c];
      } while (w == 0);
    }
    last = best.wall;  // the hit wall, which may go on into the next cells
  }
  for (;;) {
    if constexpr (!kFenced) testCell(cells[c], std::true_type{});
    // The nearest hit so far (or the far end) lies in this cell or before it: no later
    // cell can hold a nearer one (every wall is listed in every cell it touches).
    if (t_max_x < t_max_y) {
      if (best.r <= t_max_x) break;
      c += step_x;
      t_max_x += dt_x;
    } else {
      if (best.r <= t_max_y) break;
      c += step_y;
      t_max_y += dt_y;
    }
    if constexpr (kFenced) testCell(cells[c], std::true_type{});
  }
  *range = best.r;
  // The fence, or past the far end: nothing within range.
  return best.wall >= m.n_walls || best.r > far ? -1 : best.wall;
}

}  // namespace map_detail

namespace map_detail {

/// castGrid from outside the fence (a robot off its map): clip the ray to the grid's box,
/// entering at t0 and leaving at t1, and end the walk half a cell before it leaves (the
/// margin holds no wall of the map).
template <typename S>
ODOERR_NOINLINE RayHit<S> castGridOutside(const MapTables<S>& m, S px, S py, S ux, S uy, S min_range,
                                          S max_range) {
  // Off the map, the rare path, the ray is checked: a NaN or infinite origin or direction,
  // or a zero direction, is no hit (the walk's end test would never end it).
  if (!(isFinite(px) && isFinite(py) && isFinite(ux) && isFinite(uy)) || (ux == S(0) && uy == S(0))) {
    return RayHit<S>{};
  }
  const GridSpec<S>& g = m.grid;
  const S h = S(0.5) * g.cell;
  const S x1 = g.x0 + S(g.nx) * g.cell, y1 = g.y0 + S(g.ny) * g.cell;
  S t0 = S(0);
  S t1 = max_range;
  if (!slab(px, ux, g.x0, x1, &t0, &t1) || !slab(py, uy, g.y0, y1, &t0, &t1)) {
    return RayHit<S>{};
  }
  const S far = t1 < max_range ? t1 - h : max_range;
  Nearest<S> best{far};
  best.wall = walkGrid<S, false>(m, px, py, ux, uy, min_range, far, t0, &best.r);
  return finishHit(m.walls, best, ux, uy);
}

}  // namespace map_detail

/// The same through the grid index of `m` (m.grid.nx > 0): the ray walks the cells.
template <typename S>
ODOERR_ALWAYS_INLINE RayHit<S> castGrid(const MapTables<S>& m, S px, S py, S ux, S uy, S min_range, S max_range) {
  const GridSpec<S>& g = m.grid;
  if (px > g.in_x0 && px < g.in_x1 && py > g.in_y0 && py < g.in_y1) {
    map_detail::Nearest<S> best{max_range};
    best.wall = map_detail::walkGrid<S, true>(m, px, py, ux, uy, min_range, max_range, S(0), &best.r);
    return map_detail::finishHit(m.walls, best, ux, uy);
  }
  return map_detail::castGridOutside(m, px, py, ux, uy, min_range, max_range);
}

/// Nearest intersection of the ray p + r u (u a finite unit vector), min_range < r <= max_range,
/// with the walls of `m` (through its grid when it has one).
template <typename S>
ODOERR_ALWAYS_INLINE RayHit<S> castTables(const MapTables<S>& m, S px, S py, S ux, S uy, S min_range, S max_range) {
  if (m.grid.nx == 0) return castEveryWall(m.walls, m.n_walls, px, py, ux, uy, min_range, max_range);
  return castGrid(m, px, py, ux, uy, min_range, max_range);
}

/// A map whose tables live elsewhere (constant tables in flash, or a host builder's).
template <typename S>
class MapView {
 public:
  MapView() = default;
  constexpr explicit MapView(const MapTables<S>& t) : t_(t) {}

  int size() const { return t_.n_walls; }
  Segment<S> wall(int i) const {
    const WallRec<S>& w = t_.walls[i];
    return {w.x1, w.y1, w.x2, w.y2};
  }
  const MapTables<S>& tables() const { return t_; }

  /// Nearest intersection of the ray p + r (cos a, sin a), r > min_range, with the map.
  RayHit<S> cast(S px, S py, S angle, S min_range = S(1e-6)) const {
    return castDir(px, py, std::cos(angle), std::sin(angle), min_range);
  }
  /// The same with the unit direction (ux, uy) given; hits beyond max_range are not hits.
  ODOERR_ALWAYS_INLINE RayHit<S> castDir(S px, S py, S ux, S uy, S min_range = S(1e-6), S max_range = S(1e30)) const {
    return castTables(t_, px, py, ux, uy, min_range, max_range);
  }

 private:
  MapTables<S> t_{};
};

/// A fixed-capacity map that owns its tables (no heap). Walls are added at set-up time;
/// buildIndex then builds the grid (MaxCells > 0), else every wall is tested per ray.
template <typename S, int MaxWalls = 32, int MaxCells = 0, int MaxItems = 0>
class SegmentMap {
  static_assert(MaxWalls <= kMaxMapIndex && MaxItems <= kMaxMapIndex, "the index type counts up to 65535");

 public:
  static constexpr int kMaxWalls = MaxWalls;
  static constexpr int kMaxCells = MaxCells;

  SegmentMap() = default;
  SegmentMap(const SegmentMap& o) { *this = o; }
  SegmentMap& operator=(const SegmentMap& o) {
    count_ = o.count_;
    grid_ = o.grid_;
    for (int i = 0; i < count_ + (grid_.nx > 0 ? 4 : 0); ++i) walls_[i] = o.walls_[i];
    if (grid_.nx > 0) {
      const int cells = grid_.nx * grid_.ny;
      for (int c = 0; c < cells; ++c) cells_[c] = o.cells_[c];
      for (int k = 0; k < o.items_used_; ++k) items_[k] = o.items_[k];
    }
    items_used_ = o.items_used_;
    return *this;
  }

  /// Adds a wall; returns false when the map is full or the segment is degenerate or
  /// not finite. Adding a wall drops an index built before.
  [[nodiscard]] bool add(const Segment<S>& w) {
    if (count_ >= MaxWalls) return false;
    WallRec<S> r;
    if (!makeWallRec(w, &r)) return false;
    walls_[count_++] = r;
    grid_ = GridSpec<S>{};
    return true;
  }

  /// Builds the grid index with square cells of `cell` metres.
  [[nodiscard]] IndexStatus buildIndex(S cell) {
    if constexpr (MaxCells == 0) {
      (void)cell;
      return IndexStatus::kTooManyCells;
    } else {
      GridSpec<S> g;
      IndexStatus st = gridFor(walls_, count_, cell, MaxCells, &g);
      if (st != IndexStatus::kOk) return st;
      gridFence(g, walls_ + count_);
      int used = 0;
      st = fillGrid(walls_, count_ + 4, g, cells_, items_, MaxItems, &used);
      if (st != IndexStatus::kOk) return st;
      grid_ = g;
      items_used_ = used;
      return IndexStatus::kOk;
    }
  }
  /// The items the index holds (0 without an index).
  int indexItems() const { return grid_.nx > 0 ? items_used_ : 0; }

  int size() const { return count_; }
  Segment<S> wall(int i) const { return view().wall(i); }
  MapView<S> view() const { return MapView<S>(tables()); }
  MapTables<S> tables() const { return MapTables<S>{walls_, count_, grid_, cells_, items_}; }

  RayHit<S> cast(S px, S py, S angle, S min_range = S(1e-6)) const {
    return castDir(px, py, std::cos(angle), std::sin(angle), min_range);
  }
  ODOERR_ALWAYS_INLINE RayHit<S> castDir(S px, S py, S ux, S uy, S min_range = S(1e-6), S max_range = S(1e30)) const {
    if constexpr (MaxCells == 0) {
      return castEveryWall(walls_, count_, px, py, ux, uy, min_range, max_range);
    } else {
      return castTables(tables(), px, py, ux, uy, min_range, max_range);
    }
  }

 private:
  static constexpr int kCells = MaxCells > 0 ? MaxCells : 1;
  static constexpr int kItems = MaxItems > 0 ? MaxItems : 1;
  WallRec<S> walls_[MaxWalls + 4]{};  // + the grid's fence
  int count_ = 0;
  GridSpec<S> grid_{};
  MapCell cells_[kCells]{};
  MapIndex items_[kItems]{};
  int items_used_ = 0;
};

}  // namespace odoerr
