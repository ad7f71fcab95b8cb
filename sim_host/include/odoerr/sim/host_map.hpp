// sim_host: a map of any size for the host's estimators. It owns the core's map tables in
// vectors (walls, and the grid index when the map is large enough to gain from one) and
// hands the estimator a MapView of them, so that copying an estimator never copies the
// map. The same tables, in float, are what `odoerr map compile` writes for the firmware.
#pragma once

#include <string>
#include <vector>

#include "odoerr/estimator.hpp"
#include "odoerr/map.hpp"
#include "odoerr/sim/odolog.hpp"

namespace odoerr::sim {

/// The grid cell the host chooses for a map of `walls` (0: no grid, every wall tested).
/// Maps of up to kBruteForceWalls walls are cast without an index.
constexpr int kBruteForceWalls = 16;
constexpr double kDefaultCellM = 0.75;  // measured on the M4F: docs/performance.md

template <typename S>
class HostMap {
 public:
  HostMap() = default;
  HostMap(const HostMap&) = delete;  // the views handed out point into this object
  HostMap& operator=(const HostMap&) = delete;

  /// Builds the tables from the walls; cell_m < 0 chooses (no grid for up to
  /// kBruteForceWalls walls, else kDefaultCellM), 0 forces no grid. False with *error
  /// when a wall is degenerate or not finite, or the index does not fit its index type.
  bool build(const std::vector<OdologWall>& walls, double cell_m, std::string* error) {
    walls_.clear();
    cells_.clear();
    items_.clear();
    grid_ = GridSpec<S>{};
    if (walls.size() + 4 > std::size_t(kMaxMapIndex)) {
      *error = "the map has " + std::to_string(walls.size()) + " walls; at most " + std::to_string(kMaxMapIndex);
      return false;
    }
    for (std::size_t i = 0; i < walls.size(); ++i) {
      const OdologWall& w = walls[i];
      WallRec<S> r;
      if (!makeWallRec(Segment<S>{S(w.x1), S(w.y1), S(w.x2), S(w.y2)}, &r)) {
        *error = "wall " + std::to_string(i) + " is degenerate or not finite";
        return false;
      }
      walls_.push_back(r);
    }
    if (cell_m < 0) cell_m = walls.size() <= std::size_t(kBruteForceWalls) ? 0.0 : kDefaultCellM;
    if (cell_m > 0 && !walls_.empty()) {
      GridSpec<S> g;
      constexpr int kMaxCells = 4 * 1024 * 1024;
      if (gridFor(walls_.data(), int(walls_.size()), S(cell_m), kMaxCells - 1, &g) != IndexStatus::kOk) {
        *error = "a grid of " + std::to_string(cell_m) + " m cells over this map would exceed " +
                 std::to_string(kMaxCells) + " cells";
        return false;
      }
      cells_.assign(std::size_t(g.nx) * std::size_t(g.ny), 0);
      items_.assign(kMaxMapIndex, 0);
      const int n = int(walls_.size());
      walls_.resize(walls_.size() + 4);
      gridFence(g, walls_.data() + n);
      int used = 0;
      if (fillGrid(walls_.data(), n + 4, g, cells_.data(), items_.data(), kMaxMapIndex, &used) !=
          IndexStatus::kOk) {
        *error = "the grid index of " + std::to_string(cell_m) + " m cells has more than " +
                 std::to_string(kMaxMapIndex) + " entries; use larger cells";
        return false;
      }
      items_.resize(std::size_t(used));
      grid_ = g;
    }
    return true;
  }

  MapView<S> view() const {
    return MapView<S>(MapTables<S>{walls_.data(), size(), grid_, cells_.empty() ? nullptr : cells_.data(),
                                   items_.empty() ? nullptr : items_.data()});
  }
  /// The map's walls (the fence not counted).
  int size() const { return int(walls_.size()) - (grid_.nx > 0 ? 4 : 0); }
  const GridSpec<S>& grid() const { return grid_; }
  /// The map's walls, then the grid's fence (4 walls) when there is a grid.
  const std::vector<WallRec<S>>& walls() const { return walls_; }
  const std::vector<MapCell>& cells() const { return cells_; }
  const std::vector<MapIndex>& cellItems() const { return items_; }

 private:
  std::vector<WallRec<S>> walls_;
  GridSpec<S> grid_{};
  std::vector<MapCell> cells_;
  std::vector<MapIndex> items_;
};

/// Beams a host estimator takes per scan (LMS2xx 361, and room to spare).
constexpr int kHostMaxBeams = 1024;

/// The host's estimator of model M: any map (through a HostMap's view), any laser.
template <typename M>
using HostEstimator = Estimator<M, MapView<typename M::Scalar>, 32, kHostMaxBeams, true>;

}  // namespace odoerr::sim
