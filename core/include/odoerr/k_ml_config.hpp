// odoerr core: the settings, counters and score model of the recursive maximum-likelihood
// estimator of K (k_ml.hpp): what a caller configures and reads, apart from the recursion.
#pragma once

#include <cmath>
#include <cstdint>

namespace odoerr {

/// The form of the ML recursion's update (KMlConfig::form, MlDriver):
///  - kPose (default): each fused scan whole (scan<Hc, Hc>), with the sensitivities carried
///    on the measured states only (the pose): dP/dK and d xhat/dK of the systematic
///    parameters are left out. The score stays an unbiased estimating equation (its weights
///    depend on the past only); on the paper's drives it moves by under 0.1 of its standard
///    deviation, and the figures at 30 m are as good or better (docs/nonsystematic.md).
///    The firmware's form: O(Hc^3) a scan.
///  - kScan: each fused scan whole, all sensitivities (scan<Hc, N>): the same score as kBeam.
///  - kBeam: each fused beam (beam(): a second ray cast for its row, O(N^2) a beam): the
///    reference the others are tested against (test_k_ml_score.cpp).
enum class KMlForm { kPose, kScan, kBeam };

template <typename S>
struct KMlConfig {
  /// Cycles between K steps. 5 measured better on the paper's drives (at commit ecc54b2,
  /// 300 runs of the sync circle: K_rho 10.0 / 10.3 -> 9.1 / 9.0 %, E_theta from above
  /// 1.027x -> 1.010x the paper OF's; docs/nonsystematic.md) but is not the default: K_w
  /// alone's sigma (heading_scale off) came out 0.56x its spread on the eight, and
  /// delta_rho's spread at 10 m 1.10x the paper OF's. 1 wandered (K_rho 21.8 %). With the
  /// iterated solve (solve_iters; measured at commit bd08b0e) 5 put delta_rho from below at
  /// 1.22x the OF's (300 runs).
  int every = 10;
  S max_log_step = S(0.5);        ///< |delta log K| per iteration of a step's solve at most
  /// Iterations of each K step's solve on the synchronous drive when the step lowers every
  /// K: the first is the Gauss-Newton step; the further ones follow the
  /// variance-scale model's curvature with the same factor (a chord method), so that from
  /// above, where the data are saturated, K falls to the batch's level at once instead of
  /// by the line's share of it. 100 runs from 100x above, K_rho / K_theta at 0.2 m 42x / 37x
  /// -> 6.5x / 2.1x the truth. 300 runs (seeds 1-300 / 1001-1300) from above, the end error
  /// against the paper OF's on the same drives (paired): E_theta 1.026x / 1.014x -> 1.003x /
  /// 0.997x, delta_rho 1.073x / 1.052x -> 1.047x / 1.031x, K_rho 10.2 / 10.5 -> 9.9 / 10.0 %;
  /// from below nothing moves (docs/nonsystematic.md "The step's solve iterated").
  /// Iterating rising steps too cost delta_rho from below (1.12x the OF's at 10 m). On the
  /// differential drive the step stays one: with the heading noise's scale the iterations
  /// pulled K_w to 0.84x on the circle, and K_w alone's sigma rose to 1.5x its spread.
  int solve_iters = 6;
  S lambda0 = S(0.9);             ///< initial forgetting factor
  S lambda_rate = S(0.98);        ///< lambda <- rate lambda + (1 - rate)  (towards 1)
  /// Stale information: when log K has moved by more than reset_log (any component) since
  /// the last restart, the sensitivities dP/dK, d xhat/dK are dropped, J is scaled by reset_keep and lambda
  /// restarts at lambda0 (0: off). Gathered at a K far from the current one, they no longer
  /// describe the likelihood there: the sensitivities of the systematic-parameter states,
  /// built while the innovations were large, decay slowly and inflate the information, so
  /// the steps stall and sigma is too small (measured: docs/nonsystematic.md).
  S reset_log = S(1.5);
  /// The share of J a restart keeps. Emptied (0), J let the inflation jump to its cap at
  /// each restart (K_f 30x the estimate); once, on a blind stretch, that lost the pose from
  /// below (seed 1059: docs/nonsystematic.md).
  S reset_keep = S(0.3);
  /// Decoupling the AKF's Q from the estimate while K is uncertain: the AKF runs with
  /// K_f = K exp(min(inflate sigma_logK - inflate_offset, max_inflate_log)) when that exponent
  /// is positive, else K (inflate 0: off); sigma_logK from J (max_inflate_log while J is not
  /// positive definite). The score then comes at K_f, and the step for K carries it down to
  /// K (scale_shift).
  S inflate = S(2);
  /// The same factor where K's sigma is taken with c held (heading_scale): 1 / J_ii leaves
  /// out what c's uncertainty adds, so it ends the inflation sooner than the marginal sigma
  /// did, and from below the AKF's delta_d learnt too much too early. Measured on the circle
  /// from below (100 runs, 30 m, seeds 1-100 / 1001-1100), delta_d against the paper OF's
  /// 14.6 / 15.1 %: 2: 16.1 / 18.3 %; 2.25: 14.9 / 15.9 %; 2.5: 13.7 / 14.5 %; 3: 12.0 /
  /// 13.1 %, with K_w 0.980x / 0.999x, 0.972x / 0.980x, 0.967x / 0.969x the truth; the eight
  /// the same (docs/nonsystematic.md "c held while K_f is inflated"). 0 with inflate 0.
  S inflate_held = S(2.5);
  /// log 30: 100 (the paper's starting factor) let one run of 400 lose the pose from above
  /// on the figure-eight (Q 10^4 times too large at the start); 30 loses none (measured).
  S max_inflate_log = S(3.4011974);
  /// The inflation's cap while J tells nothing of K's uncertainty (before the first step):
  /// log 10. With max_inflate_log (30) there, one run of 400 of the figure-eight from 100x
  /// above (seed 113) predicted its first 0.1 m with K_w 3000x the truth and turned its
  /// heading by pi/2 for good (the square room's symmetry); 10 loses none of 400 on either
  /// path or drive, and from below the figures stay (docs/nonsystematic.md).
  S max_start_inflate_log = S(2.3025851);
  /// The offset ends the inflation once K is known to about inflate_offset / inflate in log
  /// (15 %), so that K_f = K at the end of a drive.
  S inflate_offset = S(0.3);
  /// How the score at K_f is carried to K (inflate > 0): true, the smaller of the
  /// Gauss-Newton line g + I (log K_f - log K) and the variance-scale model (each beam's s =
  /// r + q K: exact where all of s comes from K); false, the line alone. Far above the truth
  /// the data are saturated (nu^2 << s, the step at most -1 in log K) and the line turned
  /// that into a push upwards; measured from 100x above: K_rho 8x the truth at 1 m with the
  /// line, E_theta 19.1 % against 19.7 % at 30 m (docs/nonsystematic.md).
  bool scale_shift = true;
  /// Differential drive: each step's information on K_w is deflated by delta_d's share,
  /// I / (1 + I 4 P_dd / delta_d^2): the heading noise fixes K_w / delta_d^2, so what was
  /// gathered while delta_d was uncertain says less of K_w (figure-eight from below: 6.8 ->
  /// 5.7 %). No effect on the synchronous drive, whose Q does not depend on its parameters.
  bool deflate = true;
  /// Differential drive: the recursion estimates, beside K_w, c = 1 / delta_d^2 as the heading
  /// noise K_w (|dR| + |dL|) / (d delta_d)^2 sees it, with the AKF's knowledge of delta_d as
  /// its prior (KMaxLikelihood::kHeadingScale): the translation noise and the heading noise
  /// then tell K_w and delta_d apart, and deflate does not apply. The AKF keeps predicting
  /// with its own delta_d; c's score is carried to c along the Gauss-Newton line. K_f's
  /// inflation follows K's uncertainty with c held, by the factor inflate_held, and while
  /// K_f is inflated c is held at the AKF's own (its information still gathers). Measured
  /// (100 runs, 30 m, below / above): K_w on the circle 0.972x / 0.981x the truth at 13.8 /
  /// 12.8 % (1.09x / 1.01x its joint bound; K_w alone: 0.894x / 0.872x at 27.4 / 16.5 %), on
  /// the eight 0.997x / 0.998x at 4.4 / 4.5 % (1.10x / 1.13x); delta_R, delta_L, delta_d no
  /// worse than with the paper's OF. false: K_w alone, read through the AKF's delta_d
  /// (docs/nonsystematic.md "c held while K_f is inflated").
  bool heading_scale = true;
  /// The smallest variance of c's prior (log c), for a delta_d the AKF holds as known.
  S min_heading_scale_var = S(1e-6);
  /// The driver's form of the update (KMlForm).
  KMlForm form = KMlForm::kPose;
  /// When K rises, what the AKF knew of the systematic parameters is discounted by the same
  /// factor, up to their prior (overstatement(), MlDriver::discount; false: never).
  bool discount = true;
  /// Only a rise beyond this factor is discounted (overstatement).
  S discount_above = S(2);
  /// Synchronous drive, from above: the mirror of the discount for delta_rho
  /// (KMaxLikelihood::understatement, MlDriver::credit). In a run whose first K step lowered
  /// every K, each step that lowers every K while the AKF predicts with an inflated K_f (that
  /// first step included) scales the information the AKF has gathered on delta_rho since its prior (1/P - 1/P_0)
  /// by the smallest fall (capped at credit_max): it was gathered under a Q too large by
  /// about that factor, so P overstated the uncertainty, and the AKF went on weighing new data
  /// too much (without the credit, at commit 4b49a26: delta_rho's sigma 4.7 % at 2 m against
  /// the oracle's 2.3 %).
  /// Measured over 300 runs from above, end error over the paper OF's, run by run: delta_rho
  /// on the circle 1.047x -> 1.007x (seeds 1-300), 1.031x -> 1.001x (1001-1300), on the eight
  /// 1.026x -> 0.991x, E_theta unchanged (docs/nonsystematic.md "The credit from above").
  /// Crediting E_theta too cost it 2-4 %; each parameter by its own K's fall, delta_rho 1.06x.
  /// Not from below: there the falls after an overshoot are wander, and crediting them put
  /// delta_rho at 1.11x. Not on the differential drive, whose Q depends on delta_d (delta
  /// from above 1.28-1.34x).
  bool credit = true;
  /// The largest factor one step credits.
  S credit_max = S(10);
};

struct KMlCounters {
  std::uint32_t steps = 0;
  std::uint32_t clipped = 0;   ///< steps limited by max_log_step
  std::uint32_t skipped = 0;   ///< steps refused (information not positive definite)
  std::uint32_t beams = 0;
  std::uint32_t resets = 0;    ///< restarts of J and the sensitivities (reset_log)
  std::uint32_t scans = 0;     ///< scans taken whole (scan())
  std::uint32_t scans_skipped = 0;  ///< scans refused by scan(): P_prior not positive definite
  std::uint32_t idle = 0;      ///< steps not taken: nothing fused since the last one
};

/// The score in log K carried down by d = log K_f - log K >= 0 under the variance-scale
/// model (KMlConfig::scale_shift): every beam's s = r + q K, with abar the share of s that
/// comes from K (the same for every beam), so that going down by d each s scales by
/// phi = 1 - abar + abar e^-d. From g (the score at K_f), h (1/2 the sum of the shares:
/// g's value with no innovation) and abar: e^-d / phi (-h + (g + h) / phi). Exact when the
/// shares are equal (test_k_ml.cpp). Near the maximum (g = 0) it is abar h d to first order,
/// the Gauss-Newton line's I d with the information 1/2 sum abar^2 = abar h.
template <typename S>
S scaleShiftedScore(S g, S h, S abar, S d) {
  const S e = std::exp(-d);
  const S phi = S(1) - abar + abar * e;
  return e / phi * (-h + (g + h) / phi);
}

}  // namespace odoerr
