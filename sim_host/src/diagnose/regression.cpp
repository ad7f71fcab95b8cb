#include "regression.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include <boost/math/distributions/normal.hpp>

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
  const int p = static_cast<int>(c.size());
  if (p == 0) {  // no column (no nuisance, nothing selected): nothing to estimate
    beta->resize(0);
    sigma->resize(0);
    return true;
  }
  const Eigen::MatrixXd g = subM(f.all.g, c);
  if (!solve(g, subV(f.all.b, c), beta)) return false;
  const int nc = d.cluster.empty() ? 0 : *std::max_element(d.cluster.begin(), d.cluster.end()) + 1;
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

int foldOfTime(double t, double block_s, int folds) {
  const double b = std::floor(t / block_s);
  return folds > 0 && std::isfinite(b) && b >= 0 ? static_cast<int>(std::fmod(b, double(folds))) : 0;
}

int TimeClusters::operator()(double t) {
  const double g = std::floor(t / stretch_s_);
  if (n_ == 0 || g > last_) {
    last_ = g;
    ++n_;
  }
  return n_ - 1;
}

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

std::vector<double> minDetectableCoefs(const Design& d, const SelectOptions& opt, double power,
                                       std::vector<double>* sigma) {
  const int p = static_cast<int>(d.x.cols());
  const int n_cand = std::max(0, p - d.n_nuisance);
  std::vector<double> out(static_cast<std::size_t>(n_cand), std::numeric_limits<double>::quiet_NaN());
  if (sigma != nullptr) sigma->assign(out.size(), std::numeric_limits<double>::quiet_NaN());
  if (d.x.rows() == 0 || n_cand == 0) return out;
  const Folds f = gramsOf(d);
  const double sse0 = cvSse(f, columnsOf(d, {}));
  // The normal quantile of `power`: |Z + mu| > z_min with probability `power` for mu about
  // z_min + z_power (the far tail is negligible at z_min = 4.5).
  const double z_power = boost::math::quantile(boost::math::normal_distribution<double>(), power);
  for (int j = d.n_nuisance; j < p; ++j) {
    const std::vector<int> c = columnsOf(d, {j});
    Eigen::VectorXd beta, sig;
    if (!robustFit(d, f, c, &beta, &sig)) continue;
    const double s = sig[sig.size() - 1];
    // |x_j|^2 beyond the nuisance columns: 1 / (G^-1)_jj.
    const Eigen::MatrixXd g = subM(f.all.g, c);
    const double gjj = g.ldlt().solve(Eigen::VectorXd::Unit(g.rows(), g.rows() - 1))[g.rows() - 1];
    if (!(s > 0) || !(gjj > 0) || !std::isfinite(s) || !std::isfinite(gjj)) continue;
    const double by_z = s * (opt.z_min + z_power);
    const double by_gain = std::isfinite(sse0) ? std::sqrt(opt.min_gain * sse0 * gjj) : 0.0;
    out[static_cast<std::size_t>(j - d.n_nuisance)] = std::max(by_z, by_gain);
    if (sigma != nullptr) (*sigma)[static_cast<std::size_t>(j - d.n_nuisance)] = s;
  }
  return out;
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

}  // namespace

namespace {

/// The sup over the splits of the change's cluster-robust Wald statistic, from the
/// clusters' sufficient statistics: n_c = X_c'X_c and the response's part beyond the
/// no-change fit, X_c'u_c, each cluster's taken w_c times (w = 1: the data; w = +-1 at
/// random: a wild cluster bootstrap draw under no change). stat[k] is split k's.
double supWald(const std::vector<Eigen::MatrixXd>& nc, const std::vector<Eigen::VectorXd>& hc,
               const std::vector<int>& splits, const std::vector<double>& w, std::vector<double>* stat) {
  const int p = static_cast<int>(hc.front().size());
  const int c = static_cast<int>(nc.size());
  Eigen::MatrixXd n_all = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd h_all = Eigen::VectorXd::Zero(p);
  for (int k = 0; k < c; ++k) {
    n_all += nc[static_cast<std::size_t>(k)];
    h_all += w[static_cast<std::size_t>(k)] * hc[static_cast<std::size_t>(k)];
  }
  double best = 0;
  if (stat != nullptr) stat->assign(splits.size(), 0.0);
  for (std::size_t s = 0; s < splits.size(); ++s) {
    const int m = splits[s];
    Eigen::MatrixXd n_after = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd h_after = Eigen::VectorXd::Zero(p);
    for (int k = m; k < c; ++k) {
      n_after += nc[static_cast<std::size_t>(k)];
      h_after += w[static_cast<std::size_t>(k)] * hc[static_cast<std::size_t>(k)];
    }
    // [beta1 - beta0; delta] from the normal equations of [N, N 1(after)]
    Eigen::MatrixXd g(2 * p, 2 * p);
    g << n_all, n_after, n_after, n_after;
    Eigen::VectorXd rhs(2 * p);
    rhs << h_all, h_after;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(g);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) continue;
    const Eigen::VectorXd z = ldlt.solve(rhs);
    const Eigen::VectorXd d1 = z.head(p), delta = z.tail(p);
    Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(2 * p, 2 * p);
    for (int k = 0; k < c; ++k) {
      const Eigen::MatrixXd& nk = nc[static_cast<std::size_t>(k)];
      const Eigen::VectorXd gk = w[static_cast<std::size_t>(k)] * hc[static_cast<std::size_t>(k)] -
                                 nk * (k < m ? d1 : Eigen::VectorXd(d1 + delta));
      Eigen::VectorXd sk(2 * p);
      sk << gk, (k < m ? Eigen::VectorXd::Zero(p) : gk);
      meat += sk * sk.transpose();
    }
    const Eigen::MatrixXd gi = ldlt.solve(Eigen::MatrixXd::Identity(2 * p, 2 * p));
    const Eigen::MatrixXd v = double(c) / double(c - 1) * gi * meat * gi;
    const Eigen::LDLT<Eigen::MatrixXd> vl(v.bottomRightCorner(p, p));
    if (vl.info() != Eigen::Success || !vl.isPositive()) continue;
    const double st = delta.dot(vl.solve(delta));
    if (!std::isfinite(st)) continue;
    if (stat != nullptr) (*stat)[s] = st;
    best = std::max(best, st);
  }
  return best;
}

}  // namespace

ChangePoint scanChange(const Design& d, double drop) {
  ChangePoint cp;
  const int p = d.n_nuisance;
  const Eigen::Index n = d.x.rows();
  const int c = d.cluster.empty() ? 0 : *std::max_element(d.cluster.begin(), d.cluster.end()) + 1;
  if (p == 0 || n < 20 * p || c < 8) return cp;
  // The no-change fit and each cluster's sufficient statistics. Clusters are consecutive
  // stretches of time; a change is looked for at their boundaries.
  Gram all(p);
  for (Eigen::Index i = 0; i < n; ++i) all.add(d.x.row(i).head(p), d.y[i]);
  Eigen::VectorXd b0;
  if (!solve(all.g, all.b, &b0)) return cp;
  std::vector<Eigen::MatrixXd> nc(static_cast<std::size_t>(c), Eigen::MatrixXd::Zero(p, p));
  std::vector<Eigen::VectorXd> hc(static_cast<std::size_t>(c), Eigen::VectorXd::Zero(p));
  std::vector<double> t_min(static_cast<std::size_t>(c), std::numeric_limits<double>::infinity());
  std::vector<long> rows(static_cast<std::size_t>(c), 0);
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::size_t k = static_cast<std::size_t>(d.cluster[static_cast<std::size_t>(i)]);
    const Eigen::RowVectorXd x = d.x.row(i).head(p);
    nc[k] += x.transpose() * x;
    hc[k] += x.transpose() * (d.y[i] - x.dot(b0));
    t_min[k] = std::min(t_min[k], d.t[i]);
    ++rows[k];
  }
  // splits at cluster boundaries with 15 % to 85 % of the rows before them
  std::vector<int> splits;
  long before = 0;
  for (int k = 0; k < c; ++k) {
    if (k > 0 && rows[static_cast<std::size_t>(k)] > 0 && before >= n * 15 / 100 && before <= n * 85 / 100)
      splits.push_back(k);
    before += rows[static_cast<std::size_t>(k)];
  }
  if (splits.empty()) return cp;
  std::vector<double> stat;
  cp.stat = supWald(nc, hc, splits, std::vector<double>(static_cast<std::size_t>(c), 1.0), &stat);
  // Its null distribution by a wild cluster bootstrap (Rademacher signs per cluster, no
  // change imposed): the clustered Wald statistic over a few dozen clusters is far from its
  // chi-square limit (the limit's 0.1 % value let 3 of 40 stationary series through).
  constexpr int kDraws = 999;
  std::mt19937_64 rng(20261125);
  std::bernoulli_distribution coin(0.5);
  std::vector<double> w(static_cast<std::size_t>(c));
  int exceed = 0;
  std::vector<double> sups;
  for (int b = 0; b < kDraws; ++b) {
    for (double& x : w) x = coin(rng) ? 1.0 : -1.0;
    const double sb = supWald(nc, hc, splits, w, nullptr);
    sups.push_back(sb);
    exceed += sb >= cp.stat ? 1 : 0;
  }
  std::sort(sups.begin(), sups.end());
  cp.threshold = sups[static_cast<std::size_t>(kDraws * 999 / 1000)];
  cp.p_value = double(1 + exceed) / double(kDraws + 1);
  std::size_t best = 0;
  for (std::size_t s = 1; s < stat.size(); ++s)
    if (stat[s] > stat[best]) best = s;
  cp.t = t_min[static_cast<std::size_t>(splits[best])];
  cp.t_lo = cp.t_hi = cp.t;
  for (std::size_t s = 0; s < stat.size(); ++s) {
    if (stat[s] >= cp.stat - drop) {
      cp.t_lo = std::min(cp.t_lo, t_min[static_cast<std::size_t>(splits[s])]);
      cp.t_hi = std::max(cp.t_hi, t_min[static_cast<std::size_t>(splits[s])]);
    }
  }
  // the coefficients on each side at the best split
  Gram pre(p), post(p);
  for (Eigen::Index i = 0; i < n; ++i)
    (d.cluster[static_cast<std::size_t>(i)] < splits[best] ? pre : post).add(d.x.row(i).head(p), d.y[i]);
  Eigen::VectorXd b1, b2;
  if (solve(pre.g, pre.b, &b1) && solve(post.g, post.b, &b2)) {
    cp.before.assign(b1.data(), b1.data() + p);
    cp.after.assign(b2.data(), b2.data() + p);
  }
  cp.found = cp.p_value <= kChangeAlpha && !cp.before.empty();
  return cp;
}

}  // namespace odoerr::sim::diag
