// diagnose, sparse regression of residuals on candidate features: forward selection
// cross-validated over time blocks, with cluster-robust standard errors, and a
// likelihood-ratio scan for one abrupt change of the coefficients. Generic (a design
// matrix with named columns); discovery.cpp builds the designs from the filter's
// residuals. docs/diagnostics.md ("Discovery") states the rules.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Dense>

namespace odoerr::sim::diag {

/// A regression problem. Columns [0, n_nuisance) are always in the model (what the model
/// already estimates, e.g. the wheel scales); the rest are candidates.
struct Design {
  Eigen::MatrixXd x;          ///< rows x columns
  Eigen::VectorXd y;          ///< one response per row
  Eigen::VectorXd t;          ///< each row's time (s), for the change-point scan
  std::vector<int> fold;      ///< cross-validation fold of each row (0..folds-1)
  std::vector<int> cluster;   ///< cluster of each row (rows whose errors may correlate), 0..
  int folds = 4;
  int n_nuisance = 0;
};

struct SelectOptions {
  int max_terms = 3;          ///< candidates selected at most
  double z_min = 4.5;         ///< |coef / cluster-robust sigma| a candidate needs
  double min_gain = 0.01;     ///< relative fall of the cross-validated SSE a candidate needs
};

struct Selection {
  std::vector<int> terms;        ///< selected candidate columns, in the order chosen
  std::vector<double> coef;      ///< per selected term
  std::vector<double> sigma;     ///< cluster-robust
  std::vector<double> nuisance;  ///< the nuisance coefficients of the final fit
  double sse_cv_nuisance = 0;    ///< cross-validated SSE with the nuisance columns only
  double sse_cv = 0;             ///< with the selected terms too
  double sse_total = 0;          ///< sum of y^2 (the residual before any fit)
  int rows = 0;
  /// The share of the cross-validated misfit (nuisance-only) that the terms explain.
  double explained() const { return sse_cv_nuisance > 0 ? 1.0 - sse_cv / sse_cv_nuisance : 0.0; }
};

/// The cross-validation fold of a row `t` s after the start: its block of `block_s`, modulo
/// `folds` (in floating point, so any time is safe; before the start or not a number: 0).
int foldOfTime(double t, double block_s, int folds);

/// The clusters of rows that come in time order: the stretches of `stretch_s` (from the
/// start) that hold a row, numbered 0, 1, ... in time order. A pause in the log makes no empty
/// cluster, so the robust fits and the change-point scan cost what the rows do, and count
/// the clusters that hold data, whatever time the rows span.
class TimeClusters {
 public:
  explicit TimeClusters(double stretch_s) : stretch_s_(stretch_s) {}
  /// The cluster of the next row, `t` s after the start (t not before the previous row's).
  int operator()(double t);

 private:
  double stretch_s_, last_ = 0;
  int n_ = 0;
};

/// Forward selection: at each step the candidate that lowers the cross-validated SSE most,
/// kept when its cluster-robust z and its gain pass the thresholds.
Selection forwardSelect(const Design& d, const SelectOptions& opt);

/// The model with the nuisance columns and exactly `terms`: its coefficients, sigmas and
/// cross-validated SSE (no selection).
Selection fitTerms(const Design& d, const std::vector<int>& terms);

/// Cross-validated SSE of the model with the nuisance columns and `terms`.
double crossValidatedSse(const Design& d, const std::vector<int>& terms);

/// The smallest coefficient of each candidate column (index j - n_nuisance) that
/// forwardSelect would keep as a first term with probability about `power`: its robust z
/// must pass opt.z_min, so the coefficient must reach sigma_j (z_min + z_power), and its fall
/// of the cross-validated SSE opt.min_gain of the nuisance-only SSE, beta^2 |x_j|^2 with x_j
/// the column beyond the nuisance columns. sigma_j: the cluster-robust sigma of the column
/// fitted alone beside the nuisance columns. NaN for a column the rows do not determine (zero
/// or dependent on the nuisance columns). sigma (may be null) receives the sigma_j.
std::vector<double> minDetectableCoefs(const Design& d, const SelectOptions& opt, double power,
                                       std::vector<double>* sigma);

/// The level of the change-point test.
constexpr double kChangeAlpha = 0.002;

struct ChangePoint {
  bool found = false;
  double t = 0, t_lo = 0, t_hi = 0;  ///< the most likely time and its interval
  double stat = 0;                   ///< the sup statistic
  double threshold = 0;              ///< its bootstrap 0.1 % critical value
  double p_value = 1;                ///< its bootstrap p-value
  std::vector<double> before, after; ///< the nuisance coefficients on each side
};

/// A scan for one change of the nuisance coefficients at a cluster boundary: at each
/// split the Wald statistic of the change with a cluster-robust covariance, its sup over
/// the splits with 15 % to 85 % of the rows before them (Andrews' sup-Wald), its p-value by
/// a wild cluster bootstrap (999 draws, fixed seed), found when p <= kChangeAlpha. The
/// interval is the set of split times whose statistic is within `drop` of the maximum.
ChangePoint scanChange(const Design& d, double drop = 7.7);

}  // namespace odoerr::sim::diag
