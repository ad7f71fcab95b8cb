// odoerr core: the map's tables (walls, grid cells, index items) as the ray cast reads
// them, whether a SegmentMap owns them or a constant table in flash holds them (map.hpp).
#pragma once

#include <cstdint>

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

/// Why an index could not be built.
enum class IndexStatus : std::uint8_t { kOk, kBadCell, kTooManyCells, kTooManyItems };

}  // namespace odoerr
