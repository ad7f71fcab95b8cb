#include "discovery.hpp"

#include "map_misfit.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace odoerr::sim::diag {

namespace {

using json = nlohmann::ordered_json;
using effects::BeamFeature;
using effects::MotionFeature;
using effects::MotionTarget;

constexpr double kSegmentS = 0.5;     // a motion segment spans at least this (s)
constexpr double kSmoothS = 0.25;     // measurement poses this close to a boundary are averaged into it
constexpr double kClusterS = 5.0;     // rows within this much time may correlate (robust sigma; change points at their boundaries)
constexpr double kCvBlockS = 2.0;     // cross-validation blocks, as the held-out comparison's
constexpr double kMaxSegmentM = 0.5;  // a segment residual beyond this is a lost filter, not a residual
constexpr double kMaxBeamZ = 5.0;     // a beam residual beyond this many sigmas is an outlier

double robustScale(std::vector<double> v) {
  if (v.empty()) return 1.0;
  for (double& x : v) x = std::abs(x);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  const double mad = v[v.size() / 2];
  return mad > 0 ? 1.4826 * mad : 1.0;
}

}  // namespace

std::string fmt(const char* f, double a) {
  char b[160];
  std::snprintf(b, sizeof b, f, a);
  return b;
}

bool writeDiscoveryCsv(const std::string& dir, const Residuals& r, std::string* error) {
  auto one = [&](const char* name, const Design& d, const Selection& sel, const std::vector<Term>& terms, int every) {
    const std::string path = dir + "/" + name;
    FILE* f = std::fopen(path.c_str(), "w");
    if (f == nullptr) {
      *error = "cannot write '" + path + "'";
      return false;
    }
    std::fprintf(f, "t,row,y,fit");
    for (int j : sel.terms) {
      const Term& t = terms[static_cast<std::size_t>(j)];
      std::fprintf(f, ",%s/%s/%s,partial_%s/%s/%s", t.frame().c_str(), t.target().c_str(), t.name().c_str(),
                   t.frame().c_str(), t.target().c_str(), t.name().c_str());
    }
    std::fprintf(f, "\n");
    for (Eigen::Index i = 0; i < d.x.rows(); i += every) {
      double fit = 0;
      for (std::size_t k = 0; k < sel.terms.size() && k < sel.coef.size(); ++k) fit += sel.coef[k] * d.x(i, sel.terms[k]);
      for (int k = 0; k < d.n_nuisance && k < static_cast<int>(sel.nuisance.size()); ++k) fit += sel.nuisance[static_cast<std::size_t>(k)] * d.x(i, k);
      std::fprintf(f, "%.3f,%ld,%.5g,%.5g", d.t[i], static_cast<long>(i), d.y[i], fit);
      for (std::size_t k = 0; k < sel.terms.size() && k < sel.coef.size(); ++k) {
        const double col = d.x(i, sel.terms[k]);
        std::fprintf(f, ",%.5g,%.5g", col, d.y[i] - (fit - sel.coef[k] * col));
      }
      std::fprintf(f, "\n");
    }
    const bool ok = std::ferror(f) == 0;
    std::fclose(f);
    if (!ok) *error = "cannot write '" + path + "'";
    return ok;
  };
  return one("discovery_motion.csv", r.motion, r.motion_sel, r.motion_terms, 1) &&
         one("discovery_beam.csv", r.beam, r.beam_sel, r.beam_terms, 8);
}

double structuredMisfit(const Selection& s) { return std::max(0.0, s.sse_cv_nuisance - s.sse_cv); }

namespace {

/// The share of base's misfit (per row) that `with` removed, clamped to [0, 1]; NaN when
/// base shows no misfit.
std::pair<double, double> removed(const Selection& base, const Selection& with) {
  const double m = structuredMisfit(base);
  if (!(m > 0) || base.rows == 0 || with.rows == 0) return {0, 0};
  const double a = base.sse_cv_nuisance / base.rows, b = with.sse_cv_nuisance / with.rows;
  return {std::clamp((a - b) * base.rows, 0.0, m), m};
}

json featuresOf(const Residuals& r) {
  json f = json::array();
  auto add = [&](const Selection& s, const std::vector<Term>& terms) {
    for (std::size_t k = 0; k < s.terms.size() && k < s.coef.size(); ++k) {
      const Term& t = terms[static_cast<std::size_t>(s.terms[k])];
      f.push_back({{"name", t.name()}, {"frame", t.frame()}, {"component", t.target()}, {"coef", s.coef[k]},
                   {"sigma", s.sigma[k]}, {"words", t.words(s.coef[k], s.sigma[k])},
                   {"with", withToken(t).empty() ? json(nullptr) : json(withToken(t))}});
    }
  };
  add(r.motion_sel, r.motion_terms);
  add(r.beam_sel, r.beam_terms);
  return f;
}

json designJson(const Selection& s, int units, const char* unit_name, double extra = -1) {
  const bool data = s.rows > 0;  // no row (a log without laser has no beam rows): null, never 0
  json j = {{unit_name, units},
            {"rows", s.rows},
            {"sse_cv_model", data ? json(s.sse_cv_nuisance) : json(nullptr)},
            {"sse_cv_features", data ? json(s.sse_cv) : json(nullptr)},
            {"features_explain", s.sse_cv_nuisance > 0 ? json(s.explained()) : json(nullptr)}};
  if (!data) j["note"] = "no rows: nothing to regress";
  if (extra >= 0) j["segment_s"] = extra;
  return j;
}

}  // namespace

json explainedBy(const Residuals& base, const Residuals& with) {
  const auto [dm, mm] = removed(base.motion_sel, with.motion_sel);
  const auto [db, mb] = removed(base.beam_sel, with.beam_sel);
  auto frac = [](double d, double m) { return m > 0 ? json(d / m) : json(nullptr); };
  return {{"motion", frac(dm, mm)}, {"beam", frac(db, mb)}, {"total", frac(dm + db, mm + mb)}};
}

json unexplainedJson(const Residuals& base, const Residuals& final_, bool named) {
  const json features = featuresOf(final_);
  const double misfit = structuredMisfit(base.motion_sel) + structuredMisfit(base.beam_sel);
  json frac = nullptr;
  if (misfit > 0) frac = named ? explainedBy(base, final_)["total"] : json(0.0);
  json j = {{"significant", !features.empty()},
            {"explained_fraction", frac},
            {"features", features},
            {"motion", designJson(final_.motion_sel, final_.segments, "segments", final_.seg_s)},
            {"beam", designJson(final_.beam_sel, static_cast<int>(final_.beams), "beams")},
            {"baseline_features", featuresOf(base)}};
  if (misfit <= 0)
    j["note"] = "the model's residuals show no structure in the feature library";
  else if (features.empty())
    j["note"] = "the named effects explain the structure the features found";
  else if (!named)
    j["note"] = "nothing in the catalogue explains the misfit: these features describe it";
  else
    j["note"] = "part of the misfit remains with the named effects in the model: these features describe it";
  return j;
}

// Where the measurement alone puts the robot at each fused measurement: a pose fix is
// that pose; a scan, the pose that best fits its beams by Gauss-Newton from the filter's
// posterior (ray casts for the geometry; the residuals at the posterior carry the model's
// measurement effects, held constant over the small step). The filter's own posterior
// lags behind an effect it lacks (odometry and laser are weighted alike over ~1 s), which
// hid half of a turn slip; the measurement's pose does not.
template <typename En>
std::vector<LaserPose> Discovery<En>::laserPoses(const RunOut& run) const {
  std::vector<LaserPose> out(run.post.size());
  const auto& ev = en_.events();
  const auto& log = en_.log();
  for (std::size_t i = 0; i < run.post.size(); ++i) {
    const PostPose& q = run.post[i];
    const Event& e = ev[static_cast<std::size_t>(q.event)];
    out[i] = {q.t, q.x, q.y, q.th, false};
    if (e.pose >= 0) {
      const OdologPose& f = log.poses[static_cast<std::size_t>(e.pose)];
      out[i] = {q.t, f.x, f.y, f.theta, true};
    }
  }
  const auto& laser = en_.laser();
  const auto& map = en_.map();
  const double sigma = std::max(1e-6, double(laser.config().sigma));
  auto cast = [&](double x, double y, double th, int b) {
    BeamHit h;
    return beamHit(map, laser, x, y, th, b, &h) ? h.range : std::numeric_limits<double>::quiet_NaN();
  };
  std::size_t k = 0;
  while (k < run.post_beams.size()) {
    const int pi = run.post_beams[k].post;
    std::size_t end = k;
    while (end < run.post_beams.size() && run.post_beams[end].post == pi) ++end;
    const PostPose& q = run.post[static_cast<std::size_t>(pi)];
    double x = q.x, y = q.y, th = q.th;
    bool ok = false;
    for (int it = 0; it < 3; ++it) {
      Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
      Eigen::Vector3d g = Eigen::Vector3d::Zero();
      int used = 0;
      for (std::size_t j = k; j < end; ++j) {
        const PostBeam& b = run.post_beams[j];
        const double r0 = cast(q.x, q.y, q.th, b.beam), r = cast(x, y, th, b.beam);
        const double nu = b.nu - (r - r0);  // the residual at (x, y, th)
        if (!std::isfinite(nu) || std::abs(nu) > 3 * sigma) continue;
        constexpr double h = 1e-4;
        const Eigen::Vector3d jac((cast(x + h, y, th, b.beam) - r) / h, (cast(x, y + h, th, b.beam) - r) / h,
                                  (cast(x, y, th + h, b.beam) - r) / h);
        if (!jac.allFinite() || jac.norm() > 1e3) continue;  // a corner between two walls
        a += jac * jac.transpose();
        g += jac * nu;
        ++used;
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(a);
      // enough beams, and every direction of the pose seen (not a corridor)
      if (used < 8 || es.eigenvalues().minCoeff() < 1e-3 * std::max(1.0, es.eigenvalues().maxCoeff()) ||
          es.eigenvalues().minCoeff() < 1.0) {
        ok = false;
        break;
      }
      const Eigen::Vector3d d = a.ldlt().solve(g);
      x += d[0];
      y += d[1];
      th += d[2];
      ok = d.allFinite();
      if (!ok || d.head<2>().norm() < 1e-5) break;
    }
    if (ok && std::hypot(x - q.x, y - q.y) < 0.2) out[static_cast<std::size_t>(pi)] = {q.t, x, y, th, true};
    k = end;
  }
  return out;
}

// A boundary's pose: the measurement poses within kSmoothS of it, each carried to the
// boundary's time along the model's odometry, averaged. A scan's pose alone is noisy
// (about 7 mm with 36 beams at 3 cm); five of them around the boundary cut that by about
// two, and the odometry's own error cancels to first order across a symmetric window.
template <typename En>
std::vector<LaserPose> Discovery<En>::smoothed(const std::vector<LaserPose>& lp, const RunOut& run,
                                               const typename En::M& model, const typename En::M::StateVec& x) const {
  using Drive = typename En::Drive;
  const auto& ev = en_.events();
  const auto& post = run.post;
  if (post.empty()) return lp;
  // the odometry chain: the pose after every event, from an arbitrary start
  std::vector<Pose<double>> chain(ev.size());
  typename En::M::Context ctx;
  Pose<double> o{post.front().x, post.front().y, post.front().th};
  const typename En::M::NoiseVec nu0 = En::M::NoiseVec::Zero();
  for (std::size_t k = 0; k < ev.size(); ++k) {
    const typename Drive::Input u{ev[k].a, ev[k].b};
    ctx.dt = ev[k].dt;
    ctx.x = o.x;
    ctx.y = o.y;
    ctx.setHeading(o.theta);
    Increment<double> drive_inc;
    const Increment<double> inc = model.increment(u, x, nu0, ctx, nullptr, nullptr, &drive_inc);
    o = applyIncrement(o, inc);
    chain[k] = o;
    model.advanceContext(ctx, drive_inc, Drive::encoderTravel(u));
  }
  std::vector<LaserPose> out = lp;
  for (std::size_t i = 0; i < post.size(); ++i) {
    if (!lp[i].ok) continue;
    const Pose<double>& oi = chain[static_cast<std::size_t>(post[i].event)];
    double sx = 0, sy = 0, sc = 0, ss = 0;
    int n = 0;
    for (std::size_t j = i >= 4 ? i - 4 : 0; j < post.size() && j <= i + 4; ++j) {
      if (!lp[j].ok || std::abs(post[j].t - post[i].t) > kSmoothS) continue;
      // carry measurement j to event i: its pose composed with the chain's j -> i motion
      const Pose<double>& oj = chain[static_cast<std::size_t>(post[j].event)];
      const double dth = lp[j].th - oj.theta, c = std::cos(dth), sn = std::sin(dth);
      const double dx = oi.x - oj.x, dy = oi.y - oj.y;
      sx += lp[j].x + c * dx - sn * dy;
      sy += lp[j].y + sn * dx + c * dy;
      sc += std::cos(oi.theta + dth);
      ss += std::sin(oi.theta + dth);
      ++n;
    }
    if (n > 0) out[i] = {lp[i].t, sx / n, sy / n, std::atan2(ss, sc), true};
  }
  return out;
}

template <typename En>
Residuals Discovery<En>::analyse(const RunOut& run, Scales* scales) const {
  using M = typename En::M;
  using Drive = typename En::Drive;
  using S = double;
  constexpr bool kSync = En::kSync;
  Residuals out;
  const M model = en_.makeModel();
  const typename M::StateVec x = run.x;
  const typename M::NoiseVec nu0 = M::NoiseVec::Zero();
  const auto p = x.template segment<Drive::kParams>(En::kD);
  double d = 0.0;  // the wheelbase (diff)
  if constexpr (!kSync) d = double(model.drive.wheelbase);
  double xc = en_.log().init.x, yc = en_.log().init.y;
  if (!en_.log().walls.empty()) {
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    for (const auto& w : en_.log().walls) {
      x0 = std::min({x0, w.x1, w.x2});
      x1 = std::max({x1, w.x1, w.x2});
      y0 = std::min({y0, w.y1, w.y2});
      y1 = std::max({y1, w.y1, w.y2});
    }
    xc = 0.5 * (x0 + x1);
    yc = 0.5 * (y0 + y1);
  }

  // The library: nuisance columns first (what the drive parameters already estimate),
  // then the candidates.
  std::vector<Term>& terms = out.motion_terms;
  auto motion = [&](MotionFeature f, MotionTarget t) { terms.push_back({Term::Kind::kMotion, f, t}); };
  int n_nuisance;
  if constexpr (kSync) {
    motion(MotionFeature::kDs, MotionTarget::kAlong);    // delta_rho
    motion(MotionFeature::kDs, MotionTarget::kHeading);  // E_theta
    n_nuisance = 2;
  } else {
    motion(MotionFeature::kDsR, MotionTarget::kWheelR);  // delta_R
    motion(MotionFeature::kDsL, MotionTarget::kWheelL);  // delta_L
    motion(MotionFeature::kDth, MotionTarget::kHeading);  // delta_d
    n_nuisance = 3;
  }
  const MotionFeature robot_features[] = {
      MotionFeature::kDs,           MotionFeature::kAbsDs,        MotionFeature::kDth, MotionFeature::kAbsDth,
      MotionFeature::kVW,           MotionFeature::kV2,           MotionFeature::kW2,  MotionFeature::kCosHeadingDs,
      MotionFeature::kSinHeadingDs, MotionFeature::kXDs,          MotionFeature::kYDs, MotionFeature::kSDs,
      MotionFeature::kDt};
  for (MotionTarget t : {MotionTarget::kAlong, MotionTarget::kCross, MotionTarget::kHeading})
    for (MotionFeature f : robot_features) {
      const bool nuisance = std::any_of(terms.begin(), terms.begin() + n_nuisance,
                                        [&](const Term& q) { return q.mf == f && q.mt == t; });
      if (!nuisance) motion(f, t);
    }
  for (MotionTarget t : {MotionTarget::kWorldX, MotionTarget::kWorldY})
    for (MotionFeature f : {MotionFeature::kAbsDs, MotionFeature::kDt}) motion(f, t);
  terms.push_back({Term::Kind::kReversal, MotionFeature::kNone, MotionTarget::kAlong});
  // The motion's history: travel lost or gained while speeding up or braking, a turn that
  // follows the turn rate's change, a drag just after reversals.
  motion(MotionFeature::kAccPosDs, MotionTarget::kAlong);
  motion(MotionFeature::kAccNegDs, MotionTarget::kAlong);
  motion(MotionFeature::kDwDs, MotionTarget::kHeading);
  motion(MotionFeature::kRevNearDs, MotionTarget::kAlong);
  if constexpr (!kSync) {
    motion(MotionFeature::kAccRDs, MotionTarget::kWheelR);
    motion(MotionFeature::kAccLDs, MotionTarget::kWheelL);
    motion(MotionFeature::kDsRSpeed, MotionTarget::kWheelR);
    motion(MotionFeature::kDsLSpeed, MotionTarget::kWheelL);
    motion(MotionFeature::kAbsDs, MotionTarget::kWheelR);
    motion(MotionFeature::kAbsDs, MotionTarget::kWheelL);
    motion(MotionFeature::kSDs, MotionTarget::kWheelR);
    motion(MotionFeature::kSDs, MotionTarget::kWheelL);
    terms.push_back({Term::Kind::kReversal, MotionFeature::kNone, MotionTarget::kWheelR, BeamFeature::kNone, 0});
    terms.push_back({Term::Kind::kReversal, MotionFeature::kNone, MotionTarget::kWheelL, BeamFeature::kNone, 1});
  }
  const int nt = static_cast<int>(terms.size());

  // Segments between fused measurements, at least kSegmentS apart, after the warm-up.
  const auto& ev = en_.events();
  const auto& post = run.post;
  const double t0 = ev.empty() ? 0.0 : ev.front().t;
  const std::vector<LaserPose> lp = smoothed(laserPoses(run), run, model, x);
  std::vector<int> bounds;
  for (std::size_t i = 0; i < post.size(); ++i) {
    if (post[i].t - t0 < opt_.warmup_s || !lp[i].ok) continue;
    if (bounds.empty() || post[i].t - post[static_cast<std::size_t>(bounds.back())].t >= kSegmentS)
      bounds.push_back(static_cast<int>(i));
  }
  struct Seg {
    double t, tm;
    Eigen::Vector3d r;
    Eigen::MatrixXd a;      // 3 x terms
    Eigen::VectorXd state;  // the segment's state (dependence.hpp); empty: none
    Eigen::Vector3d per_m;  // r per metre in the robot frame
    double travel;
  };
  SegmentState seg_state;
  std::vector<Seg> segs;
  // The model's context, with the motion's history for the history features whether or not
  // the model reads it (a HistoryMotionContext is every model's Context or derives from it).
  HistoryMotionContext<S> ctx;
  int last_sign[3] = {0, 0, 0};  // robot, right wheel, left wheel
  std::size_t next_bound = 0;
  Pose<S> pp{};
  bool in_seg = false;
  double seg_start = 0;
  Eigen::MatrixXd acc(3, nt);
  Eigen::MatrixXd th_acc(1, nt), thp_acc(2, nt);  // sum of heading parts, and of heading part x position
  for (std::size_t k = 0; k < ev.size(); ++k) {
    const Event& e = ev[k];
    const typename Drive::Input u{e.a, e.b};
    ctx.dt = e.dt;
    ctx.x = pp.x;
    ctx.y = pp.y;
    ctx.setHeading(pp.theta);
    Increment<S> drive_inc;
    const Increment<S> inc = model.increment(u, x, nu0, ctx, nullptr, nullptr, &drive_inc);
    const Increment<S> dinc = model.drive.increment(u, p, nu0);
    if (in_seg) {
      // every term's displacement at this cycle, per unit coefficient
      const double m = pp.theta + 0.5 * inc.theta, cm = std::cos(m), sm = std::sin(m);
      const Pose<S> after = applyIncrement(pp, inc);
      const double wheel_travel[3] = {dinc.rho, dinc.rho + 0.5 * d * dinc.theta, dinc.rho - 0.5 * d * dinc.theta};
      int rev[3] = {0, 0, 0};
      for (int w = 0; w < 3; ++w) {
        const int sg = wheel_travel[w] > 0 ? 1 : (wheel_travel[w] < 0 ? -1 : 0);
        if (sg != 0 && last_sign[w] != 0 && sg != last_sign[w]) rev[w] = sg;
      }
      seg_state.cycle(e.dt, dinc.rho, dinc.theta, wheel_travel[1], wheel_travel[2], pp.x, pp.y, pp.theta);
      for (int j = 0; j < nt; ++j) {
        const Term& tm = terms[static_cast<std::size_t>(j)];
        double f;
        if (tm.kind == Term::Kind::kReversal)
          f = tm.mt == MotionTarget::kAlong ? rev[0] : rev[1 + tm.wheel];
        else
          f = effects::motionFeature(tm.mf, dinc.rho, dinc.theta, ctx, d, xc, yc).f;
        if (f == 0) continue;
        S dir[3];
        effects::motionTargetDirection(tm.mt, ctx, d, dir);
        const double dr = f * dir[0], dth = f * dir[1], ds = f * dir[2];
        acc(0, j) += dr * cm - ds * sm;
        acc(1, j) += dr * sm + ds * cm;
        acc(2, j) += dth;
        th_acc(0, j) += dth;
        thp_acc(0, j) += dth * after.x;
        thp_acc(1, j) += dth * after.y;
      }
      pp = after;
    }
    for (int w = 0; w < 3; ++w) {
      const double tr = w == 0 ? dinc.rho : (w == 1 ? dinc.rho + 0.5 * d * dinc.theta : dinc.rho - 0.5 * d * dinc.theta);
      const int sg = tr > 0 ? 1 : (tr < 0 ? -1 : 0);
      if (sg != 0) last_sign[w] = sg;
    }
    model.advanceContext(ctx, drive_inc, Drive::encoderTravel(u));
    if constexpr (!M::kHasHistory) ctx.advanceHistory(dinc.rho, dinc.theta, e.dt);
    // A boundary: close the open segment, open the next.
    if (next_bound < bounds.size() && post[static_cast<std::size_t>(bounds[next_bound])].event == static_cast<int>(k)) {
      const LaserPose& q = lp[static_cast<std::size_t>(bounds[next_bound])];
      if (in_seg) {
        Seg sg;
        sg.t = q.t;
        sg.tm = 0.5 * (q.t + seg_start);
        sg.r = Eigen::Vector3d(q.x - pp.x, q.y - pp.y, wrapAngle(q.th - pp.theta));
        // a heading part at a cycle turns the rest of the segment's path about that cycle
        sg.a = acc;
        for (int j = 0; j < nt; ++j) {
          sg.a(0, j) += -(th_acc(0, j) * pp.y - thp_acc(1, j));
          sg.a(1, j) += th_acc(0, j) * pp.x - thp_acc(0, j);
        }
        if (!seg_state.row(!kSync, &sg.state)) sg.state.resize(0);
        sg.per_m = seg_state.perMetre(sg.r);
        sg.travel = seg_state.travel();
        if (sg.r.template head<2>().norm() < kMaxSegmentM) segs.push_back(sg);
      }
      seg_state.open(q.t - t0, ctx.s_abs, ctx.s_rev);
      pp = Pose<S>{q.x, q.y, q.th};  // the measurement's own pose: no filter lag
      seg_start = q.t;
      acc.setZero();
      th_acc.setZero();
      thp_acc.setZero();
      in_seg = true;
      ++next_bound;
    }
  }

  // Standardised rows: each component over its robust scale.
  Scales own;
  for (int c = 0; c < 3; ++c) {
    std::vector<double> v;
    for (const Seg& s : segs) v.push_back(s.r[c]);
    own.motion[c] = robustScale(v);
  }
  if (scales != nullptr && scales->motion[0] > 0) {
    for (int c = 0; c < 3; ++c) own.motion[c] = scales->motion[c];
  }
  Design& dm = out.motion;
  dm.n_nuisance = n_nuisance;
  const Eigen::Index rows = static_cast<Eigen::Index>(segs.size()) * 3;
  dm.x.resize(rows, nt);
  dm.y.resize(rows);
  dm.t.resize(rows);
  TimeClusters motion_cluster(kClusterS);
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const int fold = foldOfTime(segs[i].tm - t0, kCvBlockS, dm.folds), cl = motion_cluster(segs[i].tm - t0);
    for (int c = 0; c < 3; ++c) {
      const Eigen::Index r = static_cast<Eigen::Index>(i) * 3 + c;
      dm.y[r] = segs[i].r[c] / own.motion[c];
      dm.x.row(r) = segs[i].a.row(c) / own.motion[c];
      dm.t[r] = segs[i].t;
      dm.fold.push_back(fold);
      dm.cluster.push_back(cl);
    }
  }
  // The same segments for the non-parametric step (dependence.hpp): travel below 5 cm
  // says nothing per metre.
  StateTable& st = out.state;
  stateVariables(!kSync, &st.names, &st.units);
  st.folds = dm.folds;
  const auto nsv = static_cast<Eigen::Index>(st.names.size());
  st.state = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(segs.size()), nsv);
  st.response = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(segs.size()), 3);
  st.weight = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(segs.size()));
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    st.fold.push_back(foldOfTime(segs[i].tm - t0, kCvBlockS, dm.folds));
    if (segs[i].state.size() != nsv || segs[i].travel < 0.05) continue;
    st.state.row(k) = segs[i].state.transpose();
    st.response.row(k) = segs[i].per_m.transpose();
    st.weight[k] = segs[i].travel;
  }
  out.segments = static_cast<int>(segs.size());
  out.seg_s = segs.size() > 1 ? (segs.back().t - segs.front().t) / double(segs.size() - 1) : 0.0;

  // Beams at the posterior.
  std::vector<Term>& bterms = out.beam_terms;
  for (int f = 1; f < effects::kBeamFeatureCount; ++f)
    bterms.push_back({Term::Kind::kBeam, MotionFeature::kNone, MotionTarget::kAlong, static_cast<BeamFeature>(f)});
  bterms.push_back({Term::Kind::kTime});  // the time since the log's start: the host knows it, the core does not
  const int nb = static_cast<int>(bterms.size());
  std::vector<double> nus;
  for (const PostBeam& b : run.post_beams) nus.push_back(b.nu);
  own.beam = scales != nullptr && scales->beam > 0 ? scales->beam : robustScale(nus);
  std::vector<std::pair<const PostBeam*, effects::BeamFeatureInputs<S>>> kept;
  for (const PostBeam& b : run.post_beams) {
    const PostPose& q = post[static_cast<std::size_t>(b.post)];
    if (q.t - t0 < opt_.warmup_s || std::abs(b.nu) > kMaxBeamZ * own.beam) continue;
    effects::BeamFeatureInputs<S> in;
    if (!effects::beamFeatureInputs(en_.map(), en_.laser(), q.x, q.y, q.th, b.beam, q.v, q.w, &in)) continue;
    kept.push_back({&b, in});
  }
  Design& db = out.beam;
  db.n_nuisance = 0;
  db.x.resize(static_cast<Eigen::Index>(kept.size()), nb);
  db.y.resize(static_cast<Eigen::Index>(kept.size()));
  db.t.resize(static_cast<Eigen::Index>(kept.size()));
  TimeClusters beam_cluster(kClusterS);
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const Eigen::Index r = static_cast<Eigen::Index>(i);
    const PostPose& q = post[static_cast<std::size_t>(kept[i].first->post)];
    db.y[r] = kept[i].first->nu / own.beam;
    for (int j = 0; j < nb; ++j) {
      const Term& tm = bterms[static_cast<std::size_t>(j)];
      db.x(r, j) = (tm.kind == Term::Kind::kTime ? q.t - t0 : effects::beamFeature(tm.bf, kept[i].second)) / own.beam;
    }
    db.t[r] = q.t;
    db.fold.push_back(foldOfTime(q.t - t0, kCvBlockS, db.folds));
    db.cluster.push_back(beam_cluster(q.t - t0));
  }
  out.beams = static_cast<long>(kept.size());
  if (scales != nullptr && !(scales->motion[0] > 0)) *scales = own;

  const SelectOptions sel;
  out.motion_sel = forwardSelect(dm, sel);
  out.beam_sel = forwardSelect(db, sel);
  return out;
}

template <typename En>
json Discovery<En>::changePoints(const Residuals& r, const Residuals* final_) const {
  json cps = json::array();
  auto scan = [](const Residuals& x) {
    if (x.segments < 40) return ChangePoint{};
    Design d = x.motion;
    d.x = d.x.leftCols(d.n_nuisance).eval();
    return scanChange(d);
  };
  const ChangePoint cp = scan(r);
  if (!cp.found) return cps;
  const Design& d = r.motion;
  std::string what = "the drive parameters change:";
  for (int i = 0; i < d.n_nuisance; ++i) {
    const Term& t = r.motion_terms[static_cast<std::size_t>(i)];
    const double delta = cp.after[static_cast<std::size_t>(i)] - cp.before[static_cast<std::size_t>(i)];
    const std::string who = t.mt == MotionTarget::kWheelR   ? " the right wheel's travel scale"
                            : t.mt == MotionTarget::kWheelL ? " the left wheel's travel scale"
                            : t.mt == MotionTarget::kAlong  ? " the travel scale"
                            : t.mf == MotionFeature::kDth   ? " the turn scale"
                                                            : " the heading drift per metre";
    what += (i ? "," : "") + who + fmt(" %+.2f %%", 1e2 * delta);
  }
  cps.push_back({{"t", cp.t}, {"t_lo", cp.t_lo}, {"t_hi", cp.t_hi}, {"what", what},
                 {"statistic", cp.stat}, {"critical_0.1pct", cp.threshold}, {"p_value", cp.p_value}, {"residual", "motion"},
                 {"remains_with_named", final_ == nullptr ? json(nullptr) : json(scan(*final_).found)}});
  return cps;
}

template class Discovery<Engine<SyncDrive>>;
template class Discovery<Engine<DiffDrive>>;
template class Discovery<Engine<SyncDrive, Featured>>;
template class Discovery<Engine<DiffDrive, Featured>>;

}  // namespace odoerr::sim::diag
