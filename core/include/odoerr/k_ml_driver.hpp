// odoerr core: the AKF driven by the recursive maximum-likelihood estimator of K
// (k_ml.hpp) instead of the paper's Observable Filter: `odoerr paper --of ml` on the host,
// and the core_replay_ml image on the Cortex-M4F, which measures its cost.
#pragma once

#include <cmath>

#include "odoerr/k_ml.hpp"

namespace odoerr {

/// The AKF driven by KMaxLikelihood instead of the OF: the same AKF, map and laser as `est`
/// (copied), the same cycle (predict with the estimator's filter K, fuse the scan), with the
/// likelihood's sensitivities carried beside it in the form KMlConfig::form names (KMlForm). The scan
/// forms (kPose, the default, and kScan) take each fused scan whole, from the AKF's state and
/// covariance before and after it (KMaxLikelihood::scan), and the prediction's Jacobians
/// from the AKF's own predict: no measurement rows, no transition computed twice. kBeam, the
/// reference, takes each fused beam, whose row it recomputes by a second ray cast at the
/// state before the beam (the core's cycle does not hand it out). Fixed-size, no heap
/// (NoHeap.MlCycle*); the firmware's core_replay_ml image measures the default form's cost
/// (footprint.json, "of_ml").
template <typename Est>
class MlDriver {
 public:
  using AkfT = typename Est::AkfT;
  using Model = typename Est::Model;
  using S = typename Model::Scalar;
  using MlT = KMaxLikelihood<Model>;
  static constexpr int N = Model::kStates;

  MlDriver(const Est& est, const KMlConfig<S>& cfg) : akf_(est.akf()), map_(est.map()), laser_(est.laser()), ml_(cfg) {
    ml_.init(est.of().estimate());
    for (int j = 0; j < N; ++j) prior_var_[j] = akf_.covariance()(j, j);
  }

  void cycle(const typename Model::Input& u, const S* ranges) {
    constexpr int Hc = AkfT::kHCols;
    const KMlForm form = ml_.config().form;
    auto sensitivities = [&](const Eigen::Matrix<S, 3, N>& f, const Eigen::Matrix<S, 3, Model::kNoise>& g) {
      if (form == KMlForm::kPose) {
        ml_.template predict<Hc>(akf_.model(), u, f, g);
      } else {
        ml_.template predict<N>(akf_.model(), u, f, g);
      }
    };
    if (akf_.predict(u, ml_.filterK(), S(0), sensitivities) != Status::kOk) return;
    if (ranges != nullptr) {
      if (form == KMlForm::kBeam) {
        fuseBeams(ranges);
      } else {
        // What KMaxLikelihood::scan reads of the state before the scan: P's first Hc
        // columns and x's first Hc entries.
        const Eigen::Matrix<S, N, Hc> p_pre = akf_.covariance().template leftCols<Hc>();
        const Eigen::Matrix<S, Hc, 1> x_pre = akf_.state().template head<Hc>();
        if (akf_.updateScan(map_, laser_, ranges).used > 0) {
          if (form == KMlForm::kPose) {
            (void)ml_.template scan<Hc, Hc>(p_pre, x_pre, akf_.covariance(), akf_.state());
          } else {
            (void)ml_.template scan<Hc, N>(p_pre, x_pre, akf_.covariance(), akf_.state());
          }
        }
      }
    }
    if (ml_.endCycle(akf_.state(), akf_.covariance())) {
      if (ml_.overstatement() > S(1)) {
        discount(ml_.overstatement());
      } else if (ml_.understatement() > S(1)) {
        credit(ml_.understatement());
      }
    }
  }

  const AkfT& akf() const { return akf_; }
  const MlT& ml() const { return ml_; }
  /// Restarts K (and its recursion) at k; for tests.
  void restartK(const typename MlT::KVec& k) { ml_.init(k); }
  /// Sum of -1/2 (log s + nu^2/s) over the fused beams so far (the innovation likelihood);
  /// accumulated with KMlForm::kBeam only.
  S logLikelihood() const { return loglik_; }

 private:
  /// What the AKF learnt of the systematic parameters under a K `factor` times too small
  /// was overconfident (KMaxLikelihood::overstatement): their variances (and covariances,
  /// by the same factors) are scaled up by factor, but not above the prior's (measured in
  /// docs/nonsystematic.md: with K 100x too small for the first metre and then right,
  /// E_theta's spread at 30 m was 78 % against 18 %).
  ODOERR_NOINLINE void discount(S factor) {
    S d[N];
    const auto& p = akf_.covariance();
    for (int j = 3; j < N; ++j) {
      const S r = p(j, j) > S(0) ? std::min(factor, prior_var_[j] / p(j, j)) : S(1);
      d[j] = r > S(1) ? std::sqrt(r) : S(1);
    }
    akf_.scaleParameterCovariance(d);  // reads d[3..N-1]
  }

  /// The mirror of discount() for delta_rho (KMlConfig::credit, synchronous drive from
  /// above): what the AKF gathered on it since its prior, 1/P - 1/P_0, came under a K
  /// `factor` times too large; that information is scaled up by factor (its row and column
  /// of P by one factor, so P stays a congruence). E_theta is left as it is: credited too it
  /// ended 2-4 % worse (docs/nonsystematic.md "The credit from above").
  ODOERR_NOINLINE void credit(S factor) {
    constexpr int j = MlT::kCreditedState;
    if constexpr (j >= 3) {
      S d[N];
      for (int i = 3; i < N; ++i) d[i] = S(1);
      const S pjj = akf_.covariance()(j, j);
      const S info = pjj > S(0) ? S(1) / pjj : S(0);
      const S gathered = prior_var_[j] > S(0) ? info - S(1) / prior_var_[j] : S(0);
      if (!(gathered > S(0))) return;
      d[j] = std::sqrt(S(1) / ((info + gathered * (factor - S(1))) * pjj));
      akf_.scaleParameterCovariance(d);  // reads d[3..N-1]
    } else {
      (void)factor;
    }
  }

  /// The kBeam form's scan: every fused beam's row by a second ray cast at the state before
  /// it (out of line: the firmware's form is kPose, and its cycle stays compact).
  ODOERR_NOINLINE void fuseBeams(const S* ranges) {
    typename AkfT::StateMat p_pre = akf_.covariance();
    typename AkfT::StateVec x_pre = akf_.state();
    auto observe = [&](const typename AkfT::BeamRecord& rec) {
      if (rec.status != Status::kOk) return;
      Eigen::Matrix<S, 1, 3> h3;
      S range = S(0);
      typename AkfT::StateVec h = AkfT::StateVec::Zero();
      if (AkfT::expectedRange(map_, laser_, x_pre[0], x_pre[1], std::cos(x_pre[2]), std::sin(x_pre[2]), rec.beam,
                              S(0), &range, &h3) == Status::kOk) {
        h.template head<3>() = h3.transpose();
        const S nu = rec.measured - rec.predicted;
        ml_.beam(h, p_pre, nu, rec.variance);
        loglik_ += S(-0.5) * (std::log(rec.variance) + nu * nu / rec.variance);
      }
      const auto& p = akf_.covariance();  // upper triangle current within a scan
      for (int j = 0; j < N; ++j) {
        for (int k = j; k < N; ++k) p_pre(j, k) = p_pre(k, j) = p(j, k);
      }
      x_pre = akf_.state();
    };
    (void)akf_.updateScan(map_, laser_, ranges, observe);
  }

  AkfT akf_;
  typename Est::MapT map_;
  typename Est::LaserT laser_;
  MlT ml_;
  S prior_var_[N];  ///< the AKF's initial variances: discount() does not go above them, credit() scales what P gained on them
  S loglik_ = S(0);
};

}  // namespace odoerr
