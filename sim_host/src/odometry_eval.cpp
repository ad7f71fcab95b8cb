// odoerr evaluate's measures: dead reckoning with given constants, the relative pose error
// over a length of path (evo's definition), the error growth K_w predicts, and UMBmark.
#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "odoerr/effects/features.hpp"
#include "odoerr/motion.hpp"
#include "odoerr/sim/evaluate.hpp"

namespace odoerr::sim {

using json = nlohmann::ordered_json;

namespace {

std::vector<double> pathOf(const std::vector<Pose2>& ref) {
  std::vector<double> s(ref.size(), 0.0);
  for (std::size_t k = 1; k < ref.size(); ++k)
    s[k] = s[k - 1] + std::hypot(ref[k].x - ref[k - 1].x, ref[k].y - ref[k - 1].y);
  return s;
}

/// The segments' (start, end) samples: a start at the first sample at or after every
/// `step` of path, its end at the first sample delta of path further.
std::vector<std::pair<std::size_t, std::size_t>> segmentPairs(const std::vector<Pose2>& ref, double delta, double step) {
  const std::vector<double> s = pathOf(ref);
  std::vector<std::pair<std::size_t, std::size_t>> out;
  double next = 0;
  std::size_t j = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] < next) continue;
    next = (std::floor(s[i] / step + 1e-9) + 1) * step;
    j = std::max(j, i);
    while (j < s.size() && s[j] - s[i] < delta) ++j;
    if (j >= s.size()) break;
    out.push_back({i, j});
  }
  return out;
}

/// The dead-reckoned pose at each encoder record (heading unwrapped).
struct Track {
  std::vector<double> t, x, y, th, dr, dl;  // dr, dl: the step's wheel travel ending at the record
};

bool track(const Odolog& log, const OdoConstants& c, Track* tr, std::string* error) {
  if (log.drive != "diff") {
    *error = log.path + ": odometry evaluation supports diff-drive logs (this one is '" + log.drive + "')";
    return false;
  }
  if (!log.has_init || log.enc.size() < 2) {
    *error = log.path + ": needs an 'init' record and at least two 'enc' records";
    return false;
  }
  const DriveConstants dc = driveConstants(log, false);
  double x = log.init.x, y = log.init.y, th = log.init.theta;
  const double b = dc.wheelbase * c.delta_d;
  tr->t.push_back(log.enc[0].t);
  tr->x.push_back(x);
  tr->y.push_back(y);
  tr->th.push_back(th);
  tr->dr.push_back(0);
  tr->dl.push_back(0);
  HistoryMotionContext<double> ctx;  // what FeatureMotion reads (its history features too)
  for (std::size_t k = 1; k < log.enc.size(); ++k) {
    const double ea = double(log.enc[k].a - log.enc[k - 1].a) / dc.ticks_a;
    const double eb = double(log.enc[k].b - log.enc[k - 1].b) / dc.ticks_b;
    const double dr = c.delta_R * ea, dl = c.delta_L * eb;
    double rho = 0.5 * (dr + dl), dth = (dr - dl) / b, side = 0;
    if (!c.terms.empty()) {  // the feature terms, as the core's FeatureMotion applies them
      ctx.dt = log.enc[k].t - log.enc[k - 1].t;
      ctx.x = x;
      ctx.y = y;
      ctx.setHeading(th);
      const double r0 = rho, t0 = dth;
      for (const OdoTerm& term : c.terms) {
        const auto v = effects::motionFeature(static_cast<effects::MotionFeature>(term.feature), r0, t0, ctx,
                                              dc.wheelbase, 0.0, 0.0);
        double dir[3];
        effects::motionTargetDirection(static_cast<effects::MotionTarget>(term.target), ctx, dc.wheelbase, dir);
        rho += term.coef * v.f * dir[0];
        dth += term.coef * v.f * dir[1];
        side += term.coef * v.f * dir[2];
      }
      ctx.advance(r0, 0.5 * (ea + eb));
      ctx.advanceHistory(r0, t0, ctx.dt);
    }
    const double m = th + 0.5 * dth;
    x += rho * std::cos(m) - side * std::sin(m);
    y += rho * std::sin(m) + side * std::cos(m);
    th += dth;
    tr->t.push_back(log.enc[k].t);
    tr->x.push_back(x);
    tr->y.push_back(y);
    tr->th.push_back(th);
    tr->dr.push_back(dr);
    tr->dl.push_back(dl);
  }
  return true;
}

/// se(2) relative motion from a to b, in a's frame.
Pose2 relative(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.th), s = std::sin(a.th), dx = b.x - a.x, dy = b.y - a.y;
  return {b.t - a.t, c * dx + s * dy, -s * dx + c * dy, wrapAngle(b.th - a.th)};
}

}  // namespace

std::vector<RpeSegment> rpeSegments(const std::vector<Pose2>& ref, const std::vector<Pose2>& est, double delta,
                                    double step) {
  std::vector<RpeSegment> out;
  if (ref.size() != est.size()) return out;
  for (const auto& [i, j] : segmentPairs(ref, delta, step)) {
    const Pose2 q = relative(ref[i], ref[j]), p = relative(est[i], est[j]);
    // E = q^-1 p: its translation R(-q.th)(p.t - q.t) has the norm of p.t - q.t
    out.push_back({i, j, std::hypot(p.x - q.x, p.y - q.y), std::abs(wrapAngle(p.th - q.th))});
  }
  return out;
}

json rpeJson(const std::vector<RpeSegment>& segs) {
  if (segs.empty())
    return {{"trans_m", nullptr}, {"rot_rad", nullptr}, {"trans_rmse_m", nullptr}, {"rot_rmse_rad", nullptr},
            {"segments", 0}, {"note", "no segment: the reference path is shorter than the length"}};
  double t = 0, t2 = 0, r = 0, r2 = 0;
  for (const RpeSegment& s : segs) {
    t += s.trans;
    t2 += s.trans * s.trans;
    r += s.rot;
    r2 += s.rot * s.rot;
  }
  const double n = double(segs.size());
  return {{"trans_m", t / n}, {"rot_rad", r / n}, {"trans_rmse_m", std::sqrt(t2 / n)},
          {"rot_rmse_rad", std::sqrt(r2 / n)}, {"segments", segs.size()}};
}

bool integrateOdometry(const Odolog& log, const OdoConstants& c, const std::vector<double>& times,
                       std::vector<Pose2>* out, std::string* error) {
  Track tr;
  if (!track(log, c, &tr, error)) return false;
  out->clear();
  std::size_t k = 0;
  for (double t : times) {
    while (k + 1 < tr.t.size() && tr.t[k + 1] <= t) ++k;
    if (k + 1 >= tr.t.size() || t <= tr.t[k]) {
      out->push_back({t, tr.x[k], tr.y[k], tr.th[k]});
      continue;
    }
    const double f = (t - tr.t[k]) / (tr.t[k + 1] - tr.t[k]);
    out->push_back({t, tr.x[k] + f * (tr.x[k + 1] - tr.x[k]), tr.y[k] + f * (tr.y[k + 1] - tr.y[k]),
                    tr.th[k] + f * (tr.th[k + 1] - tr.th[k])});
  }
  return true;
}

std::vector<Pose2> referenceOf(const Odolog& log, std::string* kind) {
  std::vector<Pose2> ref;
  if (!log.truth.empty()) {
    *kind = "truth";
    for (const auto& r : log.truth) ref.push_back({r.t, r.x, r.y, r.theta});
  } else if (!log.poses.empty()) {
    *kind = "pose_fixes";
    for (const auto& r : log.poses) ref.push_back({r.t, r.x, r.y, r.theta});
  } else {
    *kind = "";
  }
  return ref;
}

double predictedRpeSigma(const Odolog& log, const OdoConstants& c, double k_w, const std::vector<Pose2>& ref,
                         double delta, double step) {
  Track tr;
  std::string err;
  if (!track(log, c, &tr, &err)) return -1;
  const DriveConstants dc = driveConstants(log, false);
  const double b = dc.wheelbase * c.delta_d;
  const auto pairs = segmentPairs(ref, delta, step);
  if (pairs.empty()) return -1;
  double sum = 0;
  for (const auto& [i, j] : pairs) {
    const double t0 = ref[i].t, t1 = ref[j].t;
    Eigen::Matrix3d p = Eigen::Matrix3d::Zero();
    const std::size_t k0 = static_cast<std::size_t>(std::upper_bound(tr.t.begin(), tr.t.end(), t0) - tr.t.begin());
    for (std::size_t k = std::max<std::size_t>(k0, 1); k < tr.t.size() && tr.t[k] <= t1; ++k) {
      const double dr = tr.dr[k], dl = tr.dl[k];
      const double rho = 0.5 * (dr + dl), dth = (dr - dl) / b, m = tr.th[k - 1] + 0.5 * dth;
      const double cm = std::cos(m), sm = std::sin(m);
      Eigen::Matrix3d f = Eigen::Matrix3d::Identity();
      f(0, 2) = -rho * sm;
      f(1, 2) = rho * cm;
      Eigen::Matrix<double, 3, 2> g;  // d pose / d (right, left) travel noise
      g << 0.5 * cm - 0.5 * rho * sm / b, 0.5 * cm + 0.5 * rho * sm / b,  //
          0.5 * sm + 0.5 * rho * cm / b, 0.5 * sm - 0.5 * rho * cm / b,   //
          1 / b, -1 / b;
      // K_w scales the variance of the encoder travel (as the estimator's noise model)
      const double ur = std::abs(dr / c.delta_R), ul = std::abs(dl / c.delta_L);
      const Eigen::Matrix2d q = Eigen::Vector2d(k_w * ur, k_w * ul).asDiagonal();
      p = f * p * f.transpose() + g * q * g.transpose();
    }
    sum += p(0, 0) + p(1, 1);
  }
  return std::sqrt(sum / double(pairs.size()));
}

bool umbmark(const std::vector<Odolog>& squares, double side_m, UmbmarkResult* out, std::string* error) {
  UmbmarkResult r;
  double b_nom = 0;
  for (const Odolog& log : squares) {
    std::string kind;
    const std::vector<Pose2> ref = referenceOf(log, &kind);
    if (ref.size() < 2) {
      *error = log.path + ": UMBmark needs the run's true end pose (truth or pose records)";
      return false;
    }
    std::vector<Pose2> odo;
    if (!integrateOdometry(log, OdoConstants{}, {ref.front().t, ref.back().t}, &odo, error)) return false;
    b_nom = driveConstants(log, false).wheelbase;
    // the return errors in the start frame (x along the initial heading), abs - calc
    const Pose2 s = ref.front();
    const Pose2 qa = relative(s, ref.back()), qc = relative(s, {odo[1].t, odo[1].x, odo[1].y, odo[1].th});
    const double ex = qa.x - qc.x, ey = qa.y - qc.y;
    // the direction: the sign of the total turn of the reference
    double turn = 0;
    for (std::size_t k = 1; k < ref.size(); ++k) turn += wrapAngle(ref[k].th - ref[k - 1].th);
    if (turn < 0) {
      r.x_cw += ex;
      r.y_cw += ey;
      ++r.n_cw;
    } else {
      r.x_ccw += ex;
      r.y_ccw += ey;
      ++r.n_ccw;
    }
  }
  if (r.n_cw == 0 || r.n_ccw == 0) {
    *error = "UMBmark needs square runs in both directions (cw " + std::to_string(r.n_cw) + ", ccw " +
             std::to_string(r.n_ccw) + ")";
    return false;
  }
  r.x_cw /= r.n_cw;
  r.y_cw /= r.n_cw;
  r.x_ccw /= r.n_ccw;
  r.y_ccw /= r.n_ccw;
  // Borenstein & Feng (1996): alpha from the wheelbase error (type A), beta from the
  // unequal wheel diameters (type B), both in rad.
  const double L = side_m;
  r.alpha = (r.x_cw + r.x_ccw) / (-4 * L);
  r.beta = (r.x_cw - r.x_ccw) / (-4 * L);
  r.radius = std::abs(r.beta) > 1e-12 ? (L / 2) / std::sin(r.beta / 2) : 1e300;
  r.ed = std::abs(r.beta) > 1e-12 ? (r.radius + b_nom / 2) / (r.radius - b_nom / 2) : 1.0;
  r.eb = (kPi<double> / 2) / (kPi<double> / 2 - r.alpha);
  r.c.delta_L = 2 / (r.ed + 1);
  r.c.delta_R = 2 / (1 / r.ed + 1);
  r.c.delta_d = r.eb;
  *out = r;
  return true;
}

}  // namespace odoerr::sim
