// odoerr core: the measurement effects of the catalogue (docs/effect-catalogue.md). Each
// one either moves the ray before it is cast (mount offsets, latency: kShiftsRay) or
// corrects the cast range (bias, scale, wall offset, to first order: a wall moved along its
// normal), and gives d range / d parameters for the scalar update. The simulators apply
// the exact physics, so the tests measure what the linearisation costs.
#pragma once

#include <Eigen/Core>

#include "odoerr/effects/motion_effects.hpp"  // NominalZero
#include "odoerr/model.hpp"

namespace odoerr::effects {

/// r = r_true + b.
struct RangeBias : NominalZero<RangeBias> {
  static constexpr EffectKind kKind = EffectKind::kMeasurement;
  static constexpr bool kShiftsRay = false;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "range_bias";
  static constexpr const char* kParamNames[kParams] = {"b_m"};
  static constexpr const char* kDescription = "the laser adds a constant offset to every range";
  static constexpr double kPriorSigma[kParams] = {0.05};
  static constexpr double kReference[kParams] = {0.01};
  template <typename S>
  S range(const BeamContext<S>&, const S* p, S* dr_dp) const {
    dr_dp[0] = S(1);
    return p[0];
  }
};

/// r = r_true (1 + s).
struct RangeScale : NominalZero<RangeScale> {
  static constexpr EffectKind kKind = EffectKind::kMeasurement;
  static constexpr bool kShiftsRay = false;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "range_scale";
  static constexpr const char* kParamNames[kParams] = {"s"};
  static constexpr const char* kDescription = "the laser's ranges are scaled (a timing or calibration error)";
  static constexpr double kPriorSigma[kParams] = {0.02};
  static constexpr double kReference[kParams] = {0.003};
  template <typename S>
  S range(const BeamContext<S>& b, const S* p, S* dr_dp) const {
    dr_dp[0] = b.range;
    return p[0] * b.range;
  }
};

/// The laser sits at (mount_x + dx, mount_y + dy) in the robot frame.
struct LaserMountXY : NominalZero<LaserMountXY> {
  static constexpr EffectKind kKind = EffectKind::kMeasurement;
  static constexpr bool kShiftsRay = true;
  static constexpr int kParams = 2;
  static constexpr const char* kName = "laser_mount_xy";
  static constexpr const char* kParamNames[kParams] = {"dx_m", "dy_m"};
  static constexpr const char* kDescription = "the laser is mounted off the position the model assumes";
  static constexpr double kPriorSigma[kParams] = {0.05, 0.05};
  static constexpr double kReference[kParams] = {0.01, 0.01};
  template <typename S>
  void shift(const RayContext<S>& rc, const S* p, RayShift<S>* out) const {
    // the offset rotated into the world frame moves the laser
    out->dlx += rc.c * p[0] - rc.sn * p[1];
    out->dly += rc.sn * p[0] + rc.c * p[1];
  }
  template <typename S>
  S range(const BeamContext<S>& b, const S*, S* dr_dp) const {
    dr_dp[0] = b.drdx * b.c + b.drdy * b.sn;
    dr_dp[1] = -b.drdx * b.sn + b.drdy * b.c;
    return S(0);
  }
};

/// The laser's yaw is mount_yaw + dpsi.
struct LaserMountYaw : NominalZero<LaserMountYaw> {
  static constexpr EffectKind kKind = EffectKind::kMeasurement;
  static constexpr bool kShiftsRay = true;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "laser_mount_yaw";
  static constexpr const char* kParamNames[kParams] = {"dpsi_rad"};
  static constexpr const char* kDescription = "the laser is rotated on its mount relative to the model";
  static constexpr double kPriorSigma[kParams] = {0.05};
  static constexpr double kReference[kParams] = {0.005};
  template <typename S>
  void shift(const RayContext<S>&, const S* p, RayShift<S>* out) const {
    out->da += p[0];
  }
  template <typename S>
  S range(const BeamContext<S>& b, const S*, S* dr_dp) const {
    dr_dp[0] = b.drda;
    return S(0);
  }
};

/// The scan stamped t was taken at t - tau: the pose then was the pose now minus tau times
/// the velocity.
struct ScanLatency : NominalZero<ScanLatency> {
  static constexpr EffectKind kKind = EffectKind::kMeasurement;
  static constexpr bool kShiftsRay = true;
  static constexpr int kParams = 1;
  static constexpr const char* kName = "scan_latency";
  static constexpr const char* kParamNames[kParams] = {"tau_s"};
  static constexpr const char* kDescription =
      "scans are time-stamped late: each was taken a little before its stamp, from where the robot was then";
  static constexpr double kPriorSigma[kParams] = {0.05};
  static constexpr double kReference[kParams] = {0.01};
  template <typename S>
  void shift(const RayContext<S>& rc, const S* p, RayShift<S>* out) const {
    // the robot tau earlier: position - tau v, heading - tau w (which also swings the lever)
    out->dlx -= p[0] * (rc.vx + rc.w * rc.lever_x);
    out->dly -= p[0] * (rc.vy + rc.w * rc.lever_y);
    out->da -= p[0] * rc.w;
  }
  template <typename S>
  S range(const BeamContext<S>& b, const S*, S* dr_dp) const {
    dr_dp[0] = -(b.drdx * b.vx + b.drdy * b.vy + b.drdth * b.w);
    return S(0);
  }
};

/// Wall w lies o_w further along its left unit normal than the map says.
template <int MaxWalls = 16>
struct WallOffsetN : NominalZero<WallOffsetN<MaxWalls>> {
  static constexpr EffectKind kKind = EffectKind::kMeasurement;
  static constexpr bool kShiftsRay = false;
  static constexpr int kParams = MaxWalls;
  static constexpr const char* kName = "wall_offset";
  static constexpr const char* kDescription = "a wall is not where the map puts it";
  static constexpr const char* kParamNames[16] = {"o0", "o1", "o2",  "o3",  "o4",  "o5",  "o6",  "o7",
                                                  "o8", "o9", "o10", "o11", "o12", "o13", "o14", "o15"};
  static_assert(MaxWalls <= 16, "name more parameters");
  static constexpr double kPriorSigma[1] = {0.05};  ///< every wall alike
  static constexpr double kReference[1] = {0.02};
  template <typename S>
  S range(const BeamContext<S>& b, const S* p, S* dr_dp) const {
    for (int k = 0; k < kParams; ++k) dr_dp[k] = S(0);
    if (b.wall < 0 || b.wall >= kParams) return S(0);
    const S inv = S(1) / b.n_dot_u;
    dr_dp[b.wall] = inv;
    return p[b.wall] * inv;
  }
};
using WallOffset = WallOffsetN<16>;

}  // namespace odoerr::effects
