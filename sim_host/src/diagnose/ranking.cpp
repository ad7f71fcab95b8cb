#include "ranking.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace odoerr::sim::diag {

namespace {
using json = nlohmann::ordered_json;
constexpr double kInformed = 0.7;    // a parameter is informed when the drive shrinks its prior sigma below this
}  // namespace

// A noise effect competes with K for the same variance, and the K the OF gives has
// absorbed that noise where the effect is real: so its profile is two-dimensional. At
// each q the likelihood is maximised over a K multiplier (steps of 1.25, extended while
// the best is at an edge); a coarse q grid finds the region and two more points (half and
// twice the best q) refine it. The likelihood ratio compares the best q > 0 with q = 0.
template <template <typename> class DriveT>
std::array<double, 4> Ranking<DriveT>::profileAtQ(const RunSpec& ref, int e, double q) const {
  const auto& fx = en_.effects();
  constexpr int kE = En::kE;
  const En& en = en_;
  std::map<int, double> ll;  // K multiplier 1.25^i -> log-likelihood
  auto at = [&](int i) {
    if (ll.count(i) == 0) {
      RunSpec s = ref;
      s.k = ref.k * std::pow(1.25, i);
      s.eff_val[fx[e].offset - kE] = q;
      ll[i] = en.run(s).loglik;
    }
    return ll[i];
  };
  int lo = -1, hi = 1, best = 0;
  for (int i = lo; i <= hi; ++i) at(i);
  for (;;) {
    best = lo;
    for (int i = lo; i <= hi; ++i)
      if (ll[i] > ll[best]) best = i;
    if (best == lo && lo > -8) at(--lo);
    else if (best == hi && hi < 6) at(++hi);
    else break;
  }
  double peak = ll[best];
  if (best > lo && best < hi) {
    const double y0 = ll[best - 1], y1 = ll[best], y2 = ll[best + 1];
    const double curv = y0 - 2 * y1 + y2;
    if (curv < 0) peak = y1 - (y0 - y2) * (y0 - y2) / (8 * curv);
  }
  return std::array<double, 4>{q, ll[best], std::pow(1.25, best), peak};
}

// Every candidate scored against a reference spec: an augmented run (its parameters join
// the state) gives the estimate and the sigma the drive achieves; a held run (the
// parameters fixed at the informed estimates) gives the profile likelihood. A noise effect
// cannot be augmented: its profile is taken over a grid, with the OF free in every run (K
// and the noise effect compete for the same variance).
template <template <typename> class DriveT>
void Ranking<DriveT>::augmentTasks(const RunSpec& ref, double ll_ref, int e, Candidate* c, RunOut* aug,
                                   Tasks* tasks) const {
  const auto& fx = en_.effects();
  c->ll_ref = ll_ref;
  if (fx[e].kind == EffectKind::kNoise) {
    c->profile.assign(4, {});
    for (int g = 0; g < 4; ++g)
      tasks->push_back([this, ref, e, g, c] { c->profile[g] = profileAtQ(ref, e, kNoiseGrid[g] * en_.effects()[e].ref[0]); });
    return;
  }
  tasks->push_back([this, ref, e, aug] {
    RunSpec s = ref;
    en_.freeEffect(&s, e);
    *aug = en_.run(s);
  });
}

// After the augmented runs: estimates, informed parameters, and the held run's task.
template <template <typename> class DriveT>
void Ranking<DriveT>::heldTasks(const RunSpec& ref, int e, Candidate* c, const RunOut& aug, Tasks* tasks) const {
  const auto& fx = en_.effects();
  constexpr int kE = En::kE;
  const EffectInfo& f = fx[e];
  c->est = Eigen::VectorXd::Zero(f.n);
  c->sig = Eigen::VectorXd::Zero(f.n);
  c->informed.assign(f.n, false);
  if (f.kind == EffectKind::kNoise) {
    tasks->push_back([this, ref, e, c] {
      const EffectInfo& fe = en_.effects()[e];
      auto argmax = [&] {
        std::size_t b = 0;
        for (std::size_t g = 1; g < c->profile.size(); ++g)
          if (c->profile[g][1] > c->profile[b][1]) b = g;
        return b;
      };
      const double qb = c->profile[argmax()][0];
      if (qb > 0) {  // refine: half and twice the best q
        c->profile.push_back(profileAtQ(ref, e, 0.5 * qb));
        c->profile.push_back(profileAtQ(ref, e, 2.0 * qb));
      }
      std::sort(c->profile.begin(), c->profile.end(), [](const auto& x, const auto& y) { return x[0] < y[0]; });
      const std::size_t b = argmax();
      c->ll = c->profile[b][1];
      c->k_mult = c->profile[b][2];
      c->q_best = c->profile[b][0];
      // The profile is not smooth (gating decisions flip as q and K change), so a
      // least-squares quadratic through every point (the peaks over K) gives the estimate,
      // and its sigma adds the fit's own uncertainty (delta method, the points' scatter)
      // to the curvature's. The test uses the fitted gain, not the best point's: the
      // largest of several jagged values is biased up.
      double q = c->profile[b][0], sq = fe.prior[0], gain = 0;
      const int np = static_cast<int>(c->profile.size());
      const double scale = fe.ref[0];
      Eigen::MatrixXd a(np, 3);
      Eigen::VectorXd y(np);
      for (int i = 0; i < np; ++i) {
        const double u = c->profile[i][0] / scale;
        a.row(i) << 1.0, u, u * u;
        y[i] = c->profile[i][3];
      }
      if (np >= 4) {
        const Eigen::Matrix3d ata = a.transpose() * a;
        const auto ldlt = ata.ldlt();
        const Eigen::Vector3d co = ldlt.solve(a.transpose() * y);
        if (ldlt.info() == Eigen::Success && ldlt.isPositive() && co[2] < 0) {
          const double u_max = c->profile.back()[0] / scale;
          const double u = std::clamp(-co[1] / (2 * co[2]), 0.0, u_max);
          const Eigen::VectorXd r = y - a * co;
          const double s2 = r.squaredNorm() / std::max(1, np - 3);
          const Eigen::Matrix3d cov = s2 * ldlt.solve(Eigen::Matrix3d::Identity());
          const Eigen::Vector3d g(0, -1 / (2 * co[2]), co[1] / (2 * co[2] * co[2]));
          const double var_fit = g.dot(cov * g), var_stat = -1 / (2 * co[2]);
          q = u * scale;
          sq = std::sqrt(var_stat + var_fit) * scale;
          gain = std::max(0.0, co[1] * u + co[2] * u * u);
        }
      }
      c->ll_ref = c->ll - gain;
      c->est[0] = q;
      c->sig[0] = sq;
      c->informed[0] = q > 0 && sq < kInformed * fe.prior[0];
      c->k = c->informed[0] ? 1 : 0;
      c->wald = c->k > 0 ? (q / sq) * (q / sq) : 0.0;
    });
    return;
  }
  for (int i = 0; i < f.n; ++i) {
    const int k = f.offset + i;
    c->est[i] = aug.x[k];
    c->sig[i] = std::sqrt(std::max(0.0, aug.p(k, k)));
    c->informed[i] = c->sig[i] < kInformed * f.prior[i];
    c->k += c->informed[i] ? 1 : 0;
  }
  // Wald statistic of the informed parameters: their estimate against their joint
  // covariance in the augmented run.
  if (c->k > 0) {
    std::vector<int> idx;
    for (int i = 0; i < f.n; ++i)
      if (c->informed[i]) idx.push_back(i);
    Eigen::VectorXd v(idx.size());
    Eigen::MatrixXd pv(idx.size(), idx.size());
    for (std::size_t a = 0; a < idx.size(); ++a) {
      v[a] = c->est[idx[a]];
      for (std::size_t b = 0; b < idx.size(); ++b) pv(a, b) = aug.p(f.offset + idx[a], f.offset + idx[b]);
    }
    const auto ldlt = pv.ldlt();
    c->wald = ldlt.info() == Eigen::Success && ldlt.isPositive() ? std::max(0.0, v.dot(ldlt.solve(v))) : 0.0;
  }
  c->ll = c->ll_ref;
  if (c->k == 0) return;
  tasks->push_back([this, ref, e, c] {
    const EffectInfo& fe = en_.effects()[e];
    RunSpec s = ref;
    for (int i = 0; i < fe.n; ++i)
      if (c->informed[i]) s.eff_val[fe.offset - kE + i] = c->est[i];
    c->ll = en_.run(s).loglik;
  });
}

// Ranking: by p-value of the profile likelihood ratio with k informed parameters.
template <template <typename> class DriveT>
bool Ranking<DriveT>::test(const Candidate& c, RankRow* r) const {
  const double ln_n = ln_n_;
  r->k = c.k;
  r->dll = c.ll - c.ll_ref;
  r->lr = std::max(0.0, 2 * r->dll);
  r->bic = r->lr - r->k * ln_n;
  r->p = r->k > 0 ? chiSquareSf(r->lr, r->k) : 1.0;
  r->wald_p = r->k > 0 ? chiSquareSf(c.wald, r->k) : 1.0;
  // Both tests must agree. The likelihood is not smooth (gating decisions flip between
  // runs, by tens of log-likelihood units), so the ratio alone took such jumps for
  // evidence on clean drives; the Wald test asks whether the estimate itself stands
  // clear of zero against its own sigma.
  return r->k > 0 && r->p < kRankAlphaLr && r->bic > 0 && r->wald_p < kRankAlphaWald;
}

// Conditional tests: each of `others` scored against a reference that has `given` in the
// model at its estimate (a noise effect with its K multiplier too).
template <template <typename> class DriveT>
std::vector<RankRow> Ranking<DriveT>::conditional(int given, const std::vector<int>& others) const {
  const int ne = static_cast<int>(en_.effects().size());
  const std::vector<Candidate>& cand = cand_;
  Tasks tasks;
  const RunSpec ref1 = heldAt({given});
  std::vector<Candidate> c2(ne);
  std::vector<RunOut> aug2(ne);
  for (int e : others) augmentTasks(ref1, cand[given].ll, e, &c2[e], &aug2[e], &tasks);
  runParallel(tasks, threads_);
  tasks.clear();
  for (int e : others) heldTasks(ref1, e, &c2[e], aug2[e], &tasks);
  runParallel(tasks, threads_);
  tasks.clear();
  std::vector<RankRow> res(ne);
  for (int e : others) {
    res[e] = RankRow{e, 0, 0, 0, 1, 0, false, false, -1, 1, {}};
    res[e].significant = test(c2[e], &res[e]);
  }
  return res;
}

template <template <typename> class DriveT>
typename Ranking<DriveT>::RunSpec Ranking<DriveT>::heldAt(const std::vector<int>& given) const {
  const auto& fx = en_.effects();
  constexpr int kE = En::kE;
  RunSpec ref1 = ref0_;
  for (int g : given) {
    for (int i = 0; i < fx[g].n; ++i)
      if (cand_[g].informed[i]) ref1.eff_val[fx[g].offset - kE + i] = cand_[g].est[i];
    if (fx[g].kind == EffectKind::kNoise) {
      ref1.eff_val[fx[g].offset - kE] = cand_[g].q_best;
      ref1.k = ref1.k * cand_[g].k_mult;
    }
  }
  return ref1;
}

template <template <typename> class DriveT>
void Ranking<DriveT>::run(const RunSpec& ref, double l_ref, long n_innov) {
  const auto& fx = en_.effects();
  const int ne = static_cast<int>(fx.size());
  ref0_ = ref;
  ln_n_ = std::log(double(n_innov));
  cand_.assign(ne, Candidate{});
  std::vector<Candidate>& cand = cand_;
  std::vector<RunOut> aug(ne);
  Tasks tasks;
  for (int e = 0; e < ne; ++e) augmentTasks(ref, l_ref, e, &cand[e], &aug[e], &tasks);
  runParallel(tasks, threads_);
  tasks.clear();
  for (int e = 0; e < ne; ++e) heldTasks(ref, e, &cand[e], aug[e], &tasks);
  runParallel(tasks, threads_);
  tasks.clear();

  std::vector<RankRow>& rows = rows_;
  rows.clear();
  for (int e = 0; e < ne; ++e) {
    RankRow r{e, 0, 0, 0, 1, 0, false, false, -1, 1, {}};
    r.significant = test(cand[e], &r);
    for (int i = 0; i < fx[e].n; ++i)
      r.detectable = r.detectable || (cand[e].informed[i] && cand[e].sig[i] < fx[e].ref[i] / 3);
    rows.push_back(r);
  }
  auto better = [](const RankRow& a, const RankRow& b) {
    if (a.significant != b.significant) return a.significant;
    if (a.p != b.p) return a.p < b.p;
    return a.bic > b.bic;
  };
  std::sort(rows.begin(), rows.end(), better);
  mutual_.assign(ne, {});
  std::vector<std::vector<int>>& mutual = mutual_;
  if (rows.size() > 1 && rows[0].significant) {
    auto significantAfterTop = [&] {
      std::vector<int> v;
      for (std::size_t i = 1; i < rows.size(); ++i)
        if (rows[i].significant) v.push_back(rows[i].e);
      return v;
    };
    std::vector<int> second = significantAfterTop();
    std::vector<RankRow> given_top = conditional(rows[0].e, second);
    if (rows[1].significant) {
      const int a = rows[0].e, b2 = rows[1].e;
      const bool a_given_b = conditional(b2, {a})[a].significant;
      const bool b_given_a = given_top[b2].significant;
      if (!a_given_b && b_given_a) {
        std::swap(rows[0], rows[1]);
        second = significantAfterTop();
        given_top = conditional(rows[0].e, second);
      } else if (!a_given_b && !b_given_a) {
        mutual[a].push_back(b2);
        mutual[b2].push_back(a);
      }
    }
    for (RankRow& r : rows) {
      if (std::find(second.begin(), second.end(), r.e) == second.end()) continue;
      r.significant = given_top[r.e].significant;
      r.cond_p = given_top[r.e].p;
    }
    std::stable_sort(rows.begin() + 1, rows.end(), better);
  }
}

template <template <typename> class DriveT>
bool Ranking<DriveT>::anySignificant() const {
  bool any = false;
  for (const RankRow& r : rows_) any = any || r.significant;
  return any;
}

template <template <typename> class DriveT>
std::vector<int> Ranking<DriveT>::named() const {
  std::vector<int> v;
  for (const RankRow& r : rows_)
    if (r.significant) v.push_back(r.e);
  return v;
}

template <template <typename> class DriveT>
void Ranking<DriveT>::unname(int e, const std::string& why) {
  for (RankRow& r : rows_)
    if (r.e == e) {
      r.significant = false;
      r.unnamed = why;
    }
}

template <template <typename> class DriveT>
json Ranking<DriveT>::toJson(const RunOut& joint) const {
  const auto& fx = en_.effects();
  const int ne = static_cast<int>(fx.size());
  constexpr int kE = En::kE;
  const std::vector<Candidate>& cand = cand_;
  const std::vector<RankRow>& rows = rows_;
  const std::vector<std::vector<int>>& mutual = mutual_;
  // Joint information (the joint run's posterior, all augmentable candidates free):
  // for a pair of candidates, condition on the others (a model with only that pair added
  // holds them fixed) and marginalise the pose and the drive parameters; the pair is
  // confusable when the canonical correlation of their parameters exceeds 0.9.
  std::vector<int> live;  // states the joint run estimated (held ones have zero variance)
  std::vector<int> pos(En::M::kStates, -1);
  for (int i = 0; i < En::M::kStates; ++i) {
    if (joint.p(i, i) > 0) {
      pos[i] = static_cast<int>(live.size());
      live.push_back(i);
    }
  }
  Eigen::MatrixXd pj(live.size(), live.size());
  for (std::size_t a = 0; a < live.size(); ++a)
    for (std::size_t b = 0; b < live.size(); ++b) pj(a, b) = joint.p(live[a], live[b]);
  const Eigen::MatrixXd info = pj.ldlt().solve(Eigen::MatrixXd::Identity(pj.rows(), pj.cols()));
  auto paramIdx = [&](int e) {
    std::vector<int> v;
    for (int i = 0; i < fx[e].n; ++i)
      if (cand[e].informed[i] && pos[fx[e].offset + i] >= 0) v.push_back(pos[fx[e].offset + i]);
    return v;
  };
  auto canonical = [&](const std::vector<int>& p1, const std::vector<int>& p2) {
    std::vector<int> keep;
    for (int i = 0; i < kE; ++i)
      if (pos[i] >= 0) keep.push_back(pos[i]);
    keep.insert(keep.end(), p1.begin(), p1.end());
    keep.insert(keep.end(), p2.begin(), p2.end());
    Eigen::MatrixXd l(keep.size(), keep.size());
    for (std::size_t a = 0; a < keep.size(); ++a)
      for (std::size_t b = 0; b < keep.size(); ++b) l(a, b) = info(keep[a], keep[b]);
    const Eigen::MatrixXd c = l.ldlt().solve(Eigen::MatrixXd::Identity(l.rows(), l.cols()));
    const int n1 = static_cast<int>(p1.size()), n2 = static_cast<int>(p2.size());
    const Eigen::MatrixXd cc = c.bottomRightCorner(n1 + n2, n1 + n2);
    // largest singular value of C11^-1/2 C12 C22^-1/2
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e1(cc.topLeftCorner(n1, n1)), e2(cc.bottomRightCorner(n2, n2));
    if (e1.eigenvalues().minCoeff() <= 0 || e2.eigenvalues().minCoeff() <= 0) return 0.0;
    const Eigen::MatrixXd m = e1.operatorInverseSqrt() * cc.topRightCorner(n1, n2) * e2.operatorInverseSqrt();
    return Eigen::JacobiSVD<Eigen::MatrixXd>(m).singularValues()(0);
  };
  json ranking = json::array();
  for (const RankRow& r : rows) {
    const EffectInfo& f = fx[r.e];
    json confused = json::array();
    const std::vector<int> pi = paramIdx(r.e);
    for (int o = 0; o < ne; ++o) {
      if (o == r.e) continue;
      if (std::find(mutual[r.e].begin(), mutual[r.e].end(), o) != mutual[r.e].end()) {
        confused.push_back(fx[o].name);  // each explains the other away (conditional tests)
        continue;
      }
      if (pi.empty() || fx[o].kind == EffectKind::kNoise) continue;
      const std::vector<int> po = paramIdx(o);
      if (!po.empty() && canonical(pi, po) > 0.9) confused.push_back(fx[o].name);
    }
    const Candidate& c = cand[r.e];
    std::vector<double> ev(c.est.data(), c.est.data() + f.n), sv(c.sig.data(), c.sig.data() + f.n);
    ranking.push_back({{"effect", f.name},
                       {"significant", r.significant},
                       {"delta_loglik", r.dll},
                       {"bic_gain", r.bic},
                       {"p_value", r.p},
                       {"conditional_p_value", r.cond_p >= 0 ? json(r.cond_p) : json(nullptr)},
                       {"wald_p_value", r.wald_p},
                       {"informed_params", r.k},
                       {"informed", c.informed},
                       {"estimate", ev},
                       {"sigma", sv},
                       {"parameters", f.pnames},
                       {"detectable", r.detectable},
                       {"confused_with", confused},
                       {"kind", f.kind == EffectKind::kMotion ? "motion"
                                : f.kind == EffectKind::kNoise ? "noise"
                                                               : "measurement"},
                       {"description", f.description}});
    if (!r.unnamed.empty()) ranking.back()["not_named_because"] = r.unnamed;
    if (f.kind == EffectKind::kNoise) {
      json prof = json::array();
      for (const auto& pt : c.profile) prof.push_back({{"q", pt[0]}, {"loglik", pt[1]}, {"k_multiplier", pt[2]}});
      ranking.back()["profile"] = prof;
    }
  }
  return ranking;
}

template class Ranking<SyncDrive>;
template class Ranking<DiffDrive>;

}  // namespace odoerr::sim::diag
