// odoerr core: the ML estimator of K taking one fused scan whole (KMaxLikelihood::scan).
// Part of k_ml.hpp (included after the class; not to be included on its own).
#pragma once

namespace odoerr {

template <typename ModelT>
template <int Hc, int Ns>
bool KMaxLikelihood<ModelT>::scan(const Eigen::Matrix<S, N, Hc>& p_prior,
                                  const Eigen::Matrix<S, Hc, 1>& x_prior, const StateMat& p_post,
                                  const StateVec& x_post) {
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
    for (int i = 0; i < P; ++i) {
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
  const int np = active();
  HMat e[P];   // C dP_i,hh
  HVec cx[P];  // C xi_i,h
  for (int i = 0; i < np; ++i) {
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
  for (int i = 0; i < np; ++i) {
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

}  // namespace odoerr
