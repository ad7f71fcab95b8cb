#include "dependence.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

namespace odoerr::sim::diag {

namespace {

using json = nlohmann::ordered_json;

constexpr int kDepShifts = 199;      // circular shifts of the null (p >= 0.005: its level 0.01 needs at most one)
constexpr double kDepWinsor = 5.0;   // responses beyond median +- this many MADs are clipped there
constexpr double kDepMinLeaf = 0.05; // a leaf holds at least this share of the fitted travel
constexpr int kDepCuts = 10;         // candidate cuts: the deciles of the travel
const char* const kDepComponents[3] = {"along", "cross", "heading"};
const char* const kDepComponentUnits[3] = {"m/m", "m/m", "rad/m"};

/// A regression tree of depth 2 on one variable: a split, and a split of each side.
struct DepTree {
  double t1 = 0, t[2] = {0, 0};
  double mean[4] = {0, 0, 0, 0};  // leaves: (left, left), (left, right), (right, left), (right, right)
  double lo[4], hi[4], w[4] = {0, 0, 0, 0};
  int n[4] = {0, 0, 0, 0};
  int leaf(double x) const { return x <= t1 ? (x <= t[0] ? 0 : 1) : (x <= t[1] ? 2 : 3); }
};

/// Rows sorted by the variable: value, weight, response.
struct DepRow {
  double x, w, r;
};

/// The best split of rows [lo, hi) by the weighted sum of squares, among the candidate
/// positions `cuts` (between distinct values) that leave each side at least min_w of weight;
/// -1 when none improves on no split.
int depBestSplit(const std::vector<DepRow>& rows, const std::vector<int>& cuts, int lo, int hi, double min_w) {
  double tw = 0, tr = 0;
  for (int i = lo; i < hi; ++i) {
    tw += rows[static_cast<std::size_t>(i)].w;
    tr += rows[static_cast<std::size_t>(i)].w * rows[static_cast<std::size_t>(i)].r;
  }
  double lw = 0, lr = 0, best = tw > 0 ? tr * tr / tw : 0;
  int at = -1, i = lo;
  for (int p : cuts) {
    if (p <= lo || p >= hi) continue;
    for (; i < p; ++i) {
      lw += rows[static_cast<std::size_t>(i)].w;
      lr += rows[static_cast<std::size_t>(i)].w * rows[static_cast<std::size_t>(i)].r;
    }
    const double rw = tw - lw;
    if (lw < min_w || rw < min_w) continue;
    const double v = lr * lr / lw + (tr - lr) * (tr - lr) / rw;
    if (v > best + 1e-12 * std::abs(best)) {
      best = v;
      at = p;
    }
  }
  return at;
}

/// Fits the tree to rows sorted by value; no split where none helps (a side of one leaf).
DepTree depFit(const std::vector<DepRow>& rows) {
  DepTree tr;
  const int n = static_cast<int>(rows.size());
  double tw = 0;
  for (const DepRow& q : rows) tw += q.w;
  const double min_w = kDepMinLeaf * tw;
  const double inf = std::numeric_limits<double>::infinity();
  // The candidate cuts: the weighted quantiles k / kDepCuts of the rows (a binned search, as
  // histogram-based boosting does: few candidates, little room to fit the noise).
  std::vector<int> cuts;
  double cum = 0;
  int next = 1;
  for (int i = 0; i + 1 < n && next < kDepCuts; ++i) {
    cum += rows[static_cast<std::size_t>(i)].w;
    if (cum < tw * next / kDepCuts) continue;
    while (next < kDepCuts && cum >= tw * next / kDepCuts) ++next;
    if (rows[static_cast<std::size_t>(i)].x < rows[static_cast<std::size_t>(i + 1)].x) cuts.push_back(i + 1);
  }
  auto mid = [&](int p) { return 0.5 * (rows[static_cast<std::size_t>(p - 1)].x + rows[static_cast<std::size_t>(p)].x); };
  const int p1 = depBestSplit(rows, cuts, 0, n, min_w);
  tr.t1 = p1 < 0 ? inf : mid(p1);
  const int e1 = p1 < 0 ? n : p1;
  const int pl = depBestSplit(rows, cuts, 0, e1, min_w), pr = p1 < 0 ? -1 : depBestSplit(rows, cuts, p1, n, min_w);
  tr.t[0] = pl < 0 ? inf : mid(pl);
  tr.t[1] = pr < 0 ? inf : mid(pr);
  double sr[4] = {0, 0, 0, 0};
  for (int l = 0; l < 4; ++l) {
    tr.lo[l] = inf;
    tr.hi[l] = -inf;
  }
  for (const DepRow& q : rows) {
    const int l = tr.leaf(q.x);
    tr.w[l] += q.w;
    sr[l] += q.w * q.r;
    tr.lo[l] = std::min(tr.lo[l], q.x);
    tr.hi[l] = std::max(tr.hi[l], q.x);
    ++tr.n[l];
  }
  for (int l = 0; l < 4; ++l) tr.mean[l] = tr.w[l] > 0 ? sr[l] / tr.w[l] : 0.0;
  return tr;
}

/// The cross-validated share of the misfit that the tree removes against a constant
/// (weighted; each fold predicted from a tree fitted on the others). `order`: the segments
/// by the variable's value. `shift` pairs response i with the state of segment
/// (i + shift) mod n.
/// The columns are matrix columns taken by reference (no copy per pair and shift).
using Column = Eigen::Ref<const Eigen::VectorXd>;
double depGain(const Column& r, const Column& w, const Column& x, const std::vector<int>& order,
               const std::vector<int>& fold, int folds, int shift) {
  const int n = static_cast<int>(r.size());
  double sse_tree = 0, sse_const = 0;
  std::vector<DepRow> rows;
  rows.reserve(static_cast<std::size_t>(n));
  for (int f = 0; f < folds; ++f) {
    rows.clear();
    double tw = 0, trr = 0;
    for (int j : order) {
      const int i = ((j - shift) % n + n) % n;  // the response paired with state j
      if (fold[static_cast<std::size_t>(i)] == f) continue;
      rows.push_back({x[j], w[i], r[i]});
      tw += w[i];
      trr += w[i] * r[i];
    }
    if (!(tw > 0)) continue;
    const double mean = trr / tw;
    const DepTree tree = depFit(rows);
    for (int i = 0; i < n; ++i) {
      if (fold[static_cast<std::size_t>(i)] != f) continue;
      const int l = tree.leaf(x[(i + shift) % n]);
      const double pred = tree.w[l] > 0 ? tree.mean[l] : mean;
      sse_tree += w[i] * (r[i] - pred) * (r[i] - pred);
      sse_const += w[i] * (r[i] - mean) * (r[i] - mean);
    }
  }
  return sse_const > 0 ? 1.0 - sse_tree / sse_const : 0.0;
}

double depMedian(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

void SegmentState::open(double t, double s_abs, double s_rev) {
  *this = SegmentState{};
  t0_ = t;
  s_abs_ = s_abs;
  s_rev_ = s_rev;
}

void SegmentState::cycle(double dt, double rho, double th, double right, double left, double x, double y,
                         double heading) {
  rho_ += rho;
  abs_rho_ += std::abs(rho);
  th_ += th;
  abs_th_ += std::abs(th);
  right_ += right;
  left_ += left;
  if (!(dt > 0)) return;
  const double tc = dur_ + 0.5 * dt, v = rho / dt, w = th / dt;
  dur_ += dt;
  sx_ += x * dt;
  sy_ += y * dt;
  sc_ += std::cos(heading) * dt;
  ss_ += std::sin(heading) * dt;
  n_ += 1;
  st_ += tc;
  stt_ += tc * tc;
  sv_ += v;
  stv_ += tc * v;
  sw_ += w;
  stw_ += tc * w;
}

bool SegmentState::row(bool wheels, Eigen::VectorXd* out) const {
  if (!(dur_ > 0)) return false;
  constexpr double kRevCap = 20.0;  // m: "no reversal yet" and "long ago" share the last bin
  const double den = n_ * stt_ - st_ * st_;
  const double a = n_ >= 3 && den > 0 ? (n_ * stv_ - st_ * sv_) / den : 0.0;
  const double alpha = n_ >= 3 && den > 0 ? (n_ * stw_ - st_ * sw_) / den : 0.0;
  const double v = rho_ / dur_;
  const double sgn = v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0);
  std::vector<double> r = {v,
                           abs_rho_ / dur_,
                           th_ / dur_,
                           abs_th_ / dur_,
                           a * sgn,
                           alpha,
                           std::atan2(ss_, sc_),
                           sx_ / dur_,
                           sy_ / dur_,
                           t0_ + 0.5 * dur_,
                           s_abs_,
                           std::min(s_rev_, kRevCap)};
  if (wheels) {
    r.push_back(right_ / dur_);
    r.push_back(left_ / dur_);
  }
  *out = Eigen::Map<const Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
  return true;
}

Eigen::Vector3d SegmentState::perMetre(const Eigen::Vector3d& rw) const {
  const double h = std::atan2(ss_, sc_), c = std::cos(h), s = std::sin(h);
  const double m = abs_rho_ > 0 ? abs_rho_ : 1.0;
  return Eigen::Vector3d(rw[0] * c + rw[1] * s, -rw[0] * s + rw[1] * c, rw[2]) / m;
}

void stateVariables(bool wheels, std::vector<std::string>* names, std::vector<std::string>* units) {
  *names = {"v", "speed", "w", "abs_w", "a_along", "alpha", "heading", "x", "y", "t", "s_abs", "s_rev"};
  *units = {"m/s", "m/s", "rad/s", "rad/s", "m/s^2", "rad/s^2", "rad", "m", "m", "s", "m", "m"};
  if (wheels) {
    names->insert(names->end(), {"v_R", "v_L"});
    units->insert(units->end(), {"m/s", "m/s"});
  }
}

namespace {

/// One table for both questions about a variable: the library's features in it (what
/// discovery may have selected), the ones the parametric step proposes (at the finding's
/// component, or on a wheel: "@R", "@L"), and the catalogue's effects in it.
struct VariableForms {
  const char* variable;
  std::vector<std::string> library, proposed, catalogue;
};

const std::vector<VariableForms>& variableForms() {
  static const std::vector<VariableForms> table = {
      {"v", {"v2", "abs_ds", "ds"}, {"v2", "abs_ds"}, {"speed_scale", "wheel_speed_scale"}},
      {"speed", {"v2", "abs_ds", "ds"}, {"v2", "abs_ds"}, {"speed_scale", "wheel_speed_scale"}},
      {"w", {"w2", "abs_dth", "v_w", "dth"}, {"w2", "abs_dth"}, {"turn_slip", "rotation_slip"}},
      {"abs_w", {"w2", "abs_dth", "v_w", "dth"}, {"w2", "abs_dth"}, {"turn_slip", "rotation_slip"}},
      {"a_along",
       {"acc_pos_ds", "acc_neg_ds", "acc_ds", "acc_R_ds", "acc_L_ds", "jerk_ds"},
       {"acc_pos_ds", "acc_neg_ds"},
       {}},
      {"alpha", {"dw_ds"}, {"dw_ds"}, {}},
      {"heading", {"cos_heading_ds", "sin_heading_ds"}, {"cos_heading_ds", "sin_heading_ds"}, {}},
      {"x", {"x_ds"}, {"x_ds"}, {"region_scale"}},
      {"y", {"y_ds"}, {"y_ds"}, {"region_scale"}},
      {"t", {"t_ds", "dt"}, {"s_ds", "t_ds"}, {"radius_drift"}},
      {"s_abs", {"s_ds", "t_ds"}, {"s_ds", "t_ds"}, {"radius_drift"}},
      {"s_rev", {"rev_near_ds", "rev", "rev_R", "rev_L"}, {"rev_near_ds"}, {"backlash", "wheel_backlash"}},
      {"v_R", {"ds_R_speed", "acc_R_ds", "ds_R"}, {"ds_R_speed@R"}, {"wheel_speed_scale"}},
      {"v_L", {"ds_L_speed", "acc_L_ds", "ds_L"}, {"ds_L_speed@L"}, {"wheel_speed_scale"}},
  };
  return table;
}

const VariableForms* formsOf(const std::string& v) {
  for (const VariableForms& f : variableForms())
    if (v == f.variable) return &f;
  return nullptr;
}

}  // namespace

std::vector<std::string> featuresInVariable(const std::string& v) {
  const VariableForms* f = formsOf(v);
  return f != nullptr ? f->library : std::vector<std::string>{};
}

ProposedForms proposedForms(const std::string& v, const std::string& c) {
  ProposedForms out;
  const VariableForms* f = formsOf(v);
  if (f == nullptr) return out;
  for (const std::string& p : f->proposed) {
    const std::size_t at = p.find('@');
    out.features.push_back(at == std::string::npos ? p + "@" + c
                                                    : p.substr(0, at) + (p[at + 1] == 'R' ? "@wheel_R" : "@wheel_L"));
  }
  out.catalogue = f->catalogue;
  return out;
}

bool targetMoves(const std::string& target, const std::string& component) {
  if (target == component) return true;
  const bool wheel = target == "wheel_R" || target == "wheel_L";
  const bool world = target == "world_x" || target == "world_y";
  if (component == "along") return wheel || world;
  if (component == "cross") return world;
  if (component == "heading") return wheel;
  return false;
}

json dependenceJson(const StateTable& t) {
  // The usable segments: some travel, finite values.
  std::vector<int> use;
  for (Eigen::Index i = 0; i < t.state.rows(); ++i)
    if (t.weight[i] > 0 && t.state.row(i).allFinite() && t.response.row(i).allFinite()) use.push_back(static_cast<int>(i));
  const int n = static_cast<int>(use.size());
  const int nv = static_cast<int>(t.names.size());
  json j = {{"method",
             "a regression tree of depth 2 (leaves of at least 5 % of the travel) of each motion residual per metre "
             "on each state variable, cross-validated over time blocks; null: circular shifts of the states, the "
             "maximum over the pairs; a finding whose next segment's state explains as much follows the misfit"},
            {"segments", n},
            {"alpha", kDependenceAlpha},
            {"shifts", kDepShifts}};
  if (n < kMinSegments) {
    j["found"] = nullptr;
    j["follows_misfit"] = nullptr;
    j["pairs"] = nullptr;
    j["note"] = "too few segments with travel: " + std::to_string(n) + " (the analysis needs " +
                std::to_string(kMinSegments) + ")";
    return j;
  }
  Eigen::VectorXd w(n);
  Eigen::MatrixXd r(n, 3), s(n, nv);
  std::vector<int> fold(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const int i = use[static_cast<std::size_t>(k)];
    w[k] = t.weight[i];
    r.row(k) = t.response.row(i);
    s.row(k) = t.state.row(i);
    fold[static_cast<std::size_t>(k)] = t.fold[static_cast<std::size_t>(i)];
  }
  j["weight_m"] = w.sum();
  // Clip each component at median +- kDepWinsor MAD: one lost segment must not decide.
  for (int c = 0; c < 3; ++c) {
    std::vector<double> v(r.col(c).data(), r.col(c).data() + n);
    const double med = depMedian(v);
    for (double& x : v) x = std::abs(x - med);
    const double mad = 1.4826 * depMedian(v);
    if (mad > 0)
      for (int k = 0; k < n; ++k) r(k, c) = std::clamp(r(k, c), med - kDepWinsor * mad, med + kDepWinsor * mad);
  }
  std::vector<std::vector<int>> order(static_cast<std::size_t>(nv));
  std::vector<bool> varies(static_cast<std::size_t>(nv));
  for (int v = 0; v < nv; ++v) {
    auto& o = order[static_cast<std::size_t>(v)];
    o.resize(static_cast<std::size_t>(n));
    std::iota(o.begin(), o.end(), 0);
    std::stable_sort(o.begin(), o.end(), [&](int a, int b) { return s(a, v) < s(b, v); });
    varies[static_cast<std::size_t>(v)] = s(o.back(), v) > s(o.front(), v);
  }
  auto all = [&](int shift, Eigen::MatrixXd* g) {
    for (int c = 0; c < 3; ++c)
      for (int v = 0; v < nv; ++v)
        (*g)(c, v) = varies[static_cast<std::size_t>(v)]
                         ? depGain(r.col(c), w, s.col(v), order[static_cast<std::size_t>(v)], fold, t.folds, shift)
                         : 0.0;
  };
  Eigen::MatrixXd g(3, nv), gs(3, nv);
  all(0, &g);
  // The null: the maximum over the pairs, the states shifted by 10 % to 90 % of the drive.
  // Not drawn when no pair reaches the smallest share worth reporting (no p-value then).
  const bool tested = g.maxCoeff() >= kDependenceMinShare;
  std::mt19937 rng(20240611u);
  std::uniform_int_distribution<int> pick(std::max(1, n / 10), std::max(1, n - n / 10));
  std::vector<double> null_max(tested ? kDepShifts : 0);
  for (double& m : null_max) {
    all(pick(rng), &gs);
    m = gs.maxCoeff();
  }
  j["tested"] = tested;
  if (!tested) j["note"] = "no pair explains 1 % of the misfit: no test drawn";
  json pairs = json::array(), found = json::array(), follows = json::array();
  struct Hit {
    int c, v;
    double g, p;
  };
  std::vector<Hit> hits;
  for (int c = 0; c < 3; ++c)
    for (int v = 0; v < nv; ++v) {
      const long ge = std::count_if(null_max.begin(), null_max.end(), [&](double x) { return x >= g(c, v); });
      const double p = static_cast<double>(1 + ge) / static_cast<double>(1 + null_max.size());
      pairs.push_back({{"component", kDepComponents[c]}, {"variable", t.names[static_cast<std::size_t>(v)]},
                       {"explained", g(c, v)}, {"p_adjusted", tested ? json(p) : json(nullptr)}});
      if (tested && p <= kDependenceAlpha && g(c, v) >= kDependenceMinShare) hits.push_back({c, v, g(c, v), p});
    }
  std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.g > b.g; });
  for (const Hit& h : hits) {
    // The shape: the tree fitted on every segment, its leaves in the variable's order.
    std::vector<DepRow> rows;
    for (int k : order[static_cast<std::size_t>(h.v)]) rows.push_back({s(k, h.v), w[k], r(k, h.c)});
    const DepTree tree = depFit(rows);
    json shape = json::array();
    for (int l = 0; l < 4; ++l)
      if (tree.n[l] > 0)
        shape.push_back({{"from", tree.lo[l]}, {"to", tree.hi[l]}, {"mean", tree.mean[l]}, {"segments", tree.n[l]},
                         {"travel_m", tree.w[l]}});
    // The direction: a variable the robot's controller sets in reply to the error it sees
    // (the turn rate's change after a heading error) is explained by the misfit, not its
    // cause, and its next segment's value explains the misfit at least as well as its own.
    const double g_next = depGain(r.col(h.c), w, s.col(h.v), order[static_cast<std::size_t>(h.v)], fold, t.folds, 1);
    json& into = g_next >= h.g ? follows : found;
    into.push_back({{"component", kDepComponents[h.c]},
                     {"unit", kDepComponentUnits[h.c]},
                     {"variable", t.names[static_cast<std::size_t>(h.v)]},
                     {"variable_unit", t.units[static_cast<std::size_t>(h.v)]},
                     {"explained", h.g},
                     {"explained_next", g_next},
                     {"p_adjusted", h.p},
                     {"leaves", shape},
                     {"library_forms", featuresInVariable(t.names[static_cast<std::size_t>(h.v)])}});
  }
  j["found"] = found;
  j["follows_misfit"] = follows;
  j["pairs"] = pairs;
  return j;
}

}  // namespace odoerr::sim::diag
