// sim_host: the deterministic simulator of Section 5.
//
// A 10 m square room (4 known walls); the robot follows a circle of radius 5 m centred in
// the room, counter-clockwise from polar angle 45 deg, one filter cycle per cm of travel.
// Encoders are quantised cumulative tick counters; the true motion of each cycle is drawn
// from the odometry error model (1)-(4) given the encoder readings, with the Table 1
// parameters; 36 beams every 10 deg with N(0, (3 cm)^2) range noise.
//
// The robot steers in closed loop on its own estimate (open loop drifts out of the room):
// curvature command  kappa = 1/R + k1 e_r - k2 e_theta, with e_r the estimated radial
// error (outward positive) and e_theta the estimated heading minus the tangent heading.
// Linearised per unit distance: e_r'' + k2 e_r' + k1 e_r = 0; k1 = 0.25 /m^2, k2 = 1 /m is
// critically damped with a 2 m length scale. The commanded increments are converted into
// wheel (encoder) motion with the estimated systematic parameters.
#pragma once

#include <array>
#include <cstdint>
#include <random>

#include "odoerr/akf.hpp"
#include "odoerr/map.hpp"
#include "odoerr/motion.hpp"
#include "odoerr/sim/random.hpp"

namespace odoerr::sim {

constexpr int kMaxBeams = 64;

struct SimConfig {
  // path
  double room = 10.0;
  double center_x = 5.0;
  double center_y = 5.0;
  double radius = 5.0;
  double start_polar_rad = 45.0 * kPi<double> / 180.0;
  int steps = 3000;          ///< cycles; 3000 x 1 cm = 30 m
  double step_m = 0.01;      ///< estimated travel per cycle
  double dt_s = 0.01;        ///< time per cycle (1 m/s), for logs
  double gain_radial = 0.25; ///< k1 (1/m^2)
  double gain_heading = 1.0; ///< k2 (1/m)
  /// Figure-eight instead of the circle: two lobes of radius `radius`, centred at
  /// (center_x, center_y +- radius), the upper one counter-clockwise and the lower one
  /// clockwise, joined at (center_x, center_y) heading +x; the lobe changes after each lap
  /// of 2 pi radius of travel. Turns both ways excite delta_d (the circle does not).
  bool figure_eight = false;
  // laser
  LaserConfig<double> laser{};
  // encoders
  double sync_ticks_per_m = 10000.0;
  double sync_ticks_per_rad = 10000.0;
  double wheel_radius_m = 0.05;
  double ticks_per_rev = 4096.0;
  double wheelbase_m = 0.5;  ///< nominal d; the true one is d * delta_d
  // truth (Table 1)
  double delta_rho = 1.1;
  double e_theta = 1.0 * kPi<double> / 180.0;    // rad/m
  double k_rho = 1.0e-3;                         // m
  double k_theta = kPi<double> / 180.0 * kPi<double> / 180.0;  // 1 deg^2/m in rad^2/m
  double delta_r = 1.1;
  double delta_l = 0.9;
  double delta_d = 1.1;
  double k_w = 2.5e-4;  // m
  // prior of the initial pose (the estimate starts at truth + a draw from it)
  double init_sigma_xy = 0.001;
  double init_sigma_theta = 0.1 * kPi<double> / 180.0;
};

/// Encoder readings of one cycle with the raw cumulative counts they came from.
struct EncoderSample {
  std::int64_t count_a = 0;  ///< diff: right wheel; sync: translation
  std::int64_t count_b = 0;  ///< diff: left wheel; sync: steering
};

template <typename Drive>
struct SimStep {
  typename Drive::Input input{};  ///< encoder increments (m / rad) from the tick counts
  EncoderSample counts{};
  std::array<double, kMaxBeams> ranges{};
  Pose<double> truth{};
  double t = 0.0;
};

template <typename Drive>
class PaperSim {
 public:
  using Input = typename Drive::Input;
  using ParamVec = typename Drive::ParamVec;
  using NonSysVec = typename Drive::NonSysVec;
  static constexpr bool kSync = std::is_same_v<Drive, SyncDrive<double>>;

  PaperSim(const SimConfig& cfg, std::uint64_t seed) : cfg_(cfg), rng_(seed) {
    const double r = cfg_.room;
    const Segment<double> walls[4] = {{0, 0, r, 0}, {r, 0, r, r}, {r, r, 0, r}, {0, r, 0, 0}};
    for (const auto& w : walls) (void)map_.add(w);
    if (cfg_.figure_eight) {
      truth_.x = cfg_.center_x;
      truth_.y = cfg_.center_y;
      truth_.theta = 0.0;
      lap_cycles_ = static_cast<long>(std::llround(2 * kPi<double> * cfg_.radius / cfg_.step_m));
    } else {
      truth_.x = cfg_.center_x + cfg_.radius * std::cos(cfg_.start_polar_rad);
      truth_.y = cfg_.center_y + cfg_.radius * std::sin(cfg_.start_polar_rad);
      truth_.theta = wrapAngle(cfg_.start_polar_rad + kPi<double> / 2);
    }
    if constexpr (!kSync) drive_.wheelbase = cfg_.wheelbase_m;
    odoerr::sim::NormalDist<double> n01(0.0, 1.0);
    init_est_.x = truth_.x + cfg_.init_sigma_xy * n01(rng_);
    init_est_.y = truth_.y + cfg_.init_sigma_xy * n01(rng_);
    init_est_.theta = wrapAngle(truth_.theta + cfg_.init_sigma_theta * n01(rng_));
  }

  const SimConfig& config() const { return cfg_; }
  const SegmentMap<double>& map() const { return map_; }
  const Drive& drive() const { return drive_; }
  Pose<double> truth() const { return truth_; }
  /// The initial pose estimate: truth plus a draw from the prior.
  Pose<double> initialEstimate() const { return init_est_; }

  ParamVec trueParams() const {
    if constexpr (kSync) {
      return ParamVec(cfg_.delta_rho, cfg_.e_theta);
    } else {
      return ParamVec(cfg_.delta_r, cfg_.delta_l, cfg_.delta_d);
    }
  }
  NonSysVec trueNonSys() const {
    if constexpr (kSync) {
      return NonSysVec(cfg_.k_rho, cfg_.k_theta);
    } else {
      NonSysVec k;
      k << cfg_.k_w;
      return k;
    }
  }
  double ticksA() const {
    return kSync ? cfg_.sync_ticks_per_m : cfg_.ticks_per_rev / (2 * kPi<double> * cfg_.wheel_radius_m);
  }
  double ticksB() const {
    return kSync ? cfg_.sync_ticks_per_rad : cfg_.ticks_per_rev / (2 * kPi<double> * cfg_.wheel_radius_m);
  }

  /// Advances one cycle: steer on the given estimate, move the truth, take a scan.
  SimStep<Drive> step(const Pose<double>& est, const ParamVec& est_params) {
    const double kappa = curvatureCommand(est);
    // Commanded encoder motion from the desired increment, with the estimated parameters.
    double cmd_a;
    double cmd_b;
    const double s = cfg_.step_m;
    if constexpr (kSync) {
      cmd_a = s / est_params[0];
      cmd_b = kappa * s - est_params[1] * cmd_a;
    } else {
      const double half = 0.5 * kappa * s * cfg_.wheelbase_m * est_params[2];
      cmd_a = (s + half) / est_params[0];
      cmd_b = (s - half) / est_params[1];
    }
    pos_a_ += cmd_a;
    pos_b_ += cmd_b;
    SimStep<Drive> out;
    out.counts.count_a = static_cast<std::int64_t>(std::llround(pos_a_ * ticksA()));
    out.counts.count_b = static_cast<std::int64_t>(std::llround(pos_b_ * ticksB()));
    const double da = double(out.counts.count_a - counts_.count_a) / ticksA();
    const double db = double(out.counts.count_b - counts_.count_b) / ticksB();
    counts_ = out.counts;
    if constexpr (kSync) {
      out.input.rho_e = da;
      out.input.theta_e = db;
    } else {
      out.input.right = da;
      out.input.left = db;
    }
    // True motion drawn from the error model given the readings.
    const typename Drive::NoiseVec var = drive_.noiseVariance(out.input, trueNonSys());
    typename Drive::NoiseVec nu;
    odoerr::sim::NormalDist<double> n01(0.0, 1.0);
    for (int i = 0; i < Drive::kNoise; ++i) nu[i] = std::sqrt(var[i]) * n01(rng_);
    Drive truth_drive = drive_;
    const Increment<double> inc = truth_drive.increment(out.input, trueParams(), nu);
    truth_ = applyIncrement(truth_, inc);
    ++k_;
    if (cfg_.figure_eight && ++lobe_cycles_ >= lap_cycles_) {
      lobe_cycles_ = 0;
      lower_lobe_ = !lower_lobe_;
    }
    out.t = k_ * cfg_.dt_s;
    out.truth = truth_;
    scan(truth_, out.ranges.data());
    return out;
  }

  /// Simulated ranges from a pose (nan where the beam hits nothing).
  void scan(const Pose<double>& p, double* ranges) {
    const auto& l = cfg_.laser;
    odoerr::sim::NormalDist<double> n01(0.0, 1.0);
    const double c = std::cos(p.theta);
    const double sn = std::sin(p.theta);
    const double lx = p.x + c * l.mount_x - sn * l.mount_y;
    const double ly = p.y + sn * l.mount_x + c * l.mount_y;
    for (int i = 0; i < l.beams && i < kMaxBeams; ++i) {
      const double a = p.theta + l.mount_yaw + l.angle_min + i * l.angle_inc;
      const RayHit<double> h = map_.cast(lx, ly, a);
      const double noise = l.sigma * n01(rng_);
      ranges[i] = h.hit ? h.range + noise : std::numeric_limits<double>::quiet_NaN();
      if (h.hit && (ranges[i] <= 0.0 || ranges[i] > l.range_max)) {
        ranges[i] = std::numeric_limits<double>::quiet_NaN();
      }
    }
  }

 private:
  double curvatureCommand(const Pose<double>& est) const {
    if (cfg_.figure_eight) {
      // The lobe's circle; clockwise is the counter-clockwise law mirrored.
      const double sgn = lower_lobe_ ? -1.0 : 1.0;
      const double dx = est.x - cfg_.center_x;
      const double dy = est.y - (cfg_.center_y + sgn * cfg_.radius);
      const double e_r = std::hypot(dx, dy) - cfg_.radius;
      const double tangent = std::atan2(dy, dx) + sgn * kPi<double> / 2;
      const double e_th = wrapAngle(est.theta - tangent);
      return sgn * (1.0 / cfg_.radius + cfg_.gain_radial * e_r) - cfg_.gain_heading * e_th;
    }
    const double dx = est.x - cfg_.center_x;
    const double dy = est.y - cfg_.center_y;
    const double e_r = std::hypot(dx, dy) - cfg_.radius;
    const double tangent = std::atan2(dy, dx) + kPi<double> / 2;
    const double e_th = wrapAngle(est.theta - tangent);
    return 1.0 / cfg_.radius + cfg_.gain_radial * e_r - cfg_.gain_heading * e_th;
  }

  SimConfig cfg_;
  std::mt19937_64 rng_;
  SegmentMap<double> map_{};
  Drive drive_{};
  Pose<double> truth_{};
  Pose<double> init_est_{};
  double pos_a_ = 0.0;
  double pos_b_ = 0.0;
  EncoderSample counts_{};
  long k_ = 0;
  long lap_cycles_ = 0;   ///< figure-eight: cycles per lobe
  long lobe_cycles_ = 0;  ///< figure-eight: cycles on the current lobe
  bool lower_lobe_ = false;
};

}  // namespace odoerr::sim
