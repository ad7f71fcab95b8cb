// sim_host (private): the joint Fisher information of theta = (K, delta) along a true path,
// with the systematic parameters delta an unknown parameter of the data distribution (not
// a state): the bound of K with delta unknown (docs/nonsystematic.md, "K with the systematic
// parameters unknown"). Driven cycle by cycle from bound_engine.hpp's runBound.
//
// The data model for a given theta, linearised at the true path: the pose-only filter
//   x' = f(x, u, delta) + G(delta) w,  w ~ N(0, Q(K)),   z = h x + v,  v ~ N(0, r),
// from the filter's prior on the pose. delta enters the innovations' mean (the prediction
// f depends on delta: d xhat-/d delta = F_pp xi + F_pd) and their covariance (through G:
// how much encoder noise becomes pose noise; F_pp is held at the true delta). Per scalar beam innovation nu ~ N(mu(theta), s(theta)) given the past:
//   J_ab += 0.5 ds_a ds_b / s^2 + (h E[xi_a xi_b^T] h^T) / s,
// E[xi xi^T] = (mean m m^T, m non-zero for delta only) + (covariance, propagated jointly with
// the estimation error as in runBound). The prior on delta (the filter's P0 block) adds
// P0_dd^-1 to J_dd (the hybrid / Van Trees bound, evaluated at the truth like the rest).
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "odoerr/akf.hpp"

namespace odoerr::sim::bound_detail {

template <typename ModelT>
struct JointRecursion {
  using Drive = typename ModelT::Drive;
  static constexpr int N = ModelT::kStates;
  static constexpr int M = Drive::kNonSys;
  static constexpr int L = Drive::kParams;
  static constexpr int T = M + L;         // theta = (K_1..K_M, delta_1..delta_L)
  static constexpr int NZ = 3 * (1 + T);  // z = (pose error e, xi_1 .. xi_T)
  static constexpr int kD = ModelT::kDriveOffset;
  using Mat3 = Eigen::Matrix3d;
  using Vec3 = Eigen::Vector3d;
  using ThetaMat = Eigen::Matrix<double, T, T>;
  using ZMat = Eigen::Matrix<double, NZ, NZ>;

  Mat3 p;              // pose covariance of the filter at theta
  Mat3 dp[T];          // dP / d theta_a
  Vec3 m[T];           // E[xi_a] (zero for K)
  ZMat c;              // covariance of z (the random parts)
  ThetaMat info_cov = ThetaMat::Zero(), info_mean = ThetaMat::Zero();
  Eigen::Matrix<double, 3, ModelT::kNoise> dg[L];  // the last prediction's d G / d delta_j
  Eigen::Matrix<double, L, L> prior_info;  // P0_dd^-1
  bool prior_ok = false;

  explicit JointRecursion(const typename ModelT::StateMat& p0) {
    p = p0.template topLeftCorner<3, 3>();
    for (auto& d : dp) d.setZero();
    for (auto& v : m) v.setZero();
    c.setZero();
    c.template topLeftCorner<3, 3>() = p;
    const Eigen::Matrix<double, L, L> pdd = p0.template block<L, L>(kD, kD);
    Eigen::LLT<Eigen::Matrix<double, L, L>> llt(pdd);
    prior_ok = llt.info() == Eigen::Success;
    prior_info = prior_ok ? llt.solve(Eigen::Matrix<double, L, L>::Identity()).eval()
                          : Eigen::Matrix<double, L, L>::Zero().eval();
  }

  /// One prediction at the true state xt (the full AKF state: pose, then the true delta).
  /// F_pp, G and d f / d delta (F's delta columns) come from the core's Akf::transition,
  /// d G / d delta by central differences in delta (step 1e-6 max(1, |delta|): G is smooth
  /// in delta; truncation ~1e-12, rounding ~1e-10 relative). F_pp is held at the true delta
  /// (docs/nonsystematic.md: its delta-dependence changes no figure there).
  void predict(const ModelT& model, const typename ModelT::StateVec& xt, const typename Drive::Input& u,
               const typename Drive::NonSysVec& k) {
    using AkfT = Akf<ModelT>;
    Eigen::Matrix<double, 3, N> f;
    Eigen::Matrix<double, 3, ModelT::kNoise> g;
    (void)AkfT::transition(model, xt, u, &f, &g);
    const Mat3 fpp = f.template leftCols<3>();
    for (int j = 0; j < L; ++j) {
      const double h = 1e-6 * std::max(1.0, std::abs(xt[kD + j]));
      typename ModelT::StateVec xp = xt, xm = xt;
      xp[kD + j] += h;
      xm[kD + j] -= h;
      Eigen::Matrix<double, 3, N> fp, fm;
      Eigen::Matrix<double, 3, ModelT::kNoise> gp, gm;
      (void)AkfT::transition(model, xp, u, &fp, &gp);
      (void)AkfT::transition(model, xm, u, &fm, &gm);
      dg[j] = (gp - gm) / (2 * h);
    }
    const auto q = model.drive.noiseVariance(u, k);
    const Mat3 gqg = g * q.asDiagonal() * g.transpose();
    for (int a = 0; a < T; ++a) {
      Mat3 d = fpp * dp[a] * fpp.transpose();
      if (a < M) {
        typename Drive::NonSysVec e = Drive::NonSysVec::Zero();
        e[a] = 1.0;
        d += g * model.drive.noiseVariance(u, e).asDiagonal() * g.transpose();  // Q linear in K
      } else {
        const Mat3 gq = dg[a - M] * q.asDiagonal() * g.transpose();
        d += gq + gq.transpose();
      }
      dp[a] = d;
    }
    p = (fpp * p * fpp.transpose()).eval() + gqg;
    for (int a = 0; a <= T; ++a)
      for (int b = 0; b <= T; ++b)
        c.template block<3, 3>(3 * a, 3 * b) = fpp * c.template block<3, 3>(3 * a, 3 * b) * fpp.transpose();
    c.template topLeftCorner<3, 3>() += gqg;
    for (int a = 0; a < T; ++a) m[a] = fpp * m[a];
    for (int j = 0; j < L; ++j) m[M + j] += f.col(kD + j);  // d f / d delta_j at the true state
  }

  /// One scalar beam with pose row h and range variance r.
  void beam(const Vec3& h, double r) {
    const Vec3 ph = p * h;
    const double s = h.dot(ph) + r;
    const Vec3 kg = ph / s;
    double ds[T];
    Vec3 dk[T];
    double hm[T];
    for (int a = 0; a < T; ++a) {
      const Vec3 dph = dp[a] * h;
      ds[a] = h.dot(dph);
      dk[a] = dph / s - ph * (ds[a] / (s * s));
      hm[a] = h.dot(m[a]);
    }
    for (int a = 0; a < T; ++a) {
      for (int b = 0; b < T; ++b) {
        info_cov(a, b) += 0.5 * ds[a] * ds[b] / (s * s);
        info_mean(a, b) += (h.dot(c.template block<3, 3>(3 * (1 + a), 3 * (1 + b)) * h) + hm[a] * hm[b]) / s;
      }
    }
    const Mat3 am = Mat3::Identity() - kg * h.transpose();
    p -= ph * ph.transpose() / s;
    p = (0.5 * (p + p.transpose())).eval();
    for (int a = 0; a < T; ++a) {
      dp[a] = (am * dp[a] * am.transpose()).eval();
      m[a] = am * m[a];
    }
    // e' = A e - k v; xi_a' = A xi_a + dk_a (h e + v): C' = Abig C Abig^T + r b b^T
    Eigen::Matrix<double, NZ, NZ> abig = Eigen::Matrix<double, NZ, NZ>::Zero();
    for (int a = 0; a <= T; ++a) abig.template block<3, 3>(3 * a, 3 * a) = am;
    for (int a = 0; a < T; ++a) abig.template block<3, 3>(3 * (1 + a), 0) = dk[a] * h.transpose();
    Eigen::Matrix<double, NZ, 1> bv;
    bv.template head<3>() = -kg;
    for (int a = 0; a < T; ++a) bv.template segment<3>(3 * (1 + a)) = dk[a];
    c = (abig * c * abig.transpose()).eval() + r * bv * bv.transpose();
    c = (0.5 * (c + c.transpose())).eval();
  }

  /// The joint information with the prior on delta.
  ThetaMat information() const {
    ThetaMat j = info_cov + info_mean;
    j.template bottomRightCorner<L, L>() += prior_info;
    return j;
  }
};

}  // namespace odoerr::sim::bound_detail
