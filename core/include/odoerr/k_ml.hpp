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
  /// The differential drive's Q has a second parameter the recursion estimates beside K_w
  /// (KMlConfig::heading_scale): the heading noise is K_w (|dR| + |dL|) / (d delta_d)^2, so
  /// the innovations fix K_w and K_w / delta_d^2 apart (the translation noise and the heading
  /// noise), and a delta_d the AKF has not learnt (a circle) must not bias K_w. Index kC holds
  /// c = 1 / delta_d^2 as the noise sees it, in the same log parametrisation as K; the AKF
  /// keeps predicting with its own delta_d (c_f = 1 / delta_d^2 from its state), and c's prior
  /// is the AKF's own knowledge of delta_d (log c ~ N(log c_f, 4 P_dd / delta_d^2)). While
  /// the AKF predicts with an inflated K, c is held at c_f (step()).
  static constexpr bool kHeadingScale = std::is_same_v<Drive, DiffDrive<S>>;
  static constexpr int P = M + (kHeadingScale ? 1 : 0);  ///< the parameters of Q estimated
  static constexpr int kC = M;                            ///< c's index (kHeadingScale)
  /// The AKF state the credit from above acts on (KMlConfig::credit): the synchronous
  /// drive's delta_rho; none (-1) on the differential drive.
  static constexpr int kCreditedState = [] {
    if constexpr (kHeadingScale) {
      return -1;
    } else {
      return Model::kDriveOffset + Drive::kDeltaRho;
    }
  }();
  using PVec = Eigen::Matrix<S, P, 1>;
  using PMat = Eigen::Matrix<S, P, P>;
  using StateVec = Eigen::Matrix<S, N, 1>;
  using StateMat = Eigen::Matrix<S, N, N>;

  KMaxLikelihood() = default;
  explicit KMaxLikelihood(const KMlConfig<S>& cfg) : cfg_(cfg) {
    if (cfg_.every < 1) cfg_.every = 1;
  }

  void init(const KVec& k0) {
    k_.setZero();
    k_.template head<M>() = k0;  // c (kC) is set from the AKF's delta_d at the first step
    kf_ = k_;
    for (int i = 0; i < P; ++i) {
      dp_[i].setZero();
      xi_[i].setZero();
    }
    g_.setZero();
    h_.setZero();
    info_.setZero();
    j_.setZero();
    prior_info_ = S(0);
    prior_mean_ = S(0);
    k_ref_ = k0;
    lambda_ = cfg_.lambda0;
    cycles_ = 0;
    taken_ = 0;
    updateFilterK();
    overstated_ = S(1);
    kf_min_ = filterK();
    credited_ = S(1);
    stepped_ = false;
    from_above_ = false;
  }

  KVec estimate() const { return k_.template head<M>(); }
  /// The K the AKF should predict with (K itself unless inflate > 0); the sensitivities and
  /// the score are with respect to it. Updated at each step.
  KVec filterK() const { return kf_.template head<M>(); }
  bool headingScaleOn() const { return kHeadingScale && cfg_.heading_scale; }
  /// delta_d as the noise sees it (kHeadingScale, once estimated: 1 / sqrt(c)); else 0.
  S noiseDeltaD() const {
    if constexpr (kHeadingScale) {
      return headingScaleOn() && k_[kC] > S(0) ? S(1) / std::sqrt(k_[kC]) : S(0);
    } else {
      return S(0);
    }
  }
  /// The factor by which the AKF's knowledge of the systematic parameters was overstated, as
  /// seen at the last step: the largest K / (the smallest K_f the AKF has predicted with
  /// since the last such discount) over the components when above
  /// KMlConfig::discount_above, else 1 (MlDriver discounts the AKF's parameters by it).
  S overstatement() const { return overstated_; }
  /// The factor by which the AKF's knowledge of delta_rho (kCreditedState) was understated,
  /// as seen at the last step (KMlConfig::credit; synchronous drive): the smallest fall
  /// K_before / K over the components when every K fell while K_f was inflated, in a run
  /// whose first step lowered every K (from above), capped at credit_max; else 1 (MlDriver
  /// credits the AKF's delta_rho by it).
  S understatement() const { return credited_; }
  /// Covariance of K from the accumulated information (J^-1 in log K, mapped to K).
  /// With c estimated (kHeadingScale), J with c's prior, marginalised over c: it then holds
  /// delta_d's share of K_w's uncertainty.
  KMat covariance() const {
    KMat c = KMat::Zero();
    Eigen::LLT<PMat> llt(withPrior());
    if (llt.info() != Eigen::Success) {
      for (int i = 0; i < M; ++i) c(i, i) = k_[i] * k_[i];  // no information: 100 %
      return c;
    }
    const PMat ci = inverseOf(llt);
    const KVec k = k_.template head<M>();
    return k.asDiagonal() * ci.template topLeftCorner<M, M>() * k.asDiagonal();
  }
  /// covariance() with the systematic parameters' uncertainty carried over where Q depends
  /// on them. On the differential drive the heading noise is K_w (|dR| + |dL|) / (d delta_d)^2:
  /// with c estimated, covariance() holds delta_d's share already; without it
  /// (heading_scale off) the innovations fix K_w / delta_d^2, and J (at the estimated
  /// delta_d) misses that share: var(log K_w) gains 4 P_dd / delta_d^2 (x, p: the AKF's state
  /// and covariance). The synchronous drive's Q does not depend on its parameters.
  KMat covarianceWithSystematic(const StateVec& x, const StateMat& p) const {
    KMat c = covariance();
    if constexpr (kHeadingScale) {
      if (!headingScaleOn()) c(Drive::kKw, Drive::kKw) += k_[Drive::kKw] * k_[Drive::kKw] * deltaDVarLogKw(x, p);
    }
    return c;
  }
  const KMlCounters& counters() const { return counters_; }
  const KMlConfig<S>& config() const { return cfg_; }
  /// This block's score and information (K, then c: P entries).
  const PVec& blockScore() const { return g_; }
  const PMat& blockInformation() const { return info_; }

  /// Before the AKF's prediction, with its Jacobians (Akf::predict's observer hands them
  /// out; Akf::transition computes them): dP_i <- F dP_i F^T + G dQ/dK_i G^T, xi_i <- F xi_i, with F = [f_pose; 0 I] and
  /// G = [g_pose; 0], so only the pose rows and columns change. Ns: the states whose
  /// sensitivities are carried (the first Ns; the others stay zero): N, or the measured
  /// states (KMlForm::kPose).
  template <int Ns = N>
  ODOERR_NOINLINE void predict(const Model& model, const Input& u, const Eigen::Matrix<S, 3, N>& f_pose,
                               const Eigen::Matrix<S, 3, Model::kNoise>& g_pose) {
    static_assert(Ns >= 3 && Ns <= N, "the sensitivities start with the pose");
    const int np = active();
    for (int i = 0; i < np; ++i) {
      // Q is linear in K: dQ/dK_i is Q at the unit vector. c scales the heading rows of
      // G Q G^T by c / c_f (the covariances by its square root): d/dlog c at c_f is Q at K_f's
      // heading row and column, the covariances halved (below).
      KVec e = KVec::Zero();
      if (i < M) {
        e[i] = S(1);
      } else {
        e = kf_.template head<M>();
      }
      const auto dq = model.drive.noiseVariance(u, e);
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
          S nq = S(0);
#pragma GCC unroll 16
          for (int l = 0; l < Model::kNoise; ++l) nq += g_pose(r, l) * dq[l] * g_pose(k, l);
          if constexpr (kHeadingScale) {
            if (i == kC) nq *= k == 2 ? (r == 2 ? S(1) : S(0.5)) : S(0);
          }
          acc += nq;
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
    const int np = active();
    S ds[P];
    S a[P];
    StateVec dph[P];
    for (int i = 0; i < np; ++i) {
      dph[i] = dp_[i] * h;
      ds[i] = h.dot(dph[i]);
      a[i] = h.dot(xi_[i]);
    }
    const S nis = nu * nu / s;
    for (int i = 0; i < np; ++i) {
      g_[i] += S(-0.5) * ds[i] / s * (S(1) - nis) + nu * a[i] / s;
      h_[i] += S(0.5) * ds[i] / s;
      for (int j = 0; j < np; ++j) info_(i, j) += S(0.5) * ds[i] * ds[j] / (s * s) + a[i] * a[j] / s;
    }
    for (int i = 0; i < np; ++i) {
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
                            const StateMat& p_post, const StateVec& x_post);

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
    credited_ = S(1);
    const KVec k_before = estimate();
    const bool was_inflated = inflated();
    const bool hs = headingScaleOn();
    if (cfg_.deflate && !hs) deflateBySystematic(x, p);
    // c's prior from the AKF's delta_d (sets c_f); without c a unit prior and no score hold
    // its entry still.
    S prior_info = S(1);
    S prior_mean = S(0);
    if constexpr (kHeadingScale) {
      if (hs) headingScalePrior(x, p, &prior_info, &prior_mean);
    }
    PVec dk = kf_;
    if constexpr (kHeadingScale) dk[kC] = S(1);  // c's sensitivities are in log c already
    const PMat info_t = dk.asDiagonal() * info_ * dk.asDiagonal();
    const PVec g_f = dk.asDiagonal() * g_;  // the score at K_f, in log K
    const bool shift = cfg_.inflate > S(0) || hs;
    // c held at c_f while K_f is inflated (below): held from here, so that the score carried
    // to K has no move of c in it (K's line would otherwise take the cross term I_Kc times
    // log c_f - log c, for a c this step then drops).
    const bool hold_c = hs && inflated();
    if constexpr (kHeadingScale) {
      if (hold_c) k_[kC] = kf_[kC];
    }
    PVec g_t = g_f;
    const PVec h_f = h_;
    if (shift) g_t = shiftScore(info_t, g_f, h_f, k_);
    const PVec s0 = g_t;  // the carried score at K now (for the solve's further iterations)
    if constexpr (kHeadingScale) {
      // The prior's pull at log c now, less the last step's, which the data balanced there
      // (forgotten with J by lambda).
      if (hs) {
        const S lc = std::log(k_[kC]);
        g_t[kC] += lambda_ * prior_info_ * (lc - prior_mean_) - prior_info * (lc - prior_mean);
      }
    }
    prior_info_ = prior_info;
    prior_mean_ = prior_mean;
    j_ = lambda_ * j_ + info_t;
    lambda_ = cfg_.lambda_rate * lambda_ + (S(1) - cfg_.lambda_rate);
    g_.setZero();
    h_.setZero();
    info_.setZero();
    PMat jp = withPrior();
    if constexpr (kHeadingScale) {
      // While the AKF predicts with an inflated K, c is held at the AKF's own c_f and K steps
      // with c held; what the data say of c still gathers in J. Moved then, c took the score
      // carried down from K_f with K's (the cross term, log K_f - log K up to log 30) and
      // wandered, and the AKF's delta_R, delta_L suffered from below; left out of J instead,
      // the information on K_w alone from that stretch (read at the AKF's delta_d) held K_w
      // low: 0.92x (docs/nonsystematic.md "c held while K_f is inflated").
      if (hold_c) {
        for (int i = 0; i < M; ++i) jp(i, kC) = jp(kC, i) = S(0);
        g_t[kC] = S(0);
      }
    }
    Eigen::LLT<PMat> llt(jp);
    if (llt.info() != Eigen::Success || !g_t.allFinite()) {
      ++counters_.skipped;
      return false;
    }
    // The step solves r(d) = 0 for the move d in log K: r is the batch's score carried to
    // K e^d (shiftScore) less J's pull back to K. The first iteration is the Gauss-Newton
    // step; further ones (KMlConfig::solve_iters, synchronous drive) follow the
    // variance-scale model's curvature with the same factor (a chord method). Where the
    // carried score is the line they add nothing, and they stop once a move is below 1e-3.
    PVec total = PVec::Zero();
    PVec r = g_t;
    const int iters = kHeadingScale ? 1 : cfg_.solve_iters;
    bool down = false;  // the first iteration lowered every K
    for (int it = 0; it < iters; ++it) {
      PVec step = llt.solve(r);
      if (!step.allFinite()) {
        if (it == 0) {
          ++counters_.skipped;
          return false;
        }
        break;
      }
      const S big = step.cwiseAbs().maxCoeff();
      if (big > cfg_.max_log_step) {
        step *= cfg_.max_log_step / big;
        if (it == 0) ++counters_.clipped;
      }
      total += step;
      if (it == 0) down = step.maxCoeff() < S(0);
      if (it + 1 == iters || !shift || !down || big < S(1e-3)) break;
      // r(d) = g_t + (S(d) - S(0) + I d) - jp d: S the carried score, I d its line's part
      PVec kk = k_;
      for (int i = 0; i < active(); ++i) kk[i] *= std::exp(total[i]);
      r = g_t + (shiftScore(info_t, g_f, h_f, kk) - s0 + info_t * total) - jp * total;
    }
    for (int i = 0; i < active(); ++i) k_[i] *= std::exp(total[i]);
    ++counters_.steps;
    creditFall(k_before, was_inflated);
    if (cfg_.reset_log > S(0)) {
      S moved = S(0);
      for (int i = 0; i < M; ++i) moved = std::max(moved, std::abs(std::log(k_[i] / k_ref_[i])));
      if (moved > cfg_.reset_log) {
        j_ *= cfg_.reset_keep;
        lambda_ = cfg_.lambda0;
        k_ref_ = estimate();
        for (int i = 0; i < P; ++i) {
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
  /// c (kHeadingScale) takes the line: the AKF never predicts with it, and log c_f - log c
  /// has either sign.
  /// g_f, h_f: the score and h at K_f; kk: the K where it is wanted (then c).
  PVec shiftScore(const PMat& info_t, const PVec& g_f, const PVec& h_f, const PVec& kk) const {
    PVec dtheta = PVec::Zero();
    for (int i = 0; i < active(); ++i) dtheta[i] = std::log(kf_[i] / kk[i]);
    PVec line = g_f + info_t * dtheta;
    if (cfg_.scale_shift) {
      for (int i = 0; i < M; ++i) {
        const S h = kf_[i] * h_f[i];
        if (h > S(0) && dtheta[i] > S(0)) {
          line[i] = std::min(line[i], scaleShiftedScore(g_f[i], h, std::min(info_t(i, i) / h, S(1)), dtheta[i]));
        }
      }
    }
    return line;
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

  /// c's prior (kHeadingScale): log c ~ N(-2 log delta_d, 4 P_dd / delta_d^2) from the AKF's
  /// state and covariance; sets c_f = 1 / delta_d^2, and c itself at the first step. Where
  /// delta_d is not usable the last prior stays.
  void headingScalePrior(const StateVec& x, const StateMat& p, S* info, S* mean) {
    constexpr int kD = Model::kDriveOffset + Drive::kDeltaD;
    const S v = deltaDVarLogKw(x, p);  // 0 where delta_d or P_dd is not usable
    if (v > S(0)) {
      const S dd = x[kD];
      kf_[kC] = S(1) / (dd * dd);
      *mean = std::log(kf_[kC]);
      *info = S(1) / std::max(v, cfg_.min_heading_scale_var);
    } else if (prior_info_ > S(0)) {
      *mean = prior_mean_;
      *info = prior_info_;
    } else {
      kf_[kC] = S(1);
      *mean = S(0);
      *info = S(1);
    }
    if (!(k_[kC] > S(0))) {  // the first step: c starts at the AKF's
      k_[kC] = kf_[kC];
      prior_mean_ = *mean;
    }
  }

  /// KMlConfig::credit, after a step from k_before: the first step marks the run as from
  /// above when it lowered every K; in such a run every fall of every K while K_f was inflated
  /// (was_inflated), the first step's included, sets credited_ to the smallest fall.
  /// Synchronous drive only (not kHeadingScale).
  void creditFall(const KVec& k_before, bool was_inflated) {
    S fall = k_before[0] / k_[0];
    for (int i = 1; i < M; ++i) fall = std::min(fall, k_before[i] / k_[i]);
    if (!stepped_) {
      stepped_ = true;
      from_above_ = fall > S(1);
    }
    if (!kHeadingScale && cfg_.credit && from_above_ && was_inflated && fall > S(1)) {
      credited_ = std::min(fall, cfg_.credit_max);
    }
  }

  /// J with c's prior (kHeadingScale).
  PMat withPrior() const {
    PMat jp = j_;
    if constexpr (kHeadingScale) jp(kC, kC) += prior_info_;
    return jp;
  }
  int active() const { return headingScaleOn() ? P : M; }
  /// The AKF predicts with a K above the estimate (KMlConfig::inflate).
  bool inflated() const {
    for (int i = 0; i < M; ++i) {
      if (kf_[i] > k_[i]) return true;
    }
    return false;
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
  static PMat inverseOf(const Eigen::LLT<PMat>& llt) {
    PMat ci;
    for (int i = 0; i < P; ++i) ci.col(i) = llt.solve(PVec::Unit(i));
    return ci;
  }

  void updateFilterK() {
    kf_.template head<M>() = k_.template head<M>();  // c_f stays the AKF's 1 / delta_d^2
    if (!(cfg_.inflate > S(0))) return;
    const PMat jp = withPrior();
    Eigen::LLT<PMat> llt(jp);
    const bool ok = llt.info() == Eigen::Success;
    // With c estimated, K's uncertainty with c held (1 / J_ii): on the differential drive the
    // AKF's Q is mostly the heading noise, which the data fix as K_w c, far better than K_w
    // alone (J is nearly singular along log K_w - log c). The marginal sigma kept the
    // inflation on for most of the drive, and the score carried from K_f mixed the two: K_w
    // 0.88x / 0.81x the truth at 30 m on the circle (100 runs), against 1.018x / 0.980x with
    // this (docs/nonsystematic.md "K_w and delta_d: the heading noise's scale estimated").
    const bool held = headingScaleOn();
    const S factor = held ? cfg_.inflate_held : cfg_.inflate;
    const PMat ci = ok && !held ? inverseOf(llt) : PMat::Zero();
    for (int i = 0; i < M; ++i) {
      const S var = held ? (jp(i, i) > S(0) ? S(1) / jp(i, i) : S(0)) : ci(i, i);
      // While J tells nothing of K's uncertainty (before the first step), the start's cap too.
      const bool known = ok && var > S(0);
      const S sig = known ? std::sqrt(var) : cfg_.max_inflate_log;
      const S cap = known ? cfg_.max_inflate_log : std::min(cfg_.max_start_inflate_log, cfg_.max_inflate_log);
      const S up = std::min(factor * sig - cfg_.inflate_offset, cap);
      kf_[i] = up > S(0) ? k_[i] * std::exp(up) : k_[i];
    }
  }

  KMlConfig<S> cfg_{};
  PVec k_ = PVec::Ones();   ///< K, then c (kHeadingScale)
  PVec kf_ = PVec::Ones();  ///< K_f, then c_f = 1 / delta_d^2 (the AKF's)
  KVec k_ref_ = KVec::Ones();  ///< K when J was last restarted
  StateMat dp_[P];
  StateVec xi_[P];
  PVec g_ = PVec::Zero();
  PMat info_ = PMat::Zero();
  PMat j_ = PMat::Zero();  ///< the information gathered (without c's prior)
  S prior_info_ = S(0);    ///< c's prior information at the last step (kHeadingScale)
  S prior_mean_ = S(0);    ///< and its mean, log c_f
  S lambda_ = S(0.9);
  int cycles_ = 0;
  int taken_ = 0;  ///< scans (or beams) taken since the last step
  S overstated_ = S(1);
  KVec kf_min_ = KVec::Ones();  ///< the smallest K_f since the last discount
  S credited_ = S(1);           ///< understatement()
  bool stepped_ = false;        ///< a step has been taken since init
  bool from_above_ = false;     ///< the first step lowered every K (credit)
  PVec h_ = PVec::Zero();  ///< 1/2 tr(C dP_i): what the score of K_i would be with no innovation
  KMlCounters counters_{};
};

}  // namespace odoerr

// The members defined out of the class.
#include "odoerr/k_ml_scan.hpp"  // NOLINT(build/include_order): KMaxLikelihood::scan
