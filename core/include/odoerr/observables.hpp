// odoerr core: moments of the observables of Section 4 (derivations: docs/paper-notes.md).
//
// Synchronous drive, observable (8): w = (D_x, D_y, e) with D = dP - dP^e (the position
// displacement between two AKF poses minus the corrected odometry displacement) and
// e = dtheta - dtheta^e; z = (|D|^2, e^2).
// Differential drive, observable of 4.2: z = e^2.
#pragma once

#include <Eigen/Core>

#include "odoerr/motion.hpp"
#include "odoerr/observable_math.hpp"

namespace odoerr {

/// The segment between two AKF poses, as the corrected odometry saw it.
template <typename S>
struct SyncSegment {
  S length = S(0);     ///< L = sum |drho_e| (encoder path length, m)
  S rotation = S(0);   ///< b = sum (dtheta_e + E_theta drho_e) (corrected rotation, rad)
  S delta_rho = S(1);  ///< translation scale used for dP^e
};

/// Exact mean of z1 = |D|^2 under the continuous model on an arc (the trajectory between
/// the poses approximated by an arc, as the paper does), with its K_theta derivative:
///   E z1 = K_rho L + (delta_rho L)^2 B(K_theta L / 2, b).
template <typename S>
struct SyncMean {
  S z1, z2;
  S dz1_dkrho, dz1_dktheta, dz2_dktheta;
};

template <typename S>
SyncMean<S> syncObservableMean(const SyncSegment<S>& seg, S k_rho, S k_theta) {
  const S l = seg.length;
  const Bracket<S> br = observableBracket(S(0.5) * k_theta * l, seg.rotation);
  const S a2 = sq(seg.delta_rho * l);
  SyncMean<S> m;
  m.z1 = k_rho * l + a2 * br.value;
  m.z2 = k_theta * l;
  m.dz1_dkrho = l;
  m.dz1_dktheta = a2 * br.d_dk * S(0.5) * l;
  m.dz2_dktheta = l;
  return m;
}

/// Eq. (9) exactly as printed (kept only so the tests can show what goes wrong with it):
/// raw encoder rotation in the cosine term, corrected rotation in F(z).
template <typename S>
S syncObservableMeanPaperEq9(S length, S raw_rotation, S e_theta, S delta_rho, S k_rho, S k_theta) {
  const std::complex<S> z(S(0.5) * k_theta * length, raw_rotation + e_theta * length);
  const S f = paperF(z).real();
  return k_rho * length + S(2) * sq(delta_rho * length) * (f - cosTerm(raw_rotation));
}

/// Second moments of w = (D_x, D_y, e) in the segment's local frame (x along the initial
/// heading), to first order in the noise (D is then Gaussian). Used for Cov_Obs and the
/// expected pose-error term.
///   Sigma_D   = K_rho int_0^L u u^T ds + delta_rho^2 K_theta int_0^L V V^T du
///   cov(D, e) = delta_rho K_theta int_0^L v(s) s ds,     var e = K_theta L
/// with u(s) = (cos as, sin as), v(s) = (-sin as, cos as), V(u) = int_u^L v(s) ds, a = b/L.
/// The integrals are smooth; 5-point Gauss-Legendre is accurate to ~1e-9 relative at
/// |b| = 1 and 2e-7 at |b| = 2 (windows of a few cm have |b| ~ 1e-3).
template <typename S>
Eigen::Matrix<S, 3, 3> syncNoiseMoments(const SyncSegment<S>& seg, S k_rho, S k_theta) {
  static constexpr S kNode[5] = {S(-0.9061798459386640), S(-0.5384693101056831), S(0),
                                 S(0.5384693101056831), S(0.9061798459386640)};
  static constexpr S kWeight[5] = {S(0.2369268850561891), S(0.4786286704993665),
                                   S(0.5688888888888889), S(0.4786286704993665),
                                   S(0.2369268850561891)};
  const S l = seg.length;
  Eigen::Matrix<S, 3, 3> m = Eigen::Matrix<S, 3, 3>::Zero();
  if (!(l > S(0))) return m;
  const S a = seg.rotation / l;
  const S dr = seg.delta_rho;
  Eigen::Matrix<S, 2, 2> su = Eigen::Matrix<S, 2, 2>::Zero();
  Eigen::Matrix<S, 2, 2> sv = Eigen::Matrix<S, 2, 2>::Zero();
  Eigen::Matrix<S, 2, 1> cv = Eigen::Matrix<S, 2, 1>::Zero();
  for (int k = 0; k < 5; ++k) {
    const S s = S(0.5) * l * (S(1) + kNode[k]);
    const S w = S(0.5) * l * kWeight[k];
    S sn;
    S c;
    sinCos(a * s, &sn, &c);
    su(0, 0) += w * c * c;
    su(0, 1) += w * c * sn;
    su(1, 1) += w * sn * sn;
    // V(s) = int_s^L v = 2h sinc(a h) (-sin a mid, cos a mid), mid = (s+L)/2, h = (L-s)/2
    const S h = S(0.5) * (l - s);
    const S mid = S(0.5) * (l + s);
    const S amp = S(2) * h * sinc(a * h);
    S sm;
    S cm;
    sinCos(a * mid, &sm, &cm);
    const S vx = -amp * sm;
    const S vy = amp * cm;
    sv(0, 0) += w * vx * vx;
    sv(0, 1) += w * vx * vy;
    sv(1, 1) += w * vy * vy;
    cv(0) += w * s * (-sn);
    cv(1) += w * s * c;
  }
  su(1, 0) = su(0, 1);
  sv(1, 0) = sv(0, 1);
  m.template topLeftCorner<2, 2>() = k_rho * su + dr * dr * k_theta * sv;
  m.template block<2, 1>(0, 2) = dr * k_theta * cv;
  m.template block<1, 2>(2, 0) = (dr * k_theta * cv).transpose();
  m(2, 2) = k_theta * l;
  return m;
}

/// Cov_Obs of z = (|D|^2, e^2) from the Gaussian moments of w (zero mean):
///   var|D|^2 = 2 tr(Sigma_D^2),  cov(|D|^2, e^2) = 2 |cov(D,e)|^2,  var e^2 = 2 var(e)^2.
template <typename S>
Eigen::Matrix<S, 2, 2> syncObservableCovariance(const Eigen::Matrix<S, 3, 3>& w) {
  const Eigen::Matrix<S, 2, 2> sd = w.template topLeftCorner<2, 2>();
  Eigen::Matrix<S, 2, 2> c;
  c(0, 0) = S(2) * (sd * sd).trace();
  c(0, 1) = S(2) * w.template block<2, 1>(0, 2).squaredNorm();
  c(1, 0) = c(0, 1);
  c(1, 1) = S(2) * sq(w(2, 2));
  return c;
}

/// Rotates the local-frame moments of w into the world frame (heading th of pose i).
template <typename S>
Eigen::Matrix<S, 3, 3> rotateMoments(const Eigen::Matrix<S, 3, 3>& local, S th) {
  Eigen::Matrix<S, 3, 3> r = Eigen::Matrix<S, 3, 3>::Identity();
  const S c = std::cos(th);
  const S s = std::sin(th);
  r(0, 0) = c;
  r(0, 1) = -s;
  r(1, 0) = s;
  r(1, 1) = c;
  return r * local * r.transpose();
}

/// The pose-error term of R for the synchronous observable:
///   sum over poses i, i+j of  E[ grad z  P  grad z^T ],  grad z_a = 2 w^T A_a,
/// = 4 [ tr(A_a P_end A_b^T W) + tr(B_a P_start B_b^T W) ]  with W = E[w w^T].
/// Pass W = the model's moments for the expectation (used), or w w^T of the observed w for
/// the paper's literal evaluation at the estimates (kept to show that it collapses).
/// dpe = dP^e in the world frame (enters through d dP^e / d theta_i).
template <typename S>
Eigen::Matrix<S, 2, 2> syncPoseErrorTerm(const Eigen::Matrix<S, 3, 3>& w,
                                         const Eigen::Matrix<S, 3, 3>& p_start,
                                         const Eigen::Matrix<S, 3, 3>& p_end, S dpe_x, S dpe_y) {
  Eigen::Matrix<S, 3, 3> a[2];
  Eigen::Matrix<S, 3, 3> b[2];
  a[0] << S(1), S(0), S(0), S(0), S(1), S(0), S(0), S(0), S(0);
  b[0] << S(-1), S(0), dpe_y, S(0), S(-1), -dpe_x, S(0), S(0), S(0);
  a[1] = Eigen::Matrix<S, 3, 3>::Zero();
  a[1](2, 2) = S(1);
  b[1] = -a[1];
  Eigen::Matrix<S, 2, 2> r;
  for (int i = 0; i < 2; ++i) {
    for (int k = i; k < 2; ++k) {
      r(i, k) = S(4) * ((a[i] * p_end * a[k].transpose() * w).trace() +
                        (b[i] * p_start * b[k].transpose() * w).trace());
      r(k, i) = r(i, k);
    }
  }
  return r;
}

/// Differential drive, eq. (10): mean and variance of e^2 with its K_w derivative.
template <typename S>
struct DiffMoments {
  S mean;
  S dmean_dkw;
  S variance;
};

template <typename S>
DiffMoments<S> diffObservableMoments(S path_right, S path_left, S wheelbase, S delta_d, S k_w) {
  const S d2 = sq(wheelbase * delta_d);
  const S g = (path_right + path_left) / d2;
  return {k_w * g, g, S(2) * sq(k_w * g)};
}

}  // namespace odoerr
