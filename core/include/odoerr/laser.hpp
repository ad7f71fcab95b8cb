// odoerr core: the range finder's set-up and the beams the filter uses from each scan.
#pragma once

#include "odoerr/scalar.hpp"

namespace odoerr {

/// Beams whose predicted range is shorter than this many sigma (LaserConfig::sigma) are not
/// fused (Status::kTooClose). A range finder reports no return when range plus noise is at
/// or below zero, so the returns it does report there are cut off from below and biased
/// away from the wall: at 2 sigma the bias is 0.05 sigma, at 1 sigma 0.29 sigma. Measured on
/// the paper's circle, which touches the walls: with K at the truth and these beams fused,
/// the squared pose error within 5 cm of a wall was 2.2x its variance in x and y and 2.7x
/// in heading; with them refused, 0.75-1.05x (docs/nonsystematic.md).
template <typename S>
inline constexpr S kNearRangeSigmas = S(2);

/// Range finder set-up (the `laser` record of odolog v1).
template <typename S>
struct LaserConfig {
  int beams = 36;
  S angle_min = -kPi<S>;
  S angle_inc = kTwoPi<S> / S(36);
  S range_max = S(20);
  S sigma = S(0.03);
  S mount_x = S(0);
  S mount_y = S(0);
  S mount_yaw = S(0);
};

/// The laser set-up with each beam's direction in the robot frame tabulated once, so that a
/// beam costs no trigonometry in the filter's inner loop, and the beams the filter fuses
/// from each scan.
///
/// Beam selection (docs/architecture.md, "Beams per scan"): a scan has beams() ranges; the
/// filter uses used() of them, spread evenly: with stride = beams() / used(), slot k
/// covers the beams k*stride .. k*stride + stride - 1. Each scan starts its slots at the
/// next phase (0, 1, .., stride - 1, 0, ..), so successive scans sample every beam; within
/// its slot a beam without a return gives way to the next beam of the slot that has one.
/// With used() == beams() every beam is used in every scan.
template <typename S, int MaxBeams = 64>
class LaserGeometry {
 public:
  static constexpr int kMaxBeams = MaxBeams;
  LaserGeometry() = default;

  /// Returns false (and stays empty) when the set-up has too many beams or is not finite.
  /// `use` beams are fused per scan (0 or >= beams: all of them).
  [[nodiscard]] bool init(const LaserConfig<S>& cfg, int use = 0) {
    beams_ = 0;
    used_ = 0;
    stride_ = 1;
    if (cfg.beams < 0 || cfg.beams > MaxBeams || use < 0) return false;
    if (!(isFinite(cfg.angle_min) && isFinite(cfg.angle_inc) && isFinite(cfg.mount_x) &&
          isFinite(cfg.mount_y) && isFinite(cfg.mount_yaw) && cfg.sigma > S(0) &&
          cfg.range_max > S(0))) {
      return false;
    }
    cfg_ = cfg;
    for (int i = 0; i < cfg.beams; ++i) {
      const S a = cfg.mount_yaw + cfg.angle_min + S(i) * cfg.angle_inc;
      dir_c_[i] = std::cos(a);
      dir_s_[i] = std::sin(a);
    }
    beams_ = cfg.beams;
    used_ = (use == 0 || use >= cfg.beams) ? cfg.beams : use;
    stride_ = used_ > 0 ? cfg.beams / used_ : 1;
    return true;
  }
  /// Ranges per scan.
  int beams() const { return beams_; }
  /// Beams fused per scan.
  int used() const { return used_; }
  /// Beams per slot (1: every beam of every scan).
  int stride() const { return stride_; }
  /// The first beam of slot k at the given phase (0 <= phase < stride()).
  int slotBeam(int k, int phase) const { return k * stride_ + phase; }
  const LaserConfig<S>& config() const { return cfg_; }
  S dirC(int i) const { return dir_c_[i]; }
  S dirS(int i) const { return dir_s_[i]; }

 private:
  LaserConfig<S> cfg_{};
  int beams_ = 0;
  int used_ = 0;
  int stride_ = 1;
  S dir_c_[MaxBeams]{};
  S dir_s_[MaxBeams]{};
};

}  // namespace odoerr
