// A textbook batch EKF cycle for comparison only (bench/, footprint): the same prediction,
// then all valid beams stacked into one H and one innovation vector, S = H P H^T + R,
// K = P H^T S^-1 by one LDLT solve, x += K nu, P -= K H P. Beams are gated at 5 sigma
// on the prior, as in the sequential filter. Dynamic-size Eigen matrices with
// a fixed maximum (36 beams), so that it also runs without a heap on the Cortex-M4F.
#pragma once

#include <Eigen/Cholesky>

#include "odoerr/akf.hpp"

namespace odoerr::fw {

template <typename ModelT, int MaxBeams = 36>
class BatchEkf {
 public:
  using S = typename ModelT::Scalar;
  static constexpr int N = ModelT::kStates;
  using MatB = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic, 0, MaxBeams, MaxBeams>;
  using MatBN = Eigen::Matrix<S, Eigen::Dynamic, N, 0, MaxBeams, N>;
  using VecB = Eigen::Matrix<S, Eigen::Dynamic, 1, 0, MaxBeams, 1>;

  void init(const typename ModelT::StateVec& x, const typename ModelT::StateMat& p) {
    x_ = x;
    p_ = p;
  }

  template <int MaxWalls, int MaxLaserBeams>
  void cycle(const ModelT& model, const typename ModelT::Input& u, const typename ModelT::NonSysVec& k,
             const SegmentMap<S, MaxWalls>& map, const LaserGeometry<S, MaxLaserBeams>& laser,
             const S* ranges, S max_incidence) {
    using AkfT = Akf<ModelT>;
    Eigen::Matrix<S, 3, N> f_pose;
    Eigen::Matrix<S, 3, ModelT::kNoise> g_pose;
    const Pose<S> next = AkfT::transition(model, x_, u, &f_pose, &g_pose);
    Eigen::Matrix<S, N, N> f = Eigen::Matrix<S, N, N>::Identity();
    f.template topRows<3>() = f_pose;
    Eigen::Matrix<S, N, ModelT::kNoise> g = Eigen::Matrix<S, N, ModelT::kNoise>::Zero();
    g.template topRows<3>() = g_pose;
    p_ = f * p_ * f.transpose() + g * model.drive.noiseVariance(u, k).asDiagonal() * g.transpose();
    x_[0] = next.x;
    x_[1] = next.y;
    x_[2] = next.theta;
    const Pose<S> pp{x_[0], x_[1], x_[2]};
    h_.resize(MaxBeams, N);  // within the fixed maximum: no allocation
    nu_.resize(MaxBeams);
    int m = 0;
    for (int i = 0; i < laser.beams() && m < MaxBeams; ++i) {
      if (!isFinite(ranges[i])) continue;
      S r = 0;
      Eigen::Matrix<S, 1, 3> hi;
      if (AkfT::expectedRange(map, laser, pp, i, max_incidence, &r, &hi) != Status::kOk) continue;
      // The same 5-sigma gate as the sequential filter, on the prior innovation variance.
      const S nu = ranges[i] - r;
      const S var_i = hi * p_.template topLeftCorner<3, 3>() * hi.transpose() +
                      laser.config().sigma * laser.config().sigma;
      if (!(nu * nu <= S(25) * var_i)) continue;
      h_.row(m).setZero();
      h_.row(m).template head<3>() = hi;
      nu_[m] = nu;
      ++m;
    }
    if (m == 0) return;
    const auto hm = h_.topRows(m);
    const S var = laser.config().sigma * laser.config().sigma;
    hp_ = hm * p_;
    s_ = hp_ * hm.transpose();
    s_.diagonal().array() += var;
    ldlt_.compute(s_);
    kt_ = ldlt_.solve(hp_);  // K^T = S^-1 H P
    x_ += kt_.transpose() * nu_.head(m);
    p_ -= kt_.transpose() * hp_;
  }

  const typename ModelT::StateVec& state() const { return x_; }

 private:
  typename ModelT::StateVec x_;
  typename ModelT::StateMat p_;
  MatBN h_;
  VecB nu_;
  MatB s_;
  MatBN hp_;
  MatBN kt_;
  Eigen::LDLT<MatB> ldlt_;
};

}  // namespace odoerr::fw
