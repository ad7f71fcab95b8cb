// sim_host: a differential-drive robot driven along a path through any map of line
// segments, with the paper's odometry error model (Table 1 truth, eqs. 1-4) and a range
// finder cast against the map: the drives on which the map index, the beam selection and
// the firmware's cycle cost are measured in rooms, offices and real buildings.
//
// The robot follows the path by pure pursuit (a point lookahead_m ahead on the path) on its TRUE pose (an ideal external
// controller: the drive is the same whatever the estimator does), at step_m per cycle.
// The commanded wheel travel becomes encoder ticks through the true systematic parameters;
// the true motion of the cycle is then drawn from the error model given those readings,
// exactly as in PaperSim. Ranges are the true ones plus N(0, sigma^2); beams that hit
// nothing within range_max are nan.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "odoerr/motion.hpp"
#include "odoerr/sim/host_map.hpp"
#include "odoerr/sim/paper_sim.hpp"

namespace odoerr::sim {

struct PathPoint {
  double x, y;
};

struct MapDriveConfig {
  std::vector<PathPoint> path;  ///< waypoints, driven in order (at least 2)
  bool loop = false;            ///< start again at the first waypoint at the end
  int steps = 3000;             ///< cycles
  double step_m = 0.01;         ///< travel per cycle
  double dt_s = 0.01;           ///< time per cycle
  double lookahead_m = 0.6;     ///< pure pursuit
  double max_curvature = 4.0;   ///< 1/m (the robot turns on a 0.25 m radius at the tightest)
  /// A SICK LMS2xx in its 180 deg / 1 deg mode by default: 181 beams.
  LaserConfig<double> laser{181, -kPi<double> / 2, kPi<double> / 180, 20.0, 0.03, 0, 0, 0};
  // Encoders and truth: the paper's differential drive (SimConfig's Table 1 values).
  double wheel_radius_m = 0.05;
  double ticks_per_rev = 4096.0;
  double wheelbase_m = 0.5;
  double delta_r = 1.1, delta_l = 0.9, delta_d = 1.1, k_w = 2.5e-4;
  double init_sigma_xy = 0.001;
  double init_sigma_theta = 0.1 * kPi<double> / 180.0;
};

struct MapDriveStep {
  DiffDrive<double>::Input input{};  ///< encoder increments (m) from the tick counts
  EncoderSample counts{};
  std::vector<double> ranges;
  Pose<double> truth{};
  double t = 0;
};

class MapDrive {
 public:
  /// The map must outlive the drive. False with *error when the path is too short or
  /// its start is not finite.
  MapDrive(const MapDriveConfig& cfg, const HostMap<double>& map, std::uint64_t seed);
  bool ok(std::string* error) const;

  const MapDriveConfig& config() const { return cfg_; }
  Pose<double> truth() const { return truth_; }
  Pose<double> initialEstimate() const { return init_est_; }
  double ticksPerMetre() const { return cfg_.ticks_per_rev / (2 * kPi<double> * cfg_.wheel_radius_m); }
  DiffDrive<double>::NonSysVec trueNonSys() const {
    DiffDrive<double>::NonSysVec k;
    k << cfg_.k_w;
    return k;
  }

  /// Advances one cycle: steer on the truth, move it, take a scan.
  MapDriveStep step();
  /// Simulated ranges from a pose.
  void scan(const Pose<double>& p, std::vector<double>* ranges);

 private:
  double curvature();

  MapDriveConfig cfg_;
  const HostMap<double>& map_;
  std::mt19937_64 rng_;
  DiffDrive<double> drive_{};
  Pose<double> truth_{};
  Pose<double> init_est_{};
  std::size_t seg_ = 0;  ///< the path segment the robot follows (path[seg_] to the next point)
  double pos_r_ = 0, pos_l_ = 0;
  EncoderSample counts_{};
  long k_ = 0;
  std::string error_;
};

/// Reads a path: an odolog file (its truth records, thinned to one point per 0.1 m) or a
/// text file of "X Y" lines (# comments). False with *error naming the file and line.
bool readPath(const std::string& path, std::vector<PathPoint>* out, std::string* error);

/// The drive as odolog v1 text (header, walls, then enc / scan / truth every cycle).
bool mapDriveOdolog(const MapDriveConfig& cfg, const std::vector<OdologWall>& walls, std::uint64_t seed,
                    const std::string& map_name, std::string* text, std::string* error);

}  // namespace odoerr::sim
