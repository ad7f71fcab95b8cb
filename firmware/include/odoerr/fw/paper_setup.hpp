// The paper's estimator set-up (Section 5 room, laser and priors), shared by the host
// simulator and the firmware images so that every build configures the filter identically.
// Core only: no I/O, no heap.
#pragma once

#include <type_traits>

#include "odoerr/estimator.hpp"

namespace odoerr::fw {

/// The filter's priors and options (docs/paper-notes.md, section (e), justifies them).
struct FilterSetup {
  double sigma_pose_xy = 0.001;
  double sigma_pose_theta = 0.1 * kPi<double> / 180.0;
  double sigma_scale = 0.2;                           ///< delta_rho, delta_R, delta_L, delta_d
  double sigma_e_theta = 2.0 * kPi<double> / 180.0;   ///< E_theta (rad/m)
  double nonsys_factor_small = 0.01;
  double nonsys_factor_large = 100.0;
  double nonsys_rel_sigma = 10.0;  ///< sigma of K0 relative to K0 (order-of-magnitude prior)
  double wheelbase_m = 0.5;
  double room_m = 10.0;
  AkfConfig<double> akf{};
  OfConfig<double> of{};
  LaserConfig<double> laser{};
};

template <typename S, template <typename> class DriveT>
struct PaperTypes {
  using ModelT = Model<DriveT<S>>;
  using EstimatorT = Estimator<ModelT>;
  static constexpr bool kSync = std::is_same_v<DriveT<S>, SyncDrive<S>>;
};

/// The laser set-up of `setup` in scalar S.
template <typename S>
LaserConfig<S> laserConfig(const FilterSetup& setup) {
  const auto& lc = setup.laser;
  return LaserConfig<S>{lc.beams, S(lc.angle_min), S(lc.angle_inc), S(lc.range_max),
                        S(lc.sigma), S(lc.mount_x), S(lc.mount_y), S(lc.mount_yaw)};
}

/// Builds an estimator of `setup`'s priors and options on any map and laser, initialised at
/// `init` with the non-systematic estimate k0.
template <typename Est, template <typename> class DriveT>
Est makeEstimatorOn(const FilterSetup& setup, const typename Est::MapT& map, const typename Est::LaserT& laser,
                    const Pose<double>& init, const typename DriveT<typename Est::S>::NonSysVec& k0) {
  using S = typename Est::S;
  using ModelT = typename Est::Model;
  constexpr bool kSync = std::is_same_v<DriveT<S>, SyncDrive<S>>;
  DriveT<S> drive;
  if constexpr (!kSync) drive.wheelbase = S(setup.wheelbase_m);
  const AkfConfig<S> ac{S(setup.akf.max_incidence_rad), S(setup.akf.gate_nis)};
  const OfConfig<S> oc{setup.of.window, setup.of.pose_term, S(setup.of.min_fraction_of_initial)};
  Est est(ModelT(drive), map, laser, ac, oc);

  typename ModelT::StateVec x0 = ModelT::StateVec::Zero();
  x0[PoseIdx::kX] = S(init.x);
  x0[PoseIdx::kY] = S(init.y);
  x0[PoseIdx::kTheta] = S(init.theta);
  ModelT::setNominal(x0);
  typename ModelT::StateVec sig;
  sig.setConstant(S(setup.sigma_scale));
  sig[PoseIdx::kX] = S(setup.sigma_pose_xy);
  sig[PoseIdx::kY] = S(setup.sigma_pose_xy);
  sig[PoseIdx::kTheta] = S(setup.sigma_pose_theta);
  if constexpr (kSync) sig[ModelT::kDriveOffset + SyncDrive<S>::kETheta] = S(setup.sigma_e_theta);
  typename Est::OfT::KMat pk0 = (k0 * S(setup.nonsys_rel_sigma)).cwiseAbs2().asDiagonal();
  typename ModelT::StateMat p0 = sig.cwiseAbs2().asDiagonal();
  est.init(x0, p0, k0, pk0);
  return est;
}

/// Builds the estimator of the paper's experiment (its room and laser), initialised at
/// `init` with the non-systematic estimate k0 (e.g. the truth times 0.01 or 100).
template <typename S, template <typename> class DriveT>
typename PaperTypes<S, DriveT>::EstimatorT makePaperEstimator(
    const FilterSetup& setup, const Pose<double>& init,
    const typename DriveT<S>::NonSysVec& k0) {
  using Est = typename PaperTypes<S, DriveT>::EstimatorT;
  typename Est::MapT map;
  const S r = S(setup.room_m);
  const Segment<S> walls[4] = {{S(0), S(0), r, S(0)}, {r, S(0), r, r}, {r, r, S(0), r}, {S(0), r, S(0), S(0)}};
  for (const auto& w : walls) (void)map.add(w);
  typename Est::LaserT laser;
  (void)laser.init(laserConfig<S>(setup));  // the paper's 36 beams always fit
  return makeEstimatorOn<Est, DriveT>(setup, map, laser, init, k0);
}

}  // namespace odoerr::fw
