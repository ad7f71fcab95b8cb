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
#pragma once

#include <cstdint>

#include "odoerr/laser.hpp"
#include "odoerr/scalar.hpp"

namespace odoerr {

template <typename S>
struct Segment {
  S x1, y1, x2, y2;
};

/// Result of casting one ray against the map.
template <typename S>
struct RayHit {
  bool hit = false;
  int wall = -1;
  S range = S(0);
  S nx = S(0);      ///< unit normal of the wall that was hit
  S ny = S(0);
  S n_dot_u = S(0); ///< normal . ray direction: |n.u| = cos(incidence angle)
};

/// One wall as the ray cast reads it: start point, direction (end - start) and unit normal
/// (-ey, ex) / |e|.
template <typename S>
struct WallRec {
  S x1, y1, ex, ey, nx, ny;
  // The end point, so that a wall reads back as it was given; it also makes the record
  // 8 words, which the walk addresses by one shift (measured on the Cortex-M4F).
  S x2, y2;
};

/// Returns false when the segment is degenerate or not finite.
template <typename S>
inline bool makeWallRec(const Segment<S>& w, WallRec<S>* out) {
  if (!(isFinite(w.x1) && isFinite(w.y1) && isFinite(w.x2) && isFinite(w.y2))) return false;
  const S ex = w.x2 - w.x1;
  const S ey = w.y2 - w.y1;
  const S len = std::sqrt(ex * ex + ey * ey);
  if (!(len > S(0))) return false;
  *out = WallRec<S>{w.x1, w.y1, ex, ey, -ey / len, ex / len, w.x2, w.y2};
  return true;
}

/// The index type of the grid's tables (walls and items are counted in it).
using MapIndex = std::uint16_t;
constexpr int kMaxMapIndex = 65535;

/// One grid cell: where its walls start in the item list (high 16 bits) and how many
/// there are (low 16 bits). An empty cell is 0, so the walk tells it by one load
/// (measured on the Cortex-M4F, docs/performance.md).
using MapCell = std::uint32_t;
constexpr int cellStart(MapCell w) { return static_cast<int>(w >> 16); }
constexpr int cellCount(MapCell w) { return static_cast<int>(w & 0xFFFFu); }

/// A uniform grid over [x0, x0 + nx cell) x [y0, y0 + ny cell). nx == 0: no grid. The
/// walls lie at least one cell inside its edge; the tables add a fence (gridFence).
template <typename S>
struct GridSpec {
  S x0 = S(0), y0 = S(0), cell = S(1), inv_cell = S(1);
  int nx = 0, ny = 0;
  /// The box inside the fence (setFenceBox): a ray from there walks with no bounds test.
  S in_x0 = S(0), in_y0 = S(0), in_x1 = S(0), in_y1 = S(0);
};

/// Sets g's box inside the fence: half a cell in from the grid's edge (see gridFence).
template <typename S>
inline void setFenceBox(GridSpec<S>* g) {
  const S h = S(0.5) * g->cell;
  g->in_x0 = g->x0 + h;
  g->in_y0 = g->y0 + h;
  g->in_x1 = g->x0 + S(g->nx) * g->cell - h;
  g->in_y1 = g->y0 + S(g->ny) * g->cell - h;
}

/// The map's tables, not owned. cells has nx * ny entries. With a grid, walls
/// holds n_walls + 4 entries: the map's walls, then the grid's fence.
template <typename S>
struct MapTables {
  const WallRec<S>* walls = nullptr;
  int n_walls = 0;
  GridSpec<S> grid{};
  const MapCell* cells = nullptr;
  const MapIndex* cell_items = nullptr;
};

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
  // Tests the walls listed in a cell.
  auto testCell = [&](MapCell w) {
    const MapIndex* it = items + cellStart(w);
    const MapIndex* const end = it + cellCount(w);
    for (; it != end; ++it) {
      const int i = *it;
      if (i == last || (!kFenced && i >= m.n_walls)) continue;
      last = i;
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
        const MapIndex* it = items + cellStart(w);
        const MapIndex* const end = it + cellCount(w);
        for (; it != end; ++it) testWall(walls[*it], *it, px, py, ux, uy, min_range, &best);
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
    if constexpr (!kFenced) testCell(cells[c]);
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
    if constexpr (kFenced) testCell(cells[c]);
  }
  *range = best.r;
  // The fence, or past the far end: nothing within range.
  return best.wall >= m.n_walls || best.r > far ? -1 : best.wall;
}

}  // namespace map_detail

/// The fence of a grid: four walls along the middle of its margin cells, which every ray
/// starting inside them hits (if nothing nearer), so that the walk needs no bounds test.
/// The grid's tables hold them after the map's own walls (indices n_walls .. n_walls + 3).
template <typename S>
inline void gridFence(const GridSpec<S>& g, WallRec<S> fence[4]) {
  const S h = S(0.5) * g.cell;
  const S gx1 = g.x0 + S(g.nx) * g.cell, gy1 = g.y0 + S(g.ny) * g.cell;
  const S x0 = g.x0 + h, y0 = g.y0 + h, x1 = gx1 - h, y1 = gy1 - h;
  // Each wall runs the grid's whole edge, past the box's corners, so that the four overlap
  // there: a ray aimed at a corner cannot slip between two of them by rounding.
  const Segment<S> sides[4] = {
      {g.x0, y0, gx1, y0}, {x1, g.y0, x1, gy1}, {gx1, y1, g.x0, y1}, {x0, gy1, x0, g.y0}};
  for (int k = 0; k < 4; ++k) (void)makeWallRec(sides[k], &fence[k]);
}

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

/// Whether wall w touches the closed cell [cx0, cx0 + cell] x [cy0, cy0 + cell] (grown by
/// a small margin, so that rounding never drops a wall from a cell its ray may meet).
template <typename S>
inline bool wallTouchesCell(const WallRec<S>& w, S cx0, S cy0, S cell) {
  const S m = cell * S(1e-3);
  const S lo_x = cx0 - m, hi_x = cx0 + cell + m, lo_y = cy0 - m, hi_y = cy0 + cell + m;
  const S x2 = w.x1 + w.ex, y2 = w.y1 + w.ey;
  // Bounding boxes first.
  if ((w.x1 < lo_x && x2 < lo_x) || (w.x1 > hi_x && x2 > hi_x) || (w.y1 < lo_y && y2 < lo_y) ||
      (w.y1 > hi_y && y2 > hi_y)) {
    return false;
  }
  // Then the wall's line: the box's corners must not all lie strictly on one side.
  const S d[4] = {w.ex * (lo_y - w.y1) - w.ey * (lo_x - w.x1), w.ex * (lo_y - w.y1) - w.ey * (hi_x - w.x1),
                  w.ex * (hi_y - w.y1) - w.ey * (lo_x - w.x1), w.ex * (hi_y - w.y1) - w.ey * (hi_x - w.x1)};
  const bool all_pos = d[0] > S(0) && d[1] > S(0) && d[2] > S(0) && d[3] > S(0);
  const bool all_neg = d[0] < S(0) && d[1] < S(0) && d[2] < S(0) && d[3] < S(0);
  return !all_pos && !all_neg;
}

/// Why an index could not be built.
enum class IndexStatus : std::uint8_t { kOk, kBadCell, kTooManyCells, kTooManyItems };

/// The grid for `n` walls at cell size `cell`: a box around the walls, one cell of margin.
template <typename S>
inline IndexStatus gridFor(const WallRec<S>* walls, int n, S cell, int max_cells, GridSpec<S>* g) {
  if (!(cell > S(0)) || !isFinite(cell) || n <= 0) return IndexStatus::kBadCell;
  S lo_x = walls[0].x1, hi_x = lo_x, lo_y = walls[0].y1, hi_y = lo_y;
  for (int i = 0; i < n; ++i) {
    const S xs[2] = {walls[i].x1, walls[i].x1 + walls[i].ex};
    const S ys[2] = {walls[i].y1, walls[i].y1 + walls[i].ey};
    for (int k = 0; k < 2; ++k) {
      lo_x = xs[k] < lo_x ? xs[k] : lo_x;
      hi_x = xs[k] > hi_x ? xs[k] : hi_x;
      lo_y = ys[k] < lo_y ? ys[k] : lo_y;
      hi_y = ys[k] > hi_y ? ys[k] : hi_y;
    }
  }
  const S nxf = (hi_x - lo_x) / cell + S(3);
  const S nyf = (hi_y - lo_y) / cell + S(3);
  if (!(nxf * nyf <= S(max_cells))) return IndexStatus::kTooManyCells;
  g->cell = cell;
  g->inv_cell = S(1) / cell;
  g->nx = static_cast<int>(nxf);
  g->ny = static_cast<int>(nyf);
  g->x0 = lo_x - cell;
  g->y0 = lo_y - cell;
  setFenceBox(g);
  return IndexStatus::kOk;
}

/// Fills the grid's tables: cells (nx * ny entries, see MapCell) and cell_items (at most
/// max_items), each cell's walls in index order. Each wall visits only the cells of its
/// bounding box; two passes (count, then fill), no heap.
template <typename S>
inline IndexStatus fillGrid(const WallRec<S>* walls, int n, const GridSpec<S>& g, MapCell* cell_tab,
                            MapIndex* cell_items, int max_items, int* items_used) {
  const int cells = g.nx * g.ny;
  // The first pass counts cell c's walls in its low half; then each cell gets its start
  // and a count of 0, which the second pass counts up again as it fills.
  for (int c = 0; c < cells; ++c) cell_tab[c] = 0;
  auto cellRange = [&g](S a, S b, S origin, int n_cells, int* lo, int* hi) {
    const S mn = a < b ? a : b, mx = a < b ? b : a;
    *lo = static_cast<int>((mn - origin) * g.inv_cell) - 1;
    *hi = static_cast<int>((mx - origin) * g.inv_cell) + 1;
    *lo = *lo < 0 ? 0 : *lo;
    *hi = *hi >= n_cells ? n_cells - 1 : *hi;
  };
  int total = 0;
  for (int pass = 0; pass < 2; ++pass) {
    for (int i = 0; i < n; ++i) {
      const WallRec<S>& w = walls[i];
      int x_lo, x_hi, y_lo, y_hi;
      cellRange(w.x1, w.x1 + w.ex, g.x0, g.nx, &x_lo, &x_hi);
      cellRange(w.y1, w.y1 + w.ey, g.y0, g.ny, &y_lo, &y_hi);
      for (int iy = y_lo; iy <= y_hi; ++iy) {
        for (int ix = x_lo; ix <= x_hi; ++ix) {
          if (!wallTouchesCell(w, g.x0 + S(ix) * g.cell, g.y0 + S(iy) * g.cell, g.cell)) continue;
          const int c = iy * g.nx + ix;
          if (pass == 0) {
            if (total >= max_items || total >= kMaxMapIndex) return IndexStatus::kTooManyItems;
            ++total;
            ++cell_tab[c];
          } else {
            cell_items[cellStart(cell_tab[c]) + cellCount(cell_tab[c])] = static_cast<MapIndex>(i);
            ++cell_tab[c];
          }
        }
      }
    }
    if (pass == 0) {  // counts to starts (an empty cell stays 0)
      MapCell start = 0;
      for (int c = 0; c < cells; ++c) {
        const MapCell count = cell_tab[c];
        cell_tab[c] = count != 0 ? start << 16 : 0;
        start += count;
      }
    }
  }
  *items_used = total;
  return IndexStatus::kOk;
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
