#include "regression.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace odoerr::sim::diag {

namespace {

/// Sufficient statistics of a set of rows: X'X, X'y, y'y.
struct Gram {
  Eigen::MatrixXd g;
  Eigen::VectorXd b;
  double yy = 0;
  explicit Gram(int p = 0) : g(Eigen::MatrixXd::Zero(p, p)), b(Eigen::VectorXd::Zero(p)) {}
  void add(const Eigen::RowVectorXd& x, double y) {
    g.noalias() += x.transpose() * x;
    b.noalias() += x.transpose() * y;
    yy += y * y;
  }
};

std::vector<int> columnsOf(const Design& d, const std::vector<int>& terms) {
  std::vector<int> c(static_cast<std::size_t>(d.n_nuisance));
  std::iota(c.begin(), c.end(), 0);
  c.insert(c.end(), terms.begin(), terms.end());
  return c;
}

Eigen::MatrixXd subM(const Eigen::MatrixXd& g, const std::vector<int>& c) {
  Eigen::MatrixXd s(c.size(), c.size());
  for (std::size_t i = 0; i < c.size(); ++i)
    for (std::size_t j = 0; j < c.size(); ++j) s(i, j) = g(c[i], c[j]);
  return s;
}
Eigen::VectorXd subV(const Eigen::VectorXd& b, const std::vector<int>& c) {
  Eigen::VectorXd s(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) s[i] = b[c[i]];
  return s;
}

/// Least squares from a Gram; false when the columns are (nearly) dependent.
bool solve(const Eigen::MatrixXd& g, const Eigen::VectorXd& b, Eigen::VectorXd* beta) {
  if (g.rows() == 0) {
    *beta = Eigen::VectorXd();
    return true;
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(g);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
  const Eigen::VectorXd d = ldlt.vectorD();
  if (d.minCoeff() <= 1e-12 * std::max(1e-300, d.maxCoeff())) return false;
  *beta = ldlt.solve(b);
  return beta->allFinite();
}

struct Folds {
  std::vector<Gram> fold;
  Gram all;
};

Folds gramsOf(const Design& d) {
  const int p = static_cast<int>(d.x.cols());
  Folds f{std::vector<Gram>(static_cast<std::size_t>(d.folds), Gram(p)), Gram(p)};
  for (Eigen::Index i = 0; i < d.x.rows(); ++i) {
    f.fold[static_cast<std::size_t>(d.fold[static_cast<std::size_t>(i)])].add(d.x.row(i), d.y[i]);
  }
  for (const Gram& g : f.fold) {
    f.all.g += g.g;
    f.all.b += g.b;
    f.all.yy += g.yy;
  }
  return f;
}

/// Cross-validated SSE over the folds for the columns c (infinite when a fold's fit is
/// singular).
double cvSse(const Folds& f, const std::vector<int>& c) {
  double sse = 0;
  for (const Gram& k : f.fold) {
    if (k.yy == 0 && k.b.isZero()) continue;  // an empty fold
    Eigen::VectorXd beta;
    if (!solve(subM(f.all.g - k.g, c), subV(f.all.b - k.b, c), &beta)) return std::numeric_limits<double>::infinity();
    const Eigen::VectorXd bk = subV(k.b, c);
    sse += k.yy - 2 * beta.dot(bk) + beta.dot(subM(k.g, c) * beta);
  }
  return sse;
}

/// Full-data fit of columns c with cluster-robust (sandwich) standard errors.
bool robustFit(const Design& d, const Folds& f, const std::vector<int>& c, Eigen::VectorXd* beta,
               Eigen::VectorXd* sigma) {
  const Eigen::MatrixXd g = subM(f.all.g, c);
  if (!solve(g, subV(f.all.b, c), beta)) return false;
  const int nc = d.cluster.empty() ? 0 : *std::max_element(d.cluster.begin(), d.cluster.end()) + 1;
  const int p = static_cast<int>(c.size());
  Eigen::MatrixXd score = Eigen::MatrixXd::Zero(std::max(1, nc), p);
  for (Eigen::Index i = 0; i < d.x.rows(); ++i) {
    double u = d.y[i];
    Eigen::RowVectorXd xi(p);
    for (int j = 0; j < p; ++j) xi[j] = d.x(i, c[static_cast<std::size_t>(j)]);
    u -= xi.dot(*beta);
    score.row(d.cluster[static_cast<std::size_t>(i)]) += xi * u;
  }
  const Eigen::MatrixXd gi = g.ldlt().solve(Eigen::MatrixXd::Identity(p, p));
  const double small = nc > 1 ? double(nc) / double(nc - 1) : 1.0;
  const Eigen::MatrixXd v = small * gi * (score.transpose() * score) * gi;
  *sigma = v.diagonal().cwiseMax(0.0).cwiseSqrt();
  return true;
}

/// The full-data fit of a selection's terms: coefficients and cluster-robust sigmas.
void fillFit(const Design& d, const Folds& f, Selection* s) {
  Eigen::VectorXd beta, sig;
  if (!robustFit(d, f, columnsOf(d, s->terms), &beta, &sig)) return;
  for (int i = 0; i < d.n_nuisance; ++i) s->nuisance.push_back(beta[i]);
  for (std::size_t k = 0; k < s->terms.size(); ++k) {
    s->coef.push_back(beta[d.n_nuisance + static_cast<Eigen::Index>(k)]);
    s->sigma.push_back(sig[d.n_nuisance + static_cast<Eigen::Index>(k)]);
  }
}

}  // namespace

double crossValidatedSse(const Design& d, const std::vector<int>& terms) {
  return cvSse(gramsOf(d), columnsOf(d, terms));
}

Selection forwardSelect(const Design& d, const SelectOptions& opt) {
  Selection s;
  s.rows = static_cast<int>(d.x.rows());
  const Folds f = gramsOf(d);
  s.sse_total = f.all.yy;
  s.sse_cv_nuisance = cvSse(f, columnsOf(d, {}));
  s.sse_cv = s.sse_cv_nuisance;
  if (!std::isfinite(s.sse_cv_nuisance) || s.rows == 0) return s;
  const int p = static_cast<int>(d.x.cols());
  for (int step = 0; step < opt.max_terms; ++step) {
    std::vector<std::pair<double, int>> gains;  // cross-validated SSE with the candidate added
    for (int j = d.n_nuisance; j < p; ++j) {
      if (std::find(s.terms.begin(), s.terms.end(), j) != s.terms.end()) continue;
      std::vector<int> t = s.terms;
      t.push_back(j);
      const double sse = cvSse(f, columnsOf(d, t));
      if (std::isfinite(sse) && sse < s.sse_cv) gains.push_back({sse, j});
    }
    std::sort(gains.begin(), gains.end());
    bool added = false;
    // The best few by cross-validated gain, each tested on its robust z: the first that
    // passes both is kept (a candidate the folds like but whose estimate is not clear of
    // zero against its clustered sigma is not).
    for (std::size_t k = 0; k < gains.size() && k < 5; ++k) {
      const auto [sse, j] = gains[k];
      if ((s.sse_cv - sse) < opt.min_gain * s.sse_cv_nuisance) break;
      std::vector<int> t = s.terms;
      t.push_back(j);
      Eigen::VectorXd beta, sig;
      if (!robustFit(d, f, columnsOf(d, t), &beta, &sig)) continue;
      const double z = std::abs(beta[beta.size() - 1]) / std::max(1e-300, sig[sig.size() - 1]);
      if (!(z >= opt.z_min)) continue;
      s.terms = t;
      s.sse_cv = sse;
      added = true;
      break;
    }
    if (!added) break;
  }
  fillFit(d, f, &s);
  return s;
}

Selection fitTerms(const Design& d, const std::vector<int>& terms) {
  Selection s;
  s.rows = static_cast<int>(d.x.rows());
  const Folds f = gramsOf(d);
  s.sse_total = f.all.yy;
  s.sse_cv_nuisance = cvSse(f, columnsOf(d, {}));
  s.terms = terms;
  s.sse_cv = cvSse(f, columnsOf(d, terms));
  fillFit(d, f, &s);
  return s;
}

namespace {

/// The 1 % critical value of Andrews' sup-Wald statistic for p parameters, 15 % trimming,
/// by simulation of its limit (a sum of p squared tied-down Brownian bridges over
/// tau (1 - tau)); a fixed seed, so it is the same number every run.
double supWaldCritical(int p) {
  constexpr int kSims = 4000, kGrid = 400;
  std::mt19937_64 rng(12345 + static_cast<unsigned>(p));
  std::normal_distribution<double> n01;
  std::vector<double> sup(kSims);
  std::vector<double> w(static_cast<std::size_t>(p) * (kGrid + 1));
  for (int s = 0; s < kSims; ++s) {
    for (int j = 0; j < p; ++j) {
      double acc = 0;
      w[static_cast<std::size_t>(j) * (kGrid + 1)] = 0;
      for (int i = 1; i <= kGrid; ++i) {
        acc += n01(rng) / std::sqrt(double(kGrid));
        w[static_cast<std::size_t>(j) * (kGrid + 1) + static_cast<std::size_t>(i)] = acc;
      }
    }
    double best = 0;
    for (int i = kGrid * 15 / 100; i <= kGrid * 85 / 100; ++i) {
      const double tau = double(i) / kGrid;
      double stat = 0;
      for (int j = 0; j < p; ++j) {
        const double* wj = &w[static_cast<std::size_t>(j) * (kGrid + 1)];
        const double b = wj[i] - tau * wj[kGrid];
        stat += b * b / (tau * (1 - tau));
      }
      best = std::max(best, stat);
    }
    sup[static_cast<std::size_t>(s)] = best;
  }
  std::sort(sup.begin(), sup.end());
  return sup[static_cast<std::size_t>(kSims * 99 / 100)];
}

}  // namespace

ChangePoint scanChange(const Design& d, double drop) {
  ChangePoint cp;
  const int p = d.n_nuisance;
  const Eigen::Index n = d.x.rows();
  if (p == 0 || n < 20 * p) return cp;
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), Eigen::Index(0));
  std::stable_sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) { return d.t[a] < d.t[b]; });
  Gram all(p);
  for (Eigen::Index i = 0; i < n; ++i) all.add(d.x.row(i).head(p), d.y[i]);
  Eigen::VectorXd b_all;
  if (!solve(all.g, all.b, &b_all)) return cp;
  const double sse0 = all.yy - b_all.dot(all.b);
  // Long-run variance of the full fit's residuals in time order (Bartlett weights): the
  // segment residuals share their end poses, so neighbours correlate.
  std::vector<double> u(static_cast<std::size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index i = order[static_cast<std::size_t>(k)];
    u[static_cast<std::size_t>(k)] = d.y[i] - d.x.row(i).head(p).dot(b_all);
  }
  const int lags = static_cast<int>(std::ceil(4 * std::pow(double(n) / 100.0, 2.0 / 9.0)));
  double g0 = 0;
  for (double v : u) g0 += v * v;
  double lr = g0;
  for (int l = 1; l <= lags; ++l) {
    double gl = 0;
    for (std::size_t k = static_cast<std::size_t>(l); k < u.size(); ++k) gl += u[k] * u[k - static_cast<std::size_t>(l)];
    lr += 2 * (1 - double(l) / (lags + 1)) * gl;
  }
  const double inflation = std::max(1.0, lr / std::max(1e-300, g0));
  // Scan: prefix sums in time order, a split every few rows inside the trimmed range.
  Gram pre(p);
  std::vector<std::pair<double, double>> stat_at;  // (tau, statistic)
  std::vector<std::pair<Eigen::VectorXd, Eigen::VectorXd>> coefs;
  const Eigen::Index lo = n * 15 / 100, hi = n * 85 / 100, step = std::max<Eigen::Index>(1, n / 400);
  double best = -1, sse1_best = sse0;
  Eigen::Index last_split = -step;
  for (Eigen::Index k = 0; k < hi; ++k) {
    const Eigen::Index i = order[static_cast<std::size_t>(k)];
    pre.add(d.x.row(i).head(p), d.y[i]);
    // a split between rows of the same time is no split; splits at least `step` rows apart
    if (k + 1 < lo || k + 1 - last_split < step) continue;
    if (k + 1 < n && d.t[order[static_cast<std::size_t>(k + 1)]] == d.t[i]) continue;
    last_split = k + 1;
    Gram post(p);
    post.g = all.g - pre.g;
    post.b = all.b - pre.b;
    post.yy = all.yy - pre.yy;
    Eigen::VectorXd b1, b2;
    if (!solve(pre.g, pre.b, &b1) || !solve(post.g, post.b, &b2)) continue;
    const double sse1 = pre.yy - b1.dot(pre.b) + post.yy - b2.dot(post.b);
    stat_at.push_back({d.t[i], sse1});
    coefs.push_back({b1, b2});
    if (best < 0 || sse1 < sse1_best) {
      sse1_best = sse1;
      best = double(stat_at.size() - 1);
    }
  }
  if (stat_at.empty()) return cp;
  const double sigma2 = sse1_best / std::max(1.0, double(n - 2 * p)) * inflation;
  for (auto& [tau, s] : stat_at) s = (sse0 - s) / sigma2;
  const std::size_t b = static_cast<std::size_t>(best);
  cp.stat = stat_at[b].second;
  cp.threshold = supWaldCritical(p);
  cp.t = stat_at[b].first;
  cp.t_lo = cp.t_hi = cp.t;
  for (const auto& [tau, s] : stat_at) {
    if (s >= cp.stat - drop) {
      cp.t_lo = std::min(cp.t_lo, tau);
      cp.t_hi = std::max(cp.t_hi, tau);
    }
  }
  cp.before.assign(coefs[b].first.data(), coefs[b].first.data() + p);
  cp.after.assign(coefs[b].second.data(), coefs[b].second.data() + p);
  cp.found = cp.stat > cp.threshold;
  return cp;
}

}  // namespace odoerr::sim::diag
