// odoerr core: a recursive maximum-likelihood estimator of the non-systematic parameters K
// (a candidate beside the paper's Observable Filter; docs/nonsystematic.md "Candidates").
//
// The AKF's innovations give the likelihood of K (prediction-error decomposition): each used
// scalar beam contributes -1/2 (log s + nu^2/s). Its score and Fisher information need the
// filter's sensitivities to K, propagated recursively beside the AKF (the bound's machinery
// at the estimate instead of at the truth):
//   prediction:  dP_i <- F dP_i F^T + G dQ/dK_i G^T,   xi_i <- F xi_i      (xi_i = d xhat / dK_i)
//   beam:        ds_i = h^T dP_i h,  a_i = h^T xi_i,   k = P h / s,  dk_i = (dP_i h - k ds_i) / s
//                score_i += -1/2 ds_i/s (1 - nu^2/s) + nu a_i / s
//                info_ij += 1/2 ds_i ds_j / s^2 + a_i a_j / s
//                xi_i <- xi_i - k a_i + dk_i nu,   dP_i <- (I - k h^T) dP_i (I - k h^T)^T
// The beams of a scan compose into one batch update, so scan() takes a whole fused scan from
// the AKF's P and x before and after it (no rows, O(Hc^3) a scan); the default form carries
// the sensitivities of the pose only (KMlConfig::Form), which is what fits the firmware's cycle.
// Every `every` cycles a Gauss-Newton (natural-gradient) step in theta = log K:
//   J <- lambda J + diag(K) I_block diag(K),   theta += clamp(J^-1 diag(K) g_block)
// with lambda rising to 1 (Ljung's forgetting schedule), so the recursion tends to the
// maximum of the whole record's likelihood. Two additions make it converge from far below
// (docs/nonsystematic.md "Candidates"): J and the sensitivities restart when log K has moved
// by more than reset_log since their last restart (stale information), and while K is
// uncertain the AKF runs with an inflated K_f = K exp(inflate sigma_logK - offset) (capped),
// so that it never over-trusts the odometry while K is too small; the step for K then
// carries the score from K_f down to K (the smaller of the Gauss-Newton line, information
// times (log K_f - log K), and a variance-scale model: KMlConfig::scale_shift).
// Fixed-size, allocation-free, Eigen only.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>

#include <Eigen/Cholesky>

#include "odoerr/akf.hpp"
#include "odoerr/k_ml_config.hpp"

namespace odoerr {

template <typename ModelT>
class KMaxLikelihood {
 public:
  using Model = ModelT;
  using S = typename Model::Scalar;
  using Drive = typename Model::Drive;
  using Input = typename Model::Input;
  static constexpr int N = Model::kStates;
  static constexpr int M = Drive::kNonSys;
  using KVec = Eigen::Matrix<S, M, 1>;
  using KMat = Eigen::Matrix<S, M, M>;
  using StateVec = Eigen::Matrix<S, N, 1>;
  using StateMat = Eigen::Matrix<S, N, N>;

  KMaxLikelihood() = default;
  explicit KMaxLikelihood(const KMlConfig<S>& cfg) : cfg_(cfg) {
    if (cfg_.every < 1) cfg_.every = 1;
  }

  void init(const KVec& k0) {
    k_ = k0;
    kf_ = k0;
    for (int i = 0; i < M; ++i) {
      dp_[i].setZero();
      xi_[i].setZero();
    }
    g_.setZero();
    h_.setZero();
    info_.setZero();
    j_.setZero();
    k_ref_ = k0;
    lambda_ = cfg_.lambda0;
    cycles_ = 0;
    taken_ = 0;
    updateFilterK();
    overstated_ = S(1);
    kf_min_ = kf_;
  }

  const KVec& estimate() const { return k_; }
  /// The K the AKF should predict with (K itself unless inflate > 0); the sensitivities and
  /// the score are with respect to it. Updated at each step.
  const KVec& filterK() const { return kf_; }
  /// The factor by which the AKF's knowledge of the systematic parameters was overstated, as
  /// seen at the last step: the largest K / (the smallest K_f the AKF has predicted with
  /// since the last such discount) over the components when above
  /// KMlConfig::discount_above, else 1 (MlDriver discounts the AKF's parameters by it).
  S overstatement() const { return overstated_; }
  /// Covariance of K from the accumulated information (J^-1 in log K, mapped to K).
  KMat covariance() const {
    KMat c = KMat::Zero();
    Eigen::LLT<KMat> llt(j_);
    if (llt.info() != Eigen::Success) {
      for (int i = 0; i < M; ++i) c(i, i) = k_[i] * k_[i];  // no information: 100 %
      return c;
    }
    const KMat ci = inverseOf(llt);
    return k_.asDiagonal() * ci * k_.asDiagonal();
  }
  /// covariance() with the systematic parameters' uncertainty carried over where Q depends
  /// on them. On the differential drive the heading noise is K_w (|dR| + |dL|) / (d delta_d)^2,
  /// so the innovations fix K_w / delta_d^2, and J (at the estimated delta_d) misses the
  /// share of delta_d: var(log K_w) gains 4 P_dd / delta_d^2 (x, p: the AKF's state and
  /// covariance). The synchronous drive's Q does not depend on its parameters: covariance().
  KMat covarianceWithSystematic(const StateVec& x, const StateMat& p) const {
    KMat c = covariance();
    if constexpr (std::is_same_v<Drive, DiffDrive<S>>) {
      c(Drive::kKw, Drive::kKw) += k_[Drive::kKw] * k_[Drive::kKw] * deltaDVarLogKw(x, p);
    }
    return c;
  }
  const KMlCounters& counters() const { return counters_; }
  const KMlConfig<S>& config() const { return cfg_; }
  const KVec& blockScore() const { return g_; }
  const KMat& blockInformation() const { return info_; }

  /// Before the AKF's prediction, with its Jacobians (Akf::predict's observer hands them
  /// out; Akf::transition computes them): dP_i <- F dP_i F^T + G dQ/dK_i G^T, xi_i <- F xi_i, with F = [f_pose; 0 I] and
  /// G = [g_pose; 0], so only the pose rows and columns change. Ns: the states whose
  /// sensitivities are carried (the first Ns; the others stay zero): N, or the measured
  /// states (KMlForm::kPose).
  template <int Ns = N>
  ODOERR_NOINLINE void predict(const Model& model, const Input& u, const Eigen::Matrix<S, 3, N>& f_pose,
                               const Eigen::Matrix<S, 3, Model::kNoise>& g_pose) {
    static_assert(Ns >= 3 && Ns <= N, "the sensitivities start with the pose");
    for (int i = 0; i < M; ++i) {
      KVec e = KVec::Zero();
      e[i] = S(1);
      const auto dq = model.drive.noiseVariance(u, e);  // Q is linear in K
      StateMat& dp = dp_[i];
      // F_pose's pose columns are I plus the heading column (a, b, 0) (Akf::transitionCS
      // builds them so): fp = F_pose dP (3 x Ns) takes the rows of dP with a and b and the
      // parameter columns; then the pose rows and columns, then the pose block
      // fp F_pose^T + G dQ G^T (symmetric: the upper triangle, mirrored).
      const S fa = f_pose(0, 2);
      const S fb = f_pose(1, 2);
      S fp[3][Ns];
#pragma GCC unroll 16
      for (int k = 0; k < Ns; ++k) {
        S r0 = dp(0, k) + fa * dp(2, k);
        S r1 = dp(1, k) + fb * dp(2, k);
        S r2 = dp(2, k);
#pragma GCC unroll 16
        for (int l = 3; l < Ns; ++l) {
          r0 += f_pose(0, l) * dp(l, k);
          r1 += f_pose(1, l) * dp(l, k);
          r2 += f_pose(2, l) * dp(l, k);
        }
        fp[0][k] = r0;
        fp[1][k] = r1;
        fp[2][k] = r2;
      }
#pragma GCC unroll 16
      for (int r = 0; r < 3; ++r) {
#pragma GCC unroll 16
        for (int k = 3; k < Ns; ++k) {
          dp(r, k) = fp[r][k];
          dp(k, r) = fp[r][k];
        }
      }
#pragma GCC unroll 16
      for (int r = 0; r < 3; ++r) {
#pragma GCC unroll 16
        for (int k = r; k < 3; ++k) {
          // (fp F_pose^T)(r, k) = fp[r][k] + F_pose(k, 2) fp[r][2] (k < 2) + parameter columns
          S acc = fp[r][k];
          if (k == 0) acc += fa * fp[r][2];
          if (k == 1) acc += fb * fp[r][2];
#pragma GCC unroll 16
          for (int l = 3; l < Ns; ++l) acc += fp[r][l] * f_pose(k, l);
#pragma GCC unroll 16
          for (int l = 0; l < Model::kNoise; ++l) acc += g_pose(r, l) * dq[l] * g_pose(k, l);
          dp(r, k) = acc;
          dp(k, r) = acc;
        }
      }
      const S* xv = xi_[i].data();
      S xp[3] = {xv[0] + fa * xv[2], xv[1] + fb * xv[2], xv[2]};
#pragma GCC unroll 16
      for (int r = 0; r < 3; ++r) {
#pragma GCC unroll 16
        for (int l = 3; l < Ns; ++l) xp[r] += f_pose(r, l) * xv[l];
      }
      for (int r = 0; r < 3; ++r) xi_[i][r] = xp[r];
    }
  }

  /// One fused beam: h its measurement row, p_prior the AKF's covariance before it, nu the
  /// innovation, s its variance.
  void beam(const StateVec& h, const StateMat& p_prior, S nu, S s) {
    const StateVec ph = p_prior * h;
    const StateVec k = ph / s;
    S ds[M];
    S a[M];
    StateVec dph[M];
    for (int i = 0; i < M; ++i) {
      dph[i] = dp_[i] * h;
      ds[i] = h.dot(dph[i]);
      a[i] = h.dot(xi_[i]);
    }
    const S nis = nu * nu / s;
    for (int i = 0; i < M; ++i) {
      g_[i] += S(-0.5) * ds[i] / s * (S(1) - nis) + nu * a[i] / s;
      h_[i] += S(0.5) * ds[i] / s;
      for (int j = 0; j < M; ++j) info_(i, j) += S(0.5) * ds[i] * ds[j] / (s * s) + a[i] * a[j] / s;
    }
    for (int i = 0; i < M; ++i) {
      const StateVec dk = (dph[i] - k * ds[i]) / s;
      xi_[i] += -k * a[i] + dk * nu;
      // (I - k h^T) dP (I - k h^T)^T = dP - k dph^T - dph k^T + k ds k^T
      dp_[i] += -k * dph[i].transpose() - dph[i] * k.transpose() + ds[i] * (k * k.transpose());
    }
    ++counters_.beams;
    ++taken_;
  }

  /// One fused scan as a whole: the equivalent (to the linearisation) of beam() over its fused
  /// beams, from what the AKF holds before and after the scan, without the beams' rows and
  /// at a cost that does not grow with their number. With the scan's stacked rows H (non-zero
  /// in the first Hc states only: the pose, Akf::kHCols), its innovation nu and variance S,
  /// C = H^T S^-1 H and v = H^T S^-1 nu are zero outside those states, and there
  ///   C_hh = P_hh^-1 (P_prior - P_post)_hh P_hh^-1,   v_h = P_hh^-1 (x_post - x_prior)_h
  /// (P_post = P - P C P and x_post - x_prior = P v), with P = P_prior. Then, U = P_:h C_hh,
  /// the scan's I - K_b H = I - U E_h^T (E_h^T takes the first Hc rows), and
  ///   score_i += -1/2 tr(C_hh dP_i,hh) + 1/2 v_h^T dP_i,hh v_h + v_h^T xi_i,h
  ///   info_ij += 1/2 tr(C_hh dP_i,hh C_hh dP_j,hh) + xi_i,h^T C_hh xi_j,h
  ///   xi_i <- w - U w_h with w = xi_i + dP_i,:h v_h,   dP_i <- dP_i - U R^T - R U^T
  ///   with R = dP_i,:h - 1/2 U dP_i,hh
  /// (the batch form of the innovation likelihood's derivatives: the sequential scalar
  /// updates compose to the batch one). P_hh is inverted by cofactors (the pose, Hc = 3) or in
  /// correlation form (scaled by its diagonal; a state without variance is left out; Hc > 3).
  /// When it is not positive definite the
  /// scan is skipped and the sensitivities restart (counted: scans_skipped); returns false.
  /// Ns (Hc..N): the states whose sensitivities are carried, as in predict<Ns>: with Ns = Hc
  /// (KMlForm::kPose) the updates of dP and xi take their measured block only.
  /// It reads P_prior's first Hc columns and x_prior's first Hc entries only, so the caller
  /// keeps just those (`p_prior`, `x_prior` here).
  template <int Hc = N, int Ns = N>
  ODOERR_NOINLINE bool scan(const Eigen::Matrix<S, N, Hc>& p_prior, const Eigen::Matrix<S, Hc, 1>& x_prior,
                            const StateMat& p_post, const StateVec& x_post) {
    static_assert(Hc >= 3 && Hc <= N, "the measured states start with the pose");
    static_assert(Ns >= Hc && Ns <= N, "the sensitivities cover the measured states");
    using HMat = Eigen::Matrix<S, Hc, Hc>;
    using HVec = Eigen::Matrix<S, Hc, 1>;
    using NxH = Eigen::Matrix<S, Ns, Hc>;
    // B = P_hh^-1. The loops below are written out on fixed sizes: the same arithmetic
    // through Eigen's expressions cost about twice as much on the M4F (measured,
    // docs/nonsystematic.md).
    HMat b;
    bool ok = false;
    if constexpr (Hc == 3) {
      // The pose block (m^2 and rad^2, of like size): positive definite iff its leading
      // minors are (Sylvester), which also refuses a NaN; then the inverse by cofactors.
      // Written out: Eigen's LU module, included here, changed how GCC laid out the paper's
      // cycle in the firmware (+540 instructions, measured).
      const auto& pt = p_prior;
      const S c00 = pt(1, 1) * pt(2, 2) - pt(1, 2) * pt(1, 2);
      const S c01 = pt(0, 2) * pt(1, 2) - pt(0, 1) * pt(2, 2);
      const S c02 = pt(0, 1) * pt(1, 2) - pt(0, 2) * pt(1, 1);
      const S det = pt(0, 0) * c00 + pt(0, 1) * c01 + pt(0, 2) * c02;
      const S m2 = pt(0, 0) * pt(1, 1) - pt(0, 1) * pt(0, 1);
      ok = pt(0, 0) > S(0) && m2 > S(0) && det > S(0);
      if (ok) {
        const S inv = S(1) / det;
        b(0, 0) = c00 * inv;
        b(0, 1) = b(1, 0) = c01 * inv;
        b(0, 2) = b(2, 0) = c02 * inv;
        b(1, 1) = (pt(0, 0) * pt(2, 2) - pt(0, 2) * pt(0, 2)) * inv;
        b(1, 2) = b(2, 1) = (pt(0, 1) * pt(0, 2) - pt(0, 0) * pt(1, 2)) * inv;
        b(2, 2) = m2 * inv;
      }
    } else {
      // Every state: in correlation form (scaled by the diagonal; a state without variance,
      // held, is left out), because the parameters' variances span many decades.
      S d[Hc];
      HMat pt;
      for (int j = 0; j < Hc; ++j) d[j] = p_prior(j, j) > S(0) ? S(1) / std::sqrt(p_prior(j, j)) : S(0);
      for (int j = 0; j < Hc; ++j) {
        for (int k = 0; k < Hc; ++k) pt(j, k) = d[j] * p_prior(j, k) * d[k];
        if (d[j] == S(0)) pt(j, j) = S(1);
      }
      Eigen::LLT<HMat> llt(pt);
      ok = llt.info() == Eigen::Success;
      if (ok) {
        for (int j = 0; j < Hc; ++j) b.col(j) = llt.solve(HVec::Unit(j));
        for (int j = 0; j < Hc; ++j) {
          for (int k = 0; k < Hc; ++k) b(j, k) *= d[j] * d[k];
        }
        ok = b.allFinite();
      }
    }
    if (!ok) {
      ++counters_.scans_skipped;
      for (int i = 0; i < M; ++i) {
        dp_[i].setZero();
        xi_[i].setZero();
      }
      return false;
    }
    // C = B (P_prior - P_post)_hh B (symmetric: the upper triangle, mirrored), v = B dx.
    HMat bd;  // B (P_prior - P_post)_hh
#pragma GCC unroll 16
    for (int j = 0; j < Hc; ++j) {
#pragma GCC unroll 16
      for (int k = 0; k < Hc; ++k) {
        S acc = S(0);
#pragma GCC unroll 16
        for (int l = 0; l < Hc; ++l) acc += b(j, l) * (p_prior(l, k) - p_post(l, k));
        bd(j, k) = acc;
      }
    }
    HMat c;
#pragma GCC unroll 16
    for (int j = 0; j < Hc; ++j) {
#pragma GCC unroll 16
      for (int k = j; k < Hc; ++k) {
        S acc = S(0);
#pragma GCC unroll 16
        for (int l = 0; l < Hc; ++l) acc += bd(j, l) * b(l, k);
        c(j, k) = acc;
        c(k, j) = acc;
      }
    }
    S dx[Hc];
#pragma GCC unroll 16
    for (int j = 0; j < Hc; ++j) dx[j] = x_post[j] - x_prior[j];
    dx[PoseIdx::kTheta] = wrapAngle(dx[PoseIdx::kTheta]);
    HVec v;
#pragma GCC unroll 16
    for (int j = 0; j < Hc; ++j) {
      S acc = S(0);
#pragma GCC unroll 16
      for (int l = 0; l < Hc; ++l) acc += b(j, l) * dx[l];
      v[j] = acc;
    }
    // U = P_:h C (the rows of the carried states). With the measured states' only
    // (Ns = Hc), U = P_hh B (P_prior - P_post)_hh B = (P_prior - P_post)_hh B = (B (...))^T.
    NxH u;
    if constexpr (Ns == Hc) {
      u = bd.transpose();
    } else {
#pragma GCC unroll 16
      for (int j = 0; j < Ns; ++j) {
#pragma GCC unroll 16
        for (int k = 0; k < Hc; ++k) {
          S acc = S(0);
#pragma GCC unroll 16
          for (int l = 0; l < Hc; ++l) acc += p_prior(j, l) * c(l, k);
          u(j, k) = acc;
        }
      }
    }
    HMat e[M];   // C dP_i,hh
    HVec cx[M];  // C xi_i,h
    for (int i = 0; i < M; ++i) {
      const StateMat& dp = dp_[i];
      S tr = S(0);
      S vdv = S(0);
      S vx = S(0);
#pragma GCC unroll 16
      for (int j = 0; j < Hc; ++j) {
        S acc_x = S(0);
        S acc_v = S(0);
#pragma GCC unroll 16
        for (int k = 0; k < Hc; ++k) {
          S acc = S(0);
#pragma GCC unroll 16
          for (int l = 0; l < Hc; ++l) acc += c(j, l) * dp(l, k);
          e[i](j, k) = acc;
          acc_x += c(j, k) * xi_[i][k];
          acc_v += dp(j, k) * v[k];
        }
        cx[i][j] = acc_x;
        tr += e[i](j, j);
        vdv += v[j] * acc_v;
        vx += v[j] * xi_[i][j];
      }
      g_[i] += S(-0.5) * tr + S(0.5) * vdv + vx;
      h_[i] += S(0.5) * tr;
      for (int m = 0; m <= i; ++m) {
        // 1/2 tr(E_i E_m) + xi_i,h^T C xi_m,h; tr(E_i E_m) = sum_jk E_i(j, k) E_m(k, j)
        S t = S(0);
        S xx = S(0);
#pragma GCC unroll 16
        for (int j = 0; j < Hc; ++j) {
#pragma GCC unroll 16
          for (int k = 0; k < Hc; ++k) t += e[i](j, k) * e[m](k, j);
          xx += cx[i][j] * xi_[m][j];
        }
        const S add = S(0.5) * t + xx;
        info_(i, m) += add;
        if (m != i) info_(m, i) += add;
      }
    }
    for (int i = 0; i < M; ++i) {
      // With Z = dP_:h: (I - U E_h^T) dP (I - U E_h^T)^T = dP - U Z^T - Z U^T + U dP_hh U^T
      //                                                = dP - U R^T - R U^T, R = Z - 1/2 U dP_hh
      // (a symmetric update: the upper triangle, mirrored). xi <- w - U w_h, w = xi + Z v.
      StateMat& dp = dp_[i];
      NxH r;
      S w[Ns];
#pragma GCC unroll 16
      for (int j = 0; j < Ns; ++j) {
        S acc_w = xi_[i][j];
#pragma GCC unroll 16
        for (int k = 0; k < Hc; ++k) {
          S acc = S(0);
#pragma GCC unroll 16
          for (int l = 0; l < Hc; ++l) acc += u(j, l) * dp(l, k);
          r(j, k) = dp(j, k) - S(0.5) * acc;
          acc_w += dp(j, k) * v[k];
        }
        w[j] = acc_w;
      }
#pragma GCC unroll 16
      for (int j = 0; j < Ns; ++j) {
        S acc = w[j];
#pragma GCC unroll 16
        for (int k = 0; k < Hc; ++k) acc -= u(j, k) * w[k];
        xi_[i][j] = acc;
      }
#pragma GCC unroll 16
      for (int row = 0; row < Ns; ++row) {
#pragma GCC unroll 16
        for (int col = row; col < Ns; ++col) {
          S acc = dp(row, col);
#pragma GCC unroll 16
          for (int k = 0; k < Hc; ++k) acc -= u(row, k) * r(col, k) + r(row, k) * u(col, k);
          dp(row, col) = acc;
          dp(col, row) = acc;
        }
      }
    }
    ++counters_.scans;
    ++taken_;
    return true;
  }

  /// At the end of a cycle: a K step every `every` cycles. Returns true when K moved.
  bool endCycle(const StateVec& x, const StateMat& p) {
    if (++cycles_ < cfg_.every) return false;
    cycles_ = 0;
    return step(x, p);
  }

 private:
  /// The K step of endCycle (out of line: it runs one cycle in `every`).
  ODOERR_NOINLINE bool step(const StateVec& x, const StateMat& p) {
    // Nothing fused since the last step (a blind stretch: no beam the map explains): no
    // step, and no forgetting either. Forgetting J per step rather than per information
    // would let sigma, and with it the inflated K the AKF predicts with, grow for as long
    // as the robot sees nothing (measured, sync circle from above, seed 76, with the near
    // limit at 3 sigma: K_f from 338x to 428x the truth in 0.2 m without a beam fused).
    if (taken_ == 0) {
      ++counters_.idle;
      return false;
    }
    taken_ = 0;
    if (cfg_.deflate) deflateBySystematic(x, p);
    const KMat dk = kf_.asDiagonal();
    const KMat info_t = dk * info_ * dk;
    KVec g_t = dk * g_;
    if (cfg_.inflate > S(0)) shiftScore(info_t, &g_t);
    j_ = lambda_ * j_ + info_t;
    lambda_ = cfg_.lambda_rate * lambda_ + (S(1) - cfg_.lambda_rate);
    g_.setZero();
    h_.setZero();
    info_.setZero();
    Eigen::LLT<KMat> llt(j_);
    if (llt.info() != Eigen::Success || !g_t.allFinite()) {
      ++counters_.skipped;
      return false;
    }
    KVec step = llt.solve(g_t);
    if (!step.allFinite()) {
      ++counters_.skipped;
      return false;
    }
    const S big = step.cwiseAbs().maxCoeff();
    if (big > cfg_.max_log_step) {
      step *= cfg_.max_log_step / big;
      ++counters_.clipped;
    }
    for (int i = 0; i < M; ++i) k_[i] *= std::exp(step[i]);
    ++counters_.steps;
    if (cfg_.reset_log > S(0)) {
      S moved = S(0);
      for (int i = 0; i < M; ++i) moved = std::max(moved, std::abs(std::log(k_[i] / k_ref_[i])));
      if (moved > cfg_.reset_log) {
        j_ *= cfg_.reset_keep;
        lambda_ = cfg_.lambda0;
        k_ref_ = k_;
        for (int i = 0; i < M; ++i) {
          dp_[i].setZero();
          xi_[i].setZero();
        }
        ++counters_.resets;
      }
    }
    updateFilterK();
    // The estimate against the smallest K the AKF has predicted with since the last
    // discount: what the AKF learnt then was overstated by about that factor. Only a clear
    // rise counts, so that the steps' wander about the truth does not add up to forgetting.
    S g = S(1);
    for (int i = 0; i < M; ++i) g = std::max(g, k_[i] / kf_min_[i]);
    overstated_ = cfg_.discount && g > cfg_.discount_above ? g : S(1);
    for (int i = 0; i < M; ++i) kf_min_[i] = overstated_ > S(1) ? kf_[i] : std::min(kf_min_[i], kf_[i]);
    return true;
  }

  /// The score at K_f carried to K (g_t: at K_f on entry, in log K), KMlConfig::scale_shift:
  /// the smaller of the Gauss-Newton line and scaleShiftedScore with abar = I_ii / h_i. The
  /// two agree near K_f; where the data are saturated (g = -h: no innovation left) the line
  /// pushes K up by I D while the model stays at -h, and where little of s comes from K the
  /// model's curvature overstates the rise (measured: K_rho 1.02x at 30 m with it alone).
  void shiftScore(const KMat& info_t, KVec* g_t) const {
    KVec dtheta;
    for (int i = 0; i < M; ++i) dtheta[i] = std::log(kf_[i] / k_[i]);
    const KVec line = *g_t + info_t * dtheta;
    if (!cfg_.scale_shift) {
      *g_t = line;
      return;
    }
    for (int i = 0; i < M; ++i) {
      const S h = kf_[i] * h_[i];
      S g = line[i];
      if (h > S(0) && dtheta[i] > S(0)) {
        g = std::min(g, scaleShiftedScore((*g_t)[i], h, std::min(info_t(i, i) / h, S(1)), dtheta[i]));
      }
      (*g_t)[i] = g;
    }
  }

  /// The variance delta_d's uncertainty adds to log K_w (differential drive): the heading
  /// noise fixes K_w / delta_d^2, so var(log K_w) gains var(log delta_d^2) = 4 P_dd / delta_d^2
  /// (x, p: the AKF's state and covariance; 0 where delta_d or P_dd is not usable).
  static S deltaDVarLogKw(const StateVec& x, const StateMat& p) {
    constexpr int kD = Model::kDriveOffset + Drive::kDeltaD;
    const S dd = x[kD];
    if (!(dd > S(0)) || !(p(kD, kD) >= S(0))) return S(0);
    return S(4) * p(kD, kD) / (dd * dd);
  }

  /// KMlConfig::deflate: on the differential drive, this step's score and information on
  /// K_w scaled by 1 / (1 + I v), v = deltaDVarLogKw; nothing on the synchronous drive, whose
  /// Q does not depend on its parameters.
  void deflateBySystematic(const StateVec& x, const StateMat& p) {
    if constexpr (std::is_same_v<Drive, DiffDrive<S>>) {
      const S kw = kf_[Drive::kKw];
      const S f = S(1) / (S(1) + kw * kw * info_(Drive::kKw, Drive::kKw) * deltaDVarLogKw(x, p));
      info_ *= f;
      g_ *= f;
      h_ *= f;
    } else {
      (void)x;
      (void)p;
    }
  }

  /// J^-1 from its factor (info() checked by the caller), one column at a time: a solve with
  /// a matrix right-hand side goes through Eigen's blocked triangular solve, which refers
  /// to malloc, and the firmware's link refuses that (heap trap).
  static KMat inverseOf(const Eigen::LLT<KMat>& llt) {
    KMat ci;
    for (int i = 0; i < M; ++i) ci.col(i) = llt.solve(KVec::Unit(i));
    return ci;
  }

  void updateFilterK() {
    kf_ = k_;
    if (!(cfg_.inflate > S(0))) return;
    Eigen::LLT<KMat> llt(j_);
    const bool ok = llt.info() == Eigen::Success;
    const KMat ci = ok ? inverseOf(llt) : KMat::Zero();
    for (int i = 0; i < M; ++i) {
      const S sig = ok && ci(i, i) > S(0) ? std::sqrt(ci(i, i)) : cfg_.max_inflate_log;
      const S up = std::min(cfg_.inflate * sig - cfg_.inflate_offset, cfg_.max_inflate_log);
      kf_[i] = up > S(0) ? k_[i] * std::exp(up) : k_[i];
    }
  }

  KMlConfig<S> cfg_{};
  KVec k_ = KVec::Ones();
  KVec kf_ = KVec::Ones();
  KVec k_ref_ = KVec::Ones();  ///< K when J was last restarted
  StateMat dp_[M];
  StateVec xi_[M];
  KVec g_ = KVec::Zero();
  KMat info_ = KMat::Zero();
  KMat j_ = KMat::Zero();
  S lambda_ = S(0.9);
  int cycles_ = 0;
  int taken_ = 0;  ///< scans (or beams) taken since the last step
  S overstated_ = S(1);
  KVec kf_min_ = KVec::Ones();  ///< the smallest K_f since the last discount
  KVec h_ = KVec::Zero();  ///< 1/2 tr(C dP_i): what the score of K_i would be with no innovation
  KMlCounters counters_{};
};

}  // namespace odoerr
