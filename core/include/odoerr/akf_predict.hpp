// odoerr core: the AKF's prediction: the state through one cycle's encoder increments, and P
// through F P F^T + G Q G^T (only the pose rows and columns change).
// Part of the AKF (akf.hpp includes it after the class; not to be included on its own).
#pragma once

namespace odoerr {

template <typename ModelT>
template <typename PredictObserver>
inline Status Akf<ModelT>::predict(const Input& u, const NonSysVec& k, S dt, PredictObserver&& observe) {
  if (!Model::Drive::inputFinite(u) || !k.allFinite()) {
    ++counters_.bad_inputs;
    return Status::kBadInput;
  }
  Eigen::Matrix<S, 3, N> f_pose;
  Eigen::Matrix<S, 3, Model::kNoise> g_pose;
  S c;
  S sn;
  headingCosSin(&c, &sn);
  if constexpr (Model::kHasEffects) {
    ctx_.dt = dt;
    ctx_.x = x_[PoseIdx::kX];
    ctx_.y = x_[PoseIdx::kY];
    if constexpr (Model::kUsesHeading) {
      ctx_.heading = x_[PoseIdx::kTheta];
      ctx_.cos_heading = c;
      ctx_.sin_heading = sn;
    }
  } else {
    (void)dt;
  }
  Increment<S> inc;
  Eigen::Matrix<S, 3, 3> d_inc;
  Increment<S> drive_inc;  // the drive model's increment before the effects (the travel totals)
  const Pose<S> next = transitionCS(model_, x_, u, ctx_, c, sn, &f_pose, &g_pose, &inc,
                                      Model::kHasNoiseEffects ? &d_inc : nullptr,
                                      Model::kHasEffects ? &drive_inc : nullptr);
  observe(f_pose, g_pose);
  const typename Model::NoiseVec q = model_.drive.noiseVariance(u, k);

  // P' = F P F^T + G Q G^T, with F = [f_pose; 0 I] and G = [g_pose; 0].
  // Rows/cols of the parameter block are unchanged except through f_pose.
  // 3 x N. Lazy (coefficient-wise) products here and below: Eigen's default switches to
  // its blocked GEMM once rows + cols + depth >= 20, whose workspace may come from the
  // heap (a float model with N >= 9 then failed the firmware's link-time heap trap); for
  // smaller N Eigen already chose the lazy product.
  if constexpr (kSparse) {
    if (!predictCovarianceSparse(f_pose, g_pose, q, inc, d_inc)) {
      ++counters_.bad_predictions;
      return Status::kBadCovariance;
    }
  } else {
    // The new P's pose rows, built beside P and written into it once checked: the
    // parameter block does not change, so P is not copied (two copies of the whole P
    // cost more than the rest of the prediction's covariance on the M4F).
    Eigen::Matrix<S, 3, N> fp = f_pose.lazyProduct(p_);
    // The pose block F P F^T + G Q G^T, its upper triangle written out and mirrored: as an
    // Eigen expression GCC called it out of line in the ML image, at 318 instructions a
    // cycle (measured).
    Eigen::Matrix<S, 3, 3> pose;
#pragma GCC unroll 3
    for (int r = 0; r < 3; ++r) {
#pragma GCC unroll 3
      for (int cl = r; cl < 3; ++cl) {
        S acc = S(0);
#pragma GCC unroll 16
        for (int j = 0; j < N; ++j) acc += fp(r, j) * f_pose(cl, j);
#pragma GCC unroll 4
        for (int n = 0; n < Model::kNoise; ++n) acc += g_pose(r, n) * q[n] * g_pose(cl, n);
        pose(r, cl) = acc;
        pose(cl, r) = acc;
      }
    }
    if constexpr (Model::kHasNoiseEffects) {
      pose += d_inc * model_.extraVariance(inc, x_, ctx_).asDiagonal() * d_inc.transpose();
    }
    // Only the new pose block can be asymmetric by rounding; the rest is copied symmetric.
    symmetrisePose(pose);
    fp.template leftCols<3>() = pose;
    if (!poseRowsHealthy(fp)) {
      ++counters_.bad_predictions;
      return Status::kBadCovariance;
    }
    p_.template topRows<3>() = fp;
    p_.template leftCols<3>() = fp.transpose();
  }
  x_[PoseIdx::kX] = next.x;
  x_[PoseIdx::kY] = next.y;
  x_[PoseIdx::kTheta] = next.theta;
  if constexpr (Model::kHasEffects) {
    // the travel totals count the drive model's increment, before the effects (a
    // backlash span counted in scaled travel lasted 25 % longer than its 5 cm)
    model_.advanceContext(ctx_, drive_inc, Model::Drive::encoderTravel(u));
    if (dt > S(0)) {  // a cycle of unknown duration keeps the last velocity
      const S inv_dt = S(1) / dt;
      vel_x_ = (next.x - ctx_.x) * inv_dt;
      vel_y_ = (next.y - ctx_.y) * inv_dt;
      vel_w_ = inc.theta * inv_dt;
    }
  }
  rotate(&c, &sn, inc.theta);
  storeHeadingCosSin(c, sn);
  ++counters_.predictions;
  return Status::kOk;
}

}  // namespace odoerr
