// odoerr core: the AKF's state transition f_a of one cycle and its Jacobians.
// Part of the AKF (akf.hpp includes it after the class; not to be included on its own).
#pragma once

namespace odoerr {

template <typename ModelT>
inline auto Akf<ModelT>::transition(const Model& model, const StateVec& x, const Input& u,
                                    Eigen::Matrix<S, 3, N>* f_pose,
                                    Eigen::Matrix<S, 3, Model::kNoise>* g_pose) -> Pose<S> {
  S c;
  S sn;
  sinCos(x[PoseIdx::kTheta], &sn, &c);
  Increment<S> inc;
  return transitionCS(model, x, u, typename Model::Context{}, c, sn, f_pose, g_pose, &inc);
}

template <typename ModelT>
inline auto Akf<ModelT>::transitionCS(const Model& model, const StateVec& x, const Input& u,
                                      const typename Model::Context& ctx, S c, S sn, Eigen::Matrix<S, 3, N>* f_pose,
                                      Eigen::Matrix<S, 3, Model::kNoise>* g_pose, Increment<S>* inc_out,
                                      Eigen::Matrix<S, 3, 3>* d_inc_out, Increment<S>* drive_inc) -> Pose<S> {
  Eigen::Matrix<S, 3, N> d_state;
  Eigen::Matrix<S, 3, Model::kNoise> d_noise;
  const typename Model::NoiseVec zero = Model::NoiseVec::Zero();
  const Increment<S> inc = model.increment(u, x, zero, ctx, &d_state, &d_noise, drive_inc);
  IncrementJacobians<S> jp;
  const Pose<S> p{x[PoseIdx::kX], x[PoseIdx::kY], x[PoseIdx::kTheta]};
  // cos/sin of the mid-point heading theta + dtheta/2 by a small rotation.
  S cm = c;
  S sm = sn;
  rotate(&cm, &sm, S(0.5) * inc.theta);
  const Pose<S> next = applyIncrementCS(p, inc, cm, sm, &jp);
  // d_state has zero pose columns: multiply the parameter block only.
  f_pose->template leftCols<3>().setZero();
  f_pose->template rightCols<N - 3>() = jp.d_inc * d_state.template rightCols<N - 3>();
  (*f_pose)(0, PoseIdx::kX) += S(1);
  (*f_pose)(1, PoseIdx::kY) += S(1);
  (*f_pose)(2, PoseIdx::kTheta) += S(1);
  (*f_pose)(0, PoseIdx::kTheta) += jp.dx_dth;
  (*f_pose)(1, PoseIdx::kTheta) += jp.dy_dth;
  *g_pose = jp.d_inc * d_noise;
  *inc_out = inc;
  if (d_inc_out != nullptr) *d_inc_out = jp.d_inc;
  return next;
}

}  // namespace odoerr
