#include "odoerr/sim/map_drive.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include "odoerr/sim/odolog_writer.hpp"
#include "odoerr/sim/random.hpp"

namespace odoerr::sim {

MapDrive::MapDrive(const MapDriveConfig& cfg, const HostMap<double>& map, std::uint64_t seed)
    : cfg_(cfg), map_(map), rng_(seed) {
  drive_.wheelbase = cfg_.wheelbase_m;
  if (cfg_.path.size() < 2) {
    error_ = "the path needs at least two points";
    return;
  }
  const PathPoint& a = cfg_.path[0];
  const PathPoint& b = cfg_.path[1];
  if (!(std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(b.x) && std::isfinite(b.y)) ||
      (a.x == b.x && a.y == b.y)) {
    error_ = "the path's first two points must be finite and distinct";
    return;
  }
  truth_ = {a.x, a.y, std::atan2(b.y - a.y, b.x - a.x)};
  odoerr::sim::NormalDist<double> n01(0.0, 1.0);
  init_est_.x = truth_.x + cfg_.init_sigma_xy * n01(rng_);
  init_est_.y = truth_.y + cfg_.init_sigma_xy * n01(rng_);
  init_est_.theta = wrapAngle(truth_.theta + cfg_.init_sigma_theta * n01(rng_));
}

bool MapDrive::ok(std::string* error) const {
  if (error_.empty()) return true;
  *error = error_;
  return false;
}

double MapDrive::curvature() {
  // Pure pursuit: the point lookahead_m further along the path than the robot's projection
  // on its current segment (segments are left once the projection passes their end).
  const auto& P = cfg_.path;
  const std::size_t n = P.size();
  auto next = [&](std::size_t i) { return i + 1 < n ? i + 1 : (cfg_.loop ? 0 : i); };
  double t = 0;
  for (std::size_t guard = 0; guard < n; ++guard) {
    const PathPoint& a = P[seg_];
    const PathPoint& b = P[next(seg_)];
    const double ex = b.x - a.x, ey = b.y - a.y, l2 = ex * ex + ey * ey;
    t = l2 > 0 ? ((truth_.x - a.x) * ex + (truth_.y - a.y) * ey) / l2 : 1.0;
    if (t < 1.0 || next(seg_) == seg_ || next(next(seg_)) == next(seg_)) break;
    seg_ = next(seg_);
  }
  t = t < 0 ? 0 : (t > 1 ? 1 : t);
  std::size_t i = seg_;
  double px = P[i].x + t * (P[next(i)].x - P[i].x), py = P[i].y + t * (P[next(i)].y - P[i].y);
  double left = cfg_.lookahead_m;
  for (std::size_t guard = 0; guard < n && left > 0; ++guard) {
    const PathPoint& b = P[next(i)];
    const double d = std::hypot(b.x - px, b.y - py);
    if (d >= left) {
      px += (b.x - px) * left / d;
      py += (b.y - py) * left / d;
      break;
    }
    left -= d;
    px = b.x;
    py = b.y;
    if (next(i) == i) break;
    i = next(i);
  }
  const double dx = px - truth_.x, dy = py - truth_.y;
  const double c = std::cos(truth_.theta), s = std::sin(truth_.theta);
  const double lx = c * dx + s * dy, ly = -s * dx + c * dy;  // the point in the robot frame
  const double d2 = lx * lx + ly * ly;
  double kappa = d2 > 1e-12 ? 2.0 * ly / d2 : 0.0;
  // A point far off the heading (a corner of the path): turn at the tightest curvature.
  if (std::abs(std::atan2(ly, lx)) > kPi<double> / 4) kappa = ly >= 0 ? cfg_.max_curvature : -cfg_.max_curvature;
  if (kappa > cfg_.max_curvature) kappa = cfg_.max_curvature;
  if (kappa < -cfg_.max_curvature) kappa = -cfg_.max_curvature;
  return kappa;
}

MapDriveStep MapDrive::step() {
  const double kappa = curvature();
  // Commanded true wheel travel; the encoders read it through the true systematic
  // parameters (true = delta * encoder).
  const double s = cfg_.step_m;
  const double half = 0.5 * kappa * s * cfg_.wheelbase_m * cfg_.delta_d;
  pos_r_ += (s + half) / cfg_.delta_r;
  pos_l_ += (s - half) / cfg_.delta_l;
  MapDriveStep out;
  const double tpm = ticksPerMetre();
  out.counts.count_a = static_cast<std::int64_t>(std::llround(pos_r_ * tpm));
  out.counts.count_b = static_cast<std::int64_t>(std::llround(pos_l_ * tpm));
  out.input.right = double(out.counts.count_a - counts_.count_a) / tpm;
  out.input.left = double(out.counts.count_b - counts_.count_b) / tpm;
  counts_ = out.counts;
  const DiffDrive<double>::NoiseVec var = drive_.noiseVariance(out.input, trueNonSys());
  DiffDrive<double>::NoiseVec nu;
  odoerr::sim::NormalDist<double> n01(0.0, 1.0);
  for (int i = 0; i < 2; ++i) nu[i] = std::sqrt(var[i]) * n01(rng_);
  const Increment<double> inc =
      drive_.increment(out.input, DiffDrive<double>::ParamVec(cfg_.delta_r, cfg_.delta_l, cfg_.delta_d), nu);
  const Pose<double> before = truth_;
  truth_ = applyIncrement(truth_, inc);
  // The robot must not pass through a wall (a path too close to one, or cut by the
  // pursuit's corners): the drive would be nonsense, so it is refused.
  const double mx = truth_.x - before.x, my = truth_.y - before.y, d = std::hypot(mx, my);
  if (error_.empty() && d > 0) {
    const RayHit<double> hit = map_.view().castDir(before.x, before.y, mx / d, my / d, 1e-9, d);
    if (hit.hit) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "the path runs the robot into wall %d at (%.2f, %.2f) after %.2f s", hit.wall,
                    before.x + hit.range * mx / d, before.y + hit.range * my / d, double(k_ + 1) * cfg_.dt_s);
      error_ = buf;
    }
  }
  ++k_;
  out.t = double(k_) * cfg_.dt_s;
  out.truth = truth_;
  scan(truth_, &out.ranges);
  return out;
}

void MapDrive::scan(const Pose<double>& p, std::vector<double>* ranges) {
  const auto& l = cfg_.laser;
  ranges->assign(std::size_t(l.beams), std::numeric_limits<double>::quiet_NaN());
  odoerr::sim::NormalDist<double> n01(0.0, 1.0);
  const double c = std::cos(p.theta), sn = std::sin(p.theta);
  const double lx = p.x + c * l.mount_x - sn * l.mount_y;
  const double ly = p.y + sn * l.mount_x + c * l.mount_y;
  const MapView<double> view = map_.view();
  for (int i = 0; i < l.beams; ++i) {
    const double a = p.theta + l.mount_yaw + l.angle_min + i * l.angle_inc;
    const RayHit<double> h = view.castDir(lx, ly, std::cos(a), std::sin(a), 1e-6, l.range_max);
    const double noise = l.sigma * n01(rng_);
    if (!h.hit) continue;
    const double r = h.range + noise;
    if (r > 0.0 && r <= l.range_max) (*ranges)[std::size_t(i)] = r;
  }
}

bool readPath(const std::string& path, std::vector<PathPoint>* out, std::string* error) {
  out->clear();
  std::ifstream f(path);
  if (!f) {
    *error = "cannot open path file '" + path + "'";
    return false;
  }
  std::string first;
  std::getline(f, first);
  if (first.rfind("odolog", 0) == 0) {
    Odolog log;
    if (!readOdolog(path, &log, error)) return false;
    for (const auto& t : log.truth) {
      if (out->empty() || std::hypot(t.x - out->back().x, t.y - out->back().y) >= 0.1) out->push_back({t.x, t.y});
    }
    if (out->size() < 2) {
      *error = path + ": the log's truth records give fewer than two path points 0.1 m apart";
      return false;
    }
    return true;
  }
  f.seekg(0);
  std::string line;
  int n = 0;
  while (std::getline(f, line)) {
    ++n;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream is(line);
    double x, y;
    if (!(is >> x)) continue;  // blank or comment
    std::string rest;
    if (!(is >> y) || (is >> rest) || !std::isfinite(x) || !std::isfinite(y)) {
      *error = path + ":" + std::to_string(n) + ": a path line is 'X Y' (two finite numbers)";
      return false;
    }
    out->push_back({x, y});
  }
  if (out->size() < 2) {
    *error = path + ": a path needs at least two points";
    return false;
  }
  return true;
}

bool mapDriveOdolog(const MapDriveConfig& cfg, const std::vector<OdologWall>& walls, std::uint64_t seed,
                    const std::string& map_name, std::string* text, std::string* error) {
  HostMap<double> map;
  if (!map.build(walls, -1, error)) return false;
  MapDrive drive(cfg, map, seed);
  if (!drive.ok(error)) return false;
  char buf[256];
  std::string& out = *text;
  out = "odolog 1\n";
  out += "meta source odoerr-sim map-drive map=" + map_name + " seed=" + std::to_string(seed) +
         " steps=" + std::to_string(cfg.steps) + "\n";
  std::snprintf(buf, sizeof buf, "meta truth delta_R=%.9g delta_L=%.9g delta_d=%.9g K_w=%.9g\n", cfg.delta_r,
                cfg.delta_l, cfg.delta_d, cfg.k_w);
  out += buf;
  out += "drive diff\n";
  std::snprintf(buf, sizeof buf, "param wheel_radius_m %.9g\nparam ticks_per_rev %.9g\nparam wheelbase_m %.9g\n",
                cfg.wheel_radius_m, cfg.ticks_per_rev, cfg.wheelbase_m);
  out += buf;
  const auto& l = cfg.laser;
  std::snprintf(buf, sizeof buf, "laser %d %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", l.beams, l.angle_min, l.angle_inc,
                l.range_max, l.sigma, l.mount_x, l.mount_y, l.mount_yaw);
  out += buf;
  for (const auto& w : walls) {
    std::snprintf(buf, sizeof buf, "wall %.9g %.9g %.9g %.9g\n", w.x1, w.y1, w.x2, w.y2);
    out += buf;
  }
  const Pose<double> p = drive.initialEstimate();
  std::snprintf(buf, sizeof buf, "init %.9g %.9g %.9g %.9g %.9g %.9g\n", p.x, p.y, p.theta, cfg.init_sigma_xy,
                cfg.init_sigma_xy, cfg.init_sigma_theta);
  out += buf;
  const Pose<double> t = drive.truth();
  std::snprintf(buf, sizeof buf, "enc 0.000000 0 0\ntruth 0.000000 %.9g %.9g %.9g\n", t.x, t.y, t.theta);
  out += buf;
  for (int k = 0; k < cfg.steps; ++k) {
    const MapDriveStep st = drive.step();
    if (!drive.ok(error)) return false;
    std::snprintf(buf, sizeof buf, "enc %.6f %lld %lld\n", st.t, static_cast<long long>(st.counts.count_a),
                  static_cast<long long>(st.counts.count_b));
    out += buf;
    std::snprintf(buf, sizeof buf, "scan %.6f", st.t);
    out += buf;
    for (double r : st.ranges) detail::appendf(out, " %.5f", r);
    out += "\n";
    std::snprintf(buf, sizeof buf, "truth %.6f %.9g %.9g %.9g\n", st.t, st.truth.x, st.truth.y, st.truth.theta);
    out += buf;
  }
  return true;
}

}  // namespace odoerr::sim
