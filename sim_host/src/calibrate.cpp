// odoerr evaluate's calibration: the online estimator (diagnose's engine: the drive
// parameters, K, the chosen catalogue effects and motion feature terms free) over
// calibration logs in order, the parameters and their covariance carried from one log to
// the next, the pose re-initialised from each log's init.
#include <algorithm>
#include <cmath>
#include <memory>

#include "diagnose/engine.hpp"
#include "diagnose/model_search.hpp"
#include "odoerr/scalar.hpp"
#include "odoerr/sim/evaluate.hpp"

namespace odoerr::sim {

using json = nlohmann::ordered_json;

namespace {

/// The prior sigma of a feature term's coefficient in the calibration: wide (a drift of
/// 10 cm per metre, or its equivalent in the feature's unit), as diagnose's fallback does
/// for a term the regression cannot size.
constexpr double kFeaturePrior = 0.1;

template <typename Effects>
bool calibrateImpl(const std::vector<Odolog>& logs, const std::vector<std::string>& with,
                   const std::vector<diag::Term>& features, Calibration* out, std::string* error,
                   const DiagnoseOptions& base) {
  using En = diag::Engine<DiffDrive, Effects>;
  constexpr int kD = En::kD;
  DiagnoseOptions opt = base;
  opt.with = with;
  double nis_sum = 0, nis_xy_sum = 0, nis_th_sum = 0;
  long n_fix = 0;
  typename En::StateVec x = En::StateVec::Zero();
  typename En::StateMat p = En::StateMat::Zero();
  typename En::KVec k = En::KVec::Zero();
  typename En::KMat pk = En::KMat::Zero();
  bool carried = false;
  Calibration cal;
  diag::FeatureSlots slots;
  for (const diag::Term& t : features) slots.motion.push_back({t.mf, t.mt, kFeaturePrior, 0.01});
  int feature_effect = -1;
  for (const Odolog& log : logs) {
    if (log.drive != "diff") {
      *error = log.path + ": odoerr evaluate supports diff-drive logs (this one is '" + log.drive + "')";
      return false;
    }
    En en(log, opt, slots);
    if (!en.prepare(error)) return false;
    diag::WithSpec ws;
    if (!diag::parseWith(with, en.effects(), false, &ws, error)) return false;
    typename En::RunSpec s = en.nominalSpec(carried ? k : en.initialK(), true);
    for (int e : ws.catalogue) en.freeEffect(&s, e);
    if (!features.empty()) {
      for (std::size_t e = 0; e < en.effects().size(); ++e)
        if (en.effects()[e].name == "feature_motion") feature_effect = static_cast<int>(e);
      en.freeEffect(&s, feature_effect);
    }
    s.record = true;  // the pose fixes' innovations (FixNis)
    if (carried) {
      s.carry_x = &x;
      s.carry_p = &p;
      s.carry_pk = &pk;
    }
    const typename En::RunOut r = en.run(s);
    if (r.n_innov == 0) {
      // Nothing was measured: the parameters would come back as their priors and be
      // reported as a calibration. (A log whose map is a separate file: calibrate with
      // `odoerr replay --map` and pass its estimate with --constants; docs/real-data.md.)
      *error = log.path + ": no measurement was fused (no pose fix, and no laser scan against map walls); "
               "nothing to calibrate on";
      return false;
    }
    for (const auto& f : r.fixes) {
      const Eigen::Map<const Eigen::Matrix3d> sm(f.s);
      const Eigen::Vector3d nu(f.nu[0], f.nu[1], f.nu[2]);
      const double nxy = nu.head<2>().dot(sm.topLeftCorner<2, 2>().ldlt().solve(nu.head<2>()));
      const double nth = nu[2] * nu[2] / sm(2, 2);
      if (!std::isfinite(f.nis) || !std::isfinite(nxy) || !std::isfinite(nth)) continue;
      nis_sum += f.nis;
      nis_xy_sum += nxy;
      nis_th_sum += nth;
      ++n_fix;
    }
    x = r.x;
    p = r.p;
    k = r.k;
    pk = r.pk;
    carried = true;
    json row = {{"log", log.path}};
    for (int i = 0; i < 3; ++i) row[En::Drive::kParamNames[i]] = x[kD + i];
    row["K_w"] = k[0];
    cal.per_log.push_back(row);
    cal.effects = json::object();
    for (int e : ws.catalogue) {
      const auto& f = en.effects()[static_cast<std::size_t>(e)];
      json est = json::array(), sig = json::array();
      for (int i = 0; i < f.n; ++i) {
        est.push_back(x[f.offset + i]);
        sig.push_back(std::sqrt(p(f.offset + i, f.offset + i)));
      }
      cal.effects[f.name] = {{"estimate", est}, {"sigma", sig}};
    }
    cal.c.terms.clear();
    if (feature_effect >= 0) {
      const auto& f = en.effects()[static_cast<std::size_t>(feature_effect)];
      for (std::size_t i = 0; i < features.size(); ++i) {
        const int idx = f.offset + static_cast<int>(i);
        const std::string token = diag::withToken(features[i]);
        cal.c.terms.push_back({static_cast<int>(features[i].mf), static_cast<int>(features[i].mt), x[idx], token});
        cal.effects[token] = {{"estimate", {x[idx]}}, {"sigma", {std::sqrt(p(idx, idx))}}};
      }
    }
  }
  cal.c.delta_R = x[kD + 0];
  cal.c.delta_L = x[kD + 1];
  cal.c.delta_d = x[kD + 2];
  for (int i = 0; i < 3; ++i) cal.sigma[i] = std::sqrt(p(kD + i, kD + i));
  cal.k_w = k[0];
  cal.k_w_sigma = std::sqrt(pk(0, 0));
  const double nan = std::nan("");
  cal.fix_nis = {n_fix, n_fix ? nis_sum / (3.0 * double(n_fix)) : nan, n_fix ? nis_xy_sum / (2.0 * double(n_fix)) : nan,
                 n_fix ? nis_th_sum / double(n_fix) : nan};
  *out = cal;
  return true;
}

}  // namespace

bool calibrateOnLogs(const std::vector<Odolog>& logs, const std::vector<std::string>& with, Calibration* out,
                     std::string* error, const DiagnoseOptions& base) {
  if (logs.empty()) {
    *error = "no calibration log";
    return false;
  }
  // Parse --with once against the first log's catalogue to split catalogue effects from
  // feature terms.
  diag::Engine<DiffDrive> probe(logs[0], DiagnoseOptions{});
  if (logs[0].drive != "diff") {
    *error = logs[0].path + ": odoerr evaluate supports diff-drive logs (this one is '" + logs[0].drive + "')";
    return false;
  }
  if (!probe.prepare(error)) return false;
  diag::WithSpec ws;
  if (!diag::parseWith(with, probe.effects(), false, &ws, error)) return false;
  if (ws.automatic) {
    *error = "--with: evaluate takes catalogue effects and motion feature terms, not auto";
    return false;
  }
  std::vector<std::string> catalogue;
  for (const std::string& w : with)
    if (w.rfind("feature:", 0) != 0) catalogue.push_back(w);
  for (const diag::Term& t : ws.features) {
    if (t.kind != diag::Term::Kind::kMotion) {
      *error = "--with: evaluate takes motion feature terms only ('" + diag::withToken(t) + "' is a beam term)";
      return false;
    }
    if (t.mf == effects::MotionFeature::kXDs || t.mf == effects::MotionFeature::kYDs) {
      *error = "--with: evaluate does not take the map-centred features x_ds, y_ds";
      return false;
    }
    if (ws.features.size() > diag::FeatureSlots::kMax) {
      *error = "--with: at most 4 feature terms";
      return false;
    }
  }
  if (ws.features.empty()) return calibrateImpl<effects::Catalogue>(logs, catalogue, {}, out, error, base);
  return calibrateImpl<diag::Featured>(logs, catalogue, ws.features, out, error, base);
}

void setFixSigma(std::vector<Odolog>* logs, double sxy, double stheta) {
  for (Odolog& log : *logs)
    for (OdologPose& q : log.poses) {
      q.sx = sxy;
      q.sy = sxy;
      q.stheta = stheta;
    }
}

void scaleFixSigma(std::vector<Odolog>* logs, double scale) {
  for (Odolog& log : *logs)
    for (OdologPose& q : log.poses) {
      q.sx *= scale;
      q.sy *= scale;
      q.stheta *= scale;
    }
}

bool chooseFixSigma(const std::vector<Odolog>& logs, const std::vector<std::string>& with,
                    const DiagnoseOptions& base, FixSigmaChoice* out, std::string* error) {
  FixSigmaChoice c;
  const OdologPose* first = nullptr;
  for (const Odolog& log : logs)
    if (!first && !log.poses.empty()) first = &log.poses.front();
  if (!first) {
    *error = "--fix-sigma auto: the calibration logs have no pose fix";
    return false;
  }
  // NIS per dof at scale s (NaN when no fix was fused)
  auto nisAt = [&](double s, double* nis) {
    std::vector<Odolog> scaled = logs;
    scaleFixSigma(&scaled, s);
    Calibration cal;
    if (!calibrateOnLogs(scaled, with, &cal, error, base)) return false;
    *nis = cal.fix_nis.per_dof;
    c.trace.push_back({s, *nis});
    return true;
  };
  double lo = std::log(1.0 / 16), hi = std::log(16.0), n_lo = 0, n_hi = 0;
  if (!nisAt(std::exp(lo), &n_lo) || !nisAt(std::exp(hi), &n_hi)) return false;
  if (!std::isfinite(n_lo) || !std::isfinite(n_hi)) {
    *error = "--fix-sigma auto: no pose fix was fused in the calibration";
    return false;
  }
  double chosen = 0;
  if (n_lo <= 1) {
    chosen = lo;
    c.note = "the NIS per dof is at most 1 already at 1/16 of the logs' sigmas: the smallest scale tried is taken";
  } else if (n_hi >= 1) {
    chosen = hi;
    c.note = "the NIS per dof is at least 1 still at 16 times the logs' sigmas: the largest scale tried is taken";
  } else {
    for (int i = 0; i < 7; ++i) {
      const double mid = 0.5 * (lo + hi);
      double n = 0;
      if (!nisAt(std::exp(mid), &n)) return false;
      if (n > 1) {
        lo = mid;
      } else {
        hi = mid;
      }
    }
    chosen = 0.5 * (lo + hi);
  }
  c.scale = std::exp(chosen);
  c.sigma_xy = first->sx * c.scale;
  c.sigma_theta = first->stheta * c.scale;
  *out = c;
  return true;
}

namespace {

/// 1.4826 times the median absolute deviation: the sigma of a Gaussian sample, robust.
double robustSigma(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  auto median = [](std::vector<double>* a) {
    const std::size_t m = a->size() / 2;
    std::nth_element(a->begin(), a->begin() + static_cast<std::ptrdiff_t>(m), a->end());
    double med = (*a)[m];
    if (a->size() % 2 == 0) med = 0.5 * (med + *std::max_element(a->begin(), a->begin() + static_cast<std::ptrdiff_t>(m)));
    return med;
  };
  const double med = median(&v);
  for (double& x : v) x = std::abs(x - med);
  return 1.4826 * median(&v);
}

}  // namespace

FixNoise measureFixNoise(const Odolog& log) {
  FixNoise n;
  n.fixes = static_cast<long>(log.poses.size());
  if (!log.poses.empty()) {
    n.declared_xy = log.poses.front().sx;
    n.declared_theta = log.poses.front().stheta;
  }
  n.sigma_xy = n.declared_xy;
  n.sigma_theta = n.declared_theta;
  if (log.poses.size() < 4) {
    n.note = "fewer than 4 pose fixes: the declared sigmas are kept";
    return n;
  }
  std::vector<double> times;
  for (const OdologPose& q : log.poses) times.push_back(q.t);
  std::vector<Pose2> odo;
  std::string err;
  if (!integrateOdometry(log, OdoConstants{}, times, &odo, &err)) {
    n.note = "no odometry to carry the fixes (" + err + "): the declared sigmas are kept";
    return n;
  }
  std::vector<double> exy, eth;
  const auto& f = log.poses;
  for (std::size_t a = 0; a + 3 < f.size(); ++a) {
    // fix a carried by the odometry's relative motion to a+1..a+3; the residuals there
    double r[3][3];
    const double ca = std::cos(odo[a].th), sa = std::sin(odo[a].th);
    const double cf = std::cos(f[a].theta), sf = std::sin(f[a].theta);
    for (int k = 0; k < 3; ++k) {
      const std::size_t j = a + 1 + static_cast<std::size_t>(k);
      const double dx = odo[j].x - odo[a].x, dy = odo[j].y - odo[a].y;
      const double lx = ca * dx + sa * dy, ly = -sa * dx + ca * dy;  // in the odometry's frame at a
      const double px = f[a].x + cf * lx - sf * ly, py = f[a].y + sf * lx + cf * ly;
      const double pth = f[a].theta + (odo[j].th - odo[a].th);
      r[k][0] = f[j].x - px;
      r[k][1] = f[j].y - py;
      r[k][2] = wrapAngle(f[j].theta - pth);
    }
    const double dtm = f[a + 2].t - f[a + 1].t, dtp = f[a + 3].t - f[a + 2].t;
    if (!(dtm > 0) || !(dtp > 0)) continue;
    const double wm = 1 / dtm, wp = 1 / dtp, norm = std::sqrt(wm * wm + wp * wp + (wm + wp) * (wm + wp));
    auto second = [&](double r1, double r2, double r3) { return (wp * (r3 - r2) - wm * (r2 - r1)) / norm; };
    exy.push_back(second(r[0][0], r[1][0], r[2][0]));
    exy.push_back(second(r[0][1], r[1][1], r[2][1]));
    eth.push_back(second(0, wrapAngle(r[1][2] - r[0][2]), wrapAngle(r[1][2] - r[0][2]) + wrapAngle(r[2][2] - r[1][2])));
  }
  n.samples = static_cast<long>(eth.size());
  if (n.samples < FixNoise::kMinSamples) {
    n.note = "fewer than " + std::to_string(FixNoise::kMinSamples) +
             " windows of four fixes to measure their noise on: the declared sigmas are kept";
    return n;
  }
  const double sxy = robustSigma(exy), sth = robustSigma(eth);
  if (!(sxy > 0) || !(sth > 0) || !std::isfinite(sxy) || !std::isfinite(sth)) {
    n.note = "the measured noise is not positive (identical fixes?): the declared sigmas are kept";
    return n;
  }
  n.sigma_xy = sxy;
  n.sigma_theta = sth;
  n.measured = true;
  return n;
}

void setFixSigma(Odolog* log, const FixNoise& n) {
  for (OdologPose& q : log->poses) {
    q.sx = n.sigma_xy;
    q.sy = n.sigma_xy;
    q.stheta = n.sigma_theta;
  }
}

}  // namespace odoerr::sim
