// sim_host: telling a lost track and finding the robot again on the map (host only; the
// firmware's cycle does not use it). The anchors are AMCL's likelihood field (a scan is
// scored by how close its end points fall to the map's walls) and Cartographer's
// correlative scan matcher (an exhaustive search of poses in a window, coarse to fine).
// docs/calibrate.md, "Lost and found", states the rules and their figures.
#pragma once

#include <string>
#include <vector>

#include "odoerr/sim/odolog.hpp"

namespace odoerr::sim {

/// The distance from each cell of a grid over the map to the nearest wall, clipped at
/// max_dist_m (a two-pass chamfer transform of the walls drawn into the grid: within 8 %
/// of the Euclidean distance).
class LikelihoodField {
 public:
  /// False with *error when there is no wall, a wall is not finite, or the grid over the
  /// walls would exceed 16 M cells.
  bool build(const std::vector<OdologWall>& walls, double cell_m, double max_dist_m, std::string* error);
  /// Distance (m) from (x, y) to the nearest wall, max_dist_m outside the grid.
  double distance(double x, double y) const;
  double maxDistance() const { return max_; }
  bool empty() const { return d_.empty(); }
  /// The grid: nx() x ny() cells of cell() m, cell (i, j) from (x0() + i cell(), y0() + j
  /// cell()); cellDistance(i, j) its distance (i, j inside the grid).
  int nx() const { return nx_; }
  int ny() const { return ny_; }
  double cell() const { return cell_; }
  double x0() const { return x0_; }
  double y0() const { return y0_; }
  double cellDistance(int i, int j) const { return double(d_[std::size_t(j) * std::size_t(nx_) + std::size_t(i)]); }

 private:
  double x0_ = 0, y0_ = 0, cell_ = 0.05, max_ = 1.0;
  int nx_ = 0, ny_ = 0;
  std::vector<float> d_;
};

/// A beam's end point in the robot frame.
struct ScanPoint {
  double x, y;
};

/// The end points of a scan's returns (finite, below range_max) in the robot frame, through
/// the laser's mount; at most max_points of them, spread evenly over the beams.
std::vector<ScanPoint> scanPoints(const OdologLaser& laser, const double* ranges, int max_points);

/// The fit of the points at pose (x, y, theta): the mean over them of
/// exp(-d^2 / (2 sigma^2)), d the distance of the point to the nearest wall. In [0, 1]; 0
/// when there is no point.
double scanFit(const LikelihoodField& field, const std::vector<ScanPoint>& pts, double x, double y, double theta,
               double sigma);

struct ScanMatch {
  double x = 0, y = 0, theta = 0;
  double fit = 0;  ///< scanFit at the match with the caller's sigma
  /// The best fit of a candidate at least 0.5 m or 0.3 rad from the match (0: none): a
  /// match that does not beat it clearly is ambiguous (a corridor, a symmetric room).
  double runner_up = 0;
};

/// The rules of ReplayOptions::relocalise (docs/calibrate.md, "Lost and found").
struct TrackingRules {
  double field_cell_m = 0.05;  ///< the likelihood field's cell
  double sigma_m = 0.10;       ///< the fit's distance scale (a 5 cm map, beams 1 deg wide)
  int max_points = 180;        ///< end points per scan scored
  double poor_fit = 0.5;       ///< a scan fitting worse at the filter's pose is checked...
  double check_m = 0.5, check_rad = 0.2;  ///< ...by a search of this window around it;
  double gain = 0.15;          ///< the search fitting better by this much is evidence of a loss,
  double very_poor_fit = 0.25; ///< and so is a fit below this (hardly an end point near a wall)
  int lost_after = 3;          ///< consecutive scans of such evidence: the track is lost;
  ///< but a poor scan whose local search finds a clear, unambiguous better pose has that
  ///< pose fused at once as a pose fix (counted as a correction)
  double distinct = 0.10;      ///< a match must beat its runner-up by this much
  double fix_sigma_m = 0.10, fix_sigma_rad = 0.03;  ///< the correction's pose-fix sigmas;
  double reset_sigmas = 3;     ///< a correction farther than 3 of them sets the pose instead
  double accept_fit = 0.5;     ///< a corrected pose must fit at least this well; a relocalised
  double found_share = 0.85;   ///< one at least this share of the median fit of the scans so far,
  double window_m = 2.0, window_rad = 0.6;  ///< searched in this window first,
  int widen_after = 5;         ///< then in one twice as wide after every 5 failed scans
                               ///< (searched on every 5th scan while lost)
  double max_window_m = 4.0, max_window_rad = 3.2;
  bool global = true;          ///< past the widest window, the whole map is searched (matchGlobal)
  int snapshots = 10;          ///< the estimator is restored from the oldest of the last 10 good scans
};

/// The pose of best fit within +-window_m and +-window_rad of (x, y, theta): an exhaustive
/// search on a coarse lattice (0.1 m, 0.02 rad, the fit's sigma doubled to smooth it), then
/// its best candidates refined twice on lattices four times finer.
ScanMatch matchScan(const LikelihoodField& field, const std::vector<ScanPoint>& pts, double x, double y,
                    double theta, double window_m, double window_rad, double sigma);

/// The pose of best fit anywhere on the map, every heading: a branch and bound over the
/// translations at each heading of a 0.02 rad lattice (the field's cells, the fit's sigma
/// doubled), blocks whose bound on the fit falls below `floor` never opened, then the best
/// distinct candidates refined as in matchScan. fit 0 when no pose reaches `floor` (with
/// the doubled sigma). `work` counts the bounds and leaves evaluated.
ScanMatch matchGlobal(const LikelihoodField& field, const std::vector<ScanPoint>& pts, double sigma, double floor,
                      std::size_t* work = nullptr);

}  // namespace odoerr::sim
