// diagnose, where the map is wrong: every beam's residual at the posterior, accumulated
// where the beam ends (its predicted hit point in map coordinates) on a grid, and the
// connected regions whose ranges are consistently shorter than the map says (an object the
// map lacks) or longer (a wall that is gone, a door open, a wall drawn too near). The
// binning by the robot's state cannot see these: a map error lives at the end of the beam.
// docs/diagnostics.md ("Where the map is wrong") states the rules.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine.hpp"
#include "map_history.hpp"

namespace odoerr::sim::diag {

/// One region of the map that the ranges disagree with.
struct MapRegion {
  double x = 0, y = 0;          ///< beam-weighted centre of the predicted hit points (m)
  double w = 0, h = 0;          ///< extent of its cells (m)
  bool short_ = true;           ///< ranges shorter than the map says
  long beams = 0;
  double mean_norm = 0;         ///< mean normalised residual (clipped at +-kClipZ)
  std::vector<std::array<double, 2>> seen_from;  ///< a few robot positions it was seen from
  int poses = 0;                ///< distinct scans that saw it
  bool has_segment = false;
  double seg[4] = {0, 0, 0, 0};  ///< candidate wall: where the beams really ended, as a line
  std::vector<int> cells;        ///< grid cells (row-major index)
  RegionHistory history;         ///< when it was seen, how often it disagreed, its kind
};

struct MapMisfit {
  double cell_m = 0.25;            ///< the grid's cell: as asked, or wider on a map too large for it
  double cell_asked_m = 0.25;
  double x0 = 0, y0 = 0;  ///< grid origin
  int nx = 0, ny = 0;
  std::string grid_note;           ///< why the grid is wider than asked, or why there is none ("": neither)
  std::vector<long> count;         ///< beams per cell
  std::vector<double> mean, rms;   ///< normalised residual per cell
  std::vector<double> t;           ///< per-cell t over scans (NaN: not tested)
  double t_crit = 0;               ///< Bonferroni threshold over the tested cells
  int tested = 0;
  std::vector<MapRegion> regions;
  /// Per beam of the run (scan * beams + beam): its predicted hit falls in a region.
  std::vector<std::uint8_t> in_region;
  /// Per map wall, the same residuals in bins of kWallBinM along its length (from its
  /// first end; a wall longer than kMaxWallBins bins has longer bins): count and mean
  /// normalised residual.
  struct WallBin {
    long count = 0;
    double sum = 0;
  };
  std::vector<std::vector<WallBin>> walls;
  std::vector<double> wall_bin_m;  ///< per wall, its bins' length (m)
};

/// Bin length along a wall (m).
constexpr double kWallBinM = 0.5;
/// The most bins along one wall (2 km at kWallBinM).
constexpr int kMaxWallBins = 4096;
/// The most cells of the residual grid: a map wider than that at the asked cell (256 m
/// square at 0.25 m) gets wider cells, and the JSON says so.
constexpr double kMaxGridCells = 1048576.0;

/// Where beam `beam` of `laser` ends on `map` from the robot pose (x, y, theta), as the
/// filter casts it (mount offset and yaw included): the laser's position (lx, ly), the
/// ray's unit direction (ux, uy), the range, the hit point and the wall. False when the
/// beam hits no wall.
struct BeamHit {
  double lx, ly, ux, uy, range, hx, hy;
  int wall;
};
template <typename MapT, typename LaserT>
bool beamHit(const MapT& map, const LaserT& laser, double x, double y, double theta, int beam, BeamHit* out) {
  const auto& cfg = laser.config();
  const double c = std::cos(theta), sn = std::sin(theta);
  BeamHit h{};
  h.lx = x + c * cfg.mount_x - sn * cfg.mount_y;
  h.ly = y + sn * cfg.mount_x + c * cfg.mount_y;
  h.ux = c * laser.dirC(beam) - sn * laser.dirS(beam);
  h.uy = sn * laser.dirC(beam) + c * laser.dirS(beam);
  const auto hit = map.castDir(h.lx, h.ly, h.ux, h.uy);
  if (!hit.hit) return false;
  h.range = hit.range;
  h.hx = h.lx + hit.range * h.ux;
  h.hy = h.ly + hit.range * h.uy;
  h.wall = hit.wall;
  *out = h;
  return true;
}

/// The grid and the regions from a run recorded with `residuals`.
template <typename En>
MapMisfit mapMisfit(const En& en, const typename En::RunOut& run, double cell_m);

/// The "map_misfit" object of the contract (grid_csv: the file written by writeMapCsv, or "").
nlohmann::ordered_json mapMisfitJson(const MapMisfit& m, const std::string& grid_csv);

/// DIR/map_grid.csv: cell centre, count, mean and RMS of the normalised residual, t, region.
bool writeMapCsv(const std::string& dir, const MapMisfit& m, std::string* error);

}  // namespace odoerr::sim::diag
