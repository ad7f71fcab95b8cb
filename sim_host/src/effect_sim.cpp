#include "odoerr/sim/effect_sim.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <tuple>

#include "odoerr/effects/catalogue.hpp"
#include "odoerr/effects/feature_effects.hpp"
#include "odoerr/map.hpp"
#include "odoerr/motion.hpp"
#include "odoerr/sim/random.hpp"

namespace odoerr::sim {

namespace {

using effects::SimEffects;  // the catalogue and the effects diagnose does not rank

constexpr double kDt = 0.01;          // encoder period (s)
constexpr int kScanEvery = 10;        // 10 Hz scans
constexpr double kWheelRadius = 0.05;
constexpr double kTicksPerRev = 4096;
constexpr double kWheelbase = 0.5;
constexpr double kSyncTicks = 20000;  // per m and per rad
constexpr double kMountX = 0.1;

template <typename F, std::size_t... I>
void forEachEffect(F&& f, std::index_sequence<I...>) {
  (f(std::tuple_element_t<I, SimEffects>{}), ...);
}
template <typename F>
void forEachEffect(F&& f) {
  forEachEffect(f, std::make_index_sequence<std::tuple_size_v<SimEffects>>{});
}

/// One leg of the driving programme: constant commanded speed and turn rate.
struct Leg {
  double length;  // m of travel (rad of rotation when v == 0)
  double v, w;
};

/// Programme p: a figure-eight about the current centre (heading north), out-and-back
/// runs, then a straight move to the next centre, so that the drive covers the room.
std::vector<Leg> programme(int p) {
  const double r = p % 2 == 0 ? 1.5 : 1.0;
  const double speeds[3] = {0.3, 0.5, 0.8};
  const double centres[3] = {5.0, 3.6, 6.4};
  const double v = speeds[p % 3];
  const double back = std::min(v, 0.5);
  const double move = centres[(p + 1) % 3] - centres[p % 3];
  return {{2 * kPi<double> * r, v, v / r},   // counter-clockwise loop left of the centre
          {2 * kPi<double> * r, v, -v / r},  // clockwise loop right of it
          {0.8, v, 0},                       // out and back: two reversals
          {0.8, -back, 0},
          {0.3, 0.3, 0},
          {0.3, -0.3, 0},
          {2 * kPi<double>, 0, 1.2},  // a turn in place each way (length in rad)
          {2 * kPi<double>, 0, -1.2},
          {std::abs(move), move > 0 ? 0.4 : -0.4, 0}};
}

}  // namespace

std::vector<std::pair<std::string, int>> catalogueEffects() {
  std::vector<std::pair<std::string, int>> out;
  forEachEffect([&](auto e) { out.emplace_back(decltype(e)::kName, decltype(e)::kParams); });
  return out;
}

bool parseEffectArg(const std::string& arg, EffectSimConfig* cfg, std::string* error) {
  const auto eq = arg.find('=');
  if (eq == std::string::npos || eq == 0) {
    *error = "effect '" + arg + "': expected NAME=V1[,V2...]";
    return false;
  }
  const std::string name = arg.substr(0, eq);
  if (name.rfind("feature:", 0) == 0) {
    const std::string spec = name.substr(8);
    const auto at = spec.find('@');
    effects::MotionFeature f;
    effects::MotionTarget t;
    if (at == std::string::npos || !effects::parseMotionFeature(spec.substr(0, at).c_str(), &f) ||
        !effects::parseMotionTarget(spec.substr(at + 1).c_str(), &t) || f == effects::MotionFeature::kNone) {
      *error = "effect '" + arg + "': expected feature:FEATURE@TARGET=C with a motion feature and target of "
               "docs/effect-catalogue.md";
      return false;
    }
    char* end = nullptr;
    const std::string tok = arg.substr(eq + 1);
    const double c = std::strtod(tok.c_str(), &end);
    if (tok.empty() || end == nullptr || *end != '\0' || !std::isfinite(c)) {
      *error = "effect '" + arg + "': '" + tok + "' is not a finite number";
      return false;
    }
    if (cfg->features.size() >= 4) {
      *error = "effect '" + arg + "': at most 4 feature terms";
      return false;
    }
    cfg->features.push_back({spec.substr(0, at), spec.substr(at + 1), c});
    return true;
  }
  std::vector<double> vals;
  std::size_t at = eq + 1;
  while (at <= arg.size()) {
    const auto comma = arg.find(',', at);
    const std::string tok = arg.substr(at, comma == std::string::npos ? std::string::npos : comma - at);
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (tok.empty() || end == nullptr || *end != '\0' || !std::isfinite(v)) {
      *error = "effect '" + arg + "': '" + tok + "' is not a finite number";
      return false;
    }
    vals.push_back(v);
    if (comma == std::string::npos) break;
    at = comma + 1;
  }
  for (const auto& [n, k] : catalogueEffects()) {
    if (n != name) continue;
    if (static_cast<int>(vals.size()) > k || (vals.size() != static_cast<std::size_t>(k) && name != "wall_offset" &&
                                              name != "region_scale")) {
      *error = "effect '" + name + "' takes " + std::to_string(k) + " value(s), got " + std::to_string(vals.size());
      return false;
    }
    vals.resize(k, 0.0);
    cfg->effects[name] = vals;
    return true;
  }
  std::string names;
  for (const auto& [n, k] : catalogueEffects()) names += (names.empty() ? "" : ", ") + n;
  *error = "unknown effect '" + name + "' (the catalogue: " + names + ")";
  return false;
}

bool simulateEffectDrive(const EffectSimConfig& cfg, std::string* text, std::string* error) {
  const bool sync = cfg.drive == "sync";
  if (!sync && cfg.drive != "diff") {
    *error = "drive must be diff or sync, not '" + cfg.drive + "'";
    return false;
  }
  for (const auto& [name, vals] : cfg.effects) {
    bool known = false;
    for (const auto& [n, k] : catalogueEffects()) known = known || (n == name && static_cast<int>(vals.size()) == k);
    if (!known) {
      *error = "effect '" + name + "' is unknown or has the wrong number of values";
      return false;
    }
  }
  if (sync) {  // the sync drive has no separately driven wheels (docs/effect-catalogue.md)
    std::string per_wheel;
    forEachEffect([&](auto e) {
      using E = decltype(e);
      if constexpr (std::is_base_of_v<effects::PerWheel, E>) {
        if (cfg.effects.count(E::kName) != 0) per_wheel = E::kName;
      }
    });
    if (!per_wheel.empty()) {
      *error = "effect '" + per_wheel + "' acts on the wheels of the differential drive; the sync drive has none";
      return false;
    }
  }
  auto param = [&](const char* name, int i) {
    const auto it = cfg.effects.find(name);
    return it == cfg.effects.end() ? 0.0 : it->second[static_cast<std::size_t>(i)];
  };

  // The world as the map says, and as it truly is (walls moved by wall_offset).
  const Segment<double> walls[8] = {{0, 0, 10, 0},     {10, 0, 10, 10},    {10, 10, 0, 10}, {0, 10, 0, 0},
                                    {8.6, 0.8, 9.4, 0.8}, {9.4, 0.8, 9.4, 1.6}, {9.4, 1.6, 8.6, 1.6}, {8.6, 1.6, 8.6, 0.8}};
  SegmentMap<double, 16> true_map;
  for (int w = 0; w < 8; ++w) {
    const auto& s = walls[w];
    const double len = std::hypot(s.x2 - s.x1, s.y2 - s.y1);
    const double nx = -(s.y2 - s.y1) / len;
    const double ny = (s.x2 - s.x1) / len;
    const double o = param("wall_offset", w);
    (void)true_map.add({s.x1 + o * nx, s.y1 + o * ny, s.x2 + o * nx, s.y2 + o * ny});
  }
  LaserConfig<double> laser;  // the nominal set-up written to the log
  laser.mount_x = kMountX;
  const double mount_x = kMountX + param("laser_mount_xy", 0);
  const double mount_y = param("laser_mount_xy", 1);
  const double mount_yaw = param("laser_mount_yaw", 0);
  const double tau = param("scan_latency", 0);
  const double bias = param("range_bias", 0);
  const double scale = param("range_scale", 0);
  const double q_turn = param("turn_noise", 0);

  // Drive truth.
  DiffDrive<double> diff;
  diff.wheelbase = kWheelbase;
  SyncDrive<double> syn;
  const Eigen::Vector3d p_diff(1.01, 0.99, 1.02);
  const Eigen::Vector2d p_sync(1.02, 0.5 * kPi<double> / 180);
  const double k_w = 2.5e-4;
  const Eigen::Vector2d k_sync(1e-4, 3e-5);
  const double ticks_a = sync ? kSyncTicks : kTicksPerRev / (2 * kPi<double> * kWheelRadius);
  const double ticks_b = sync ? kSyncTicks : ticks_a;

  // The motion effects' instances (configured like the estimator's).
  effects::WheelEccentricity ecc;
  ecc.wheel_radius = kWheelRadius;
  effects::RegionScale region;
  region.x_min = 0;
  region.y_min = 0;
  region.x_max = 10;
  region.y_max = 10;
  effects::PerWheel wheels;  // the per-wheel effects' wheelbase and split (diff drive only)
  wheels.wheelbase = kWheelbase;

  std::string& out = *text;
  out.clear();
  char buf[512];
  auto line = [&](const char* fmt, auto... a) {
    if constexpr (sizeof...(a) == 0) {
      out += fmt;
    } else {
      std::snprintf(buf, sizeof buf, fmt, a...);
      out += buf;
    }
  };
  line("odolog 1\n");
  line("meta source odoerr-sim-excite seed=%llu\n", static_cast<unsigned long long>(cfg.seed));
  if (sync) {
    line("meta truth_param delta_rho %.9g\nmeta truth_param E_theta %.9g\n", p_sync[0], p_sync[1]);
    line("meta truth_param K_rho %.9g\nmeta truth_param K_theta %.9g\n", k_sync[0], k_sync[1]);
  } else {
    line("meta truth_param delta_R %.9g\nmeta truth_param delta_L %.9g\nmeta truth_param delta_d %.9g\n", p_diff[0],
         p_diff[1], p_diff[2]);
    line("meta truth_param K_w %.9g\n", k_w);
  }
  for (const auto& [name, vals] : cfg.effects) {
    out += "meta truth_effect " + name;
    for (double v : vals) line(" %.9g", v);
    out += "\n";
  }
  for (const auto& ft : cfg.features) line("meta truth_feature %s@%s %.9g\n", ft.feature.c_str(), ft.target.c_str(), ft.coef);
  line("drive %s\n", sync ? "sync" : "diff");
  if (sync) {
    line("param ticks_per_m %.9g\nparam ticks_per_rad %.9g\nparam wheel_radius_m %.9g\n", kSyncTicks, kSyncTicks,
         kWheelRadius);
  } else {
    line("param wheel_radius_m %.9g\nparam ticks_per_rev %.9g\nparam wheelbase_m %.9g\n", kWheelRadius, kTicksPerRev,
         kWheelbase);
  }
  line("laser %d %.17g %.17g %.9g %.9g %.9g %.9g %.9g\n", laser.beams, laser.angle_min, laser.angle_inc,
       laser.range_max, laser.sigma, laser.mount_x, laser.mount_y, laser.mount_yaw);
  for (const auto& w : walls) line("wall %.9g %.9g %.9g %.9g\n", w.x1, w.y1, w.x2, w.y2);
  Pose<double> truth{5.0, 5.0, kPi<double> / 2};
  line("init %.9g %.9g %.9g 0.005 0.005 0.005\n", truth.x, truth.y, truth.theta);

  std::mt19937_64 rng(cfg.seed * 0x9E3779B97F4A7C15ull + 17);
  odoerr::sim::NormalDist<double> n01(0.0, 1.0);
  Pose<double> plan = truth;
  HistoryMotionContext<double> ctx;  // what every catalogue effect and feature term may depend on
  ctx.dt = kDt;
  // The injected feature terms, as the estimator's FeatureMotion applies them.
  effects::FeatureMotion<4> feature_truth;
  double feature_coef[4] = {0, 0, 0, 0};
  feature_truth.wheelbase = kWheelbase;
  feature_truth.xc = 5.0;  // the room's centre
  feature_truth.yc = 5.0;
  for (std::size_t i = 0; i < cfg.features.size() && i < 4; ++i) {
    effects::MotionFeature f;
    effects::MotionTarget t;
    if (!effects::parseMotionFeature(cfg.features[i].feature.c_str(), &f) ||
        !effects::parseMotionTarget(cfg.features[i].target.c_str(), &t) ||
        !feature_truth.configure(static_cast<int>(i), f, t, 0.0, 0.0)) {
      *error = "feature term '" + cfg.features[i].feature + "@" + cfg.features[i].target + "' is unknown";
      return false;
    }
    feature_coef[i] = cfg.features[i].coef;
  }
  std::vector<Pose<double>> history{truth};
  double pos_a = 0, pos_b = 0;
  std::int64_t cnt_a = 0, cnt_b = 0;
  line("enc 0 0 0\ntruth 0 %.9g %.9g %.9g\n", truth.x, truth.y, truth.theta);
  const long steps = std::lround(cfg.minutes * 60.0 / kDt);
  int prog = 0;
  std::vector<Leg> legs = programme(prog);
  std::size_t leg = 0;
  double leg_done = 0;
  double v_corr = 0, w_corr = 0;
  for (long k = 1; k <= steps; ++k) {
    const double t = k * kDt;
    if (leg_done >= legs[leg].length) {
      leg_done = 0;
      if (++leg == legs.size()) {
        legs = programme(++prog);
        leg = 0;
      }
    }
    const Leg& L = legs[leg];
    // Once a second: a weak correction of the plan-frame error of the true pose.
    if (k % 100 == 0) {
      const double c = std::cos(plan.theta), s = std::sin(plan.theta);
      const double ex = truth.x - plan.x, ey = truth.y - plan.y;
      const double along = c * ex + s * ey;
      const double cross = -s * ex + c * ey;
      const double head = wrapAngle(truth.theta - plan.theta);
      v_corr = -0.3 * along;
      w_corr = -0.5 * cross * L.v - 0.5 * head;
      if (L.v == 0) v_corr = 0;
    }
    const double v = L.v + v_corr;
    const double w = L.w + w_corr;
    plan = applyIncrement(plan, Increment<double>{L.v * kDt, L.w * kDt, 0});
    leg_done += (L.v != 0 ? std::abs(L.v) : std::abs(L.w)) * kDt;
    // Encoders follow the command; counts are quantised, the remainder carried.
    if (sync) {
      pos_a += v * kDt;
      pos_b += w * kDt;
    } else {
      pos_a += (v + 0.5 * w * kWheelbase) * kDt;
      pos_b += (v - 0.5 * w * kWheelbase) * kDt;
    }
    const std::int64_t na = std::llround(pos_a * ticks_a), nb = std::llround(pos_b * ticks_b);
    const double da = double(na - cnt_a) / ticks_a, db = double(nb - cnt_b) / ticks_b;
    cnt_a = na;
    cnt_b = nb;
    // True increment: the drive's error model, then the motion effects. The effects act on
    // the noise-free increment (their speeds and travel are the robot's mean motion, as in
    // the estimator); the drive's noise is added after.
    Increment<double> inc, noisy;
    if (sync) {
      const SyncDrive<double>::Input u{da, db};
      const auto var = syn.noiseVariance(u, k_sync);
      inc = syn.increment(u, p_sync, {0, 0});
      noisy = syn.increment(u, p_sync, {std::sqrt(var[0]) * n01(rng), std::sqrt(var[1]) * n01(rng)});
    } else {
      const DiffDrive<double>::Input u{da, db};
      Eigen::Matrix<double, 1, 1> kw;
      kw << k_w;
      const auto var = diff.noiseVariance(u, kw);
      inc = diff.increment(u, p_diff, {0, 0});
      noisy = diff.increment(u, p_diff, {std::sqrt(var[0]) * n01(rng), std::sqrt(var[1]) * n01(rng)});
    }
    const Increment<double> noise{noisy.rho - inc.rho, noisy.theta - inc.theta, noisy.side - inc.side};
    ctx.x = truth.x;
    ctx.y = truth.y;
    ctx.setHeading(truth.theta);  // the heading at the cycle's start (feature effects)
    const Increment<double> drive_inc = inc;  // the travel totals count the increment before the effects
    forEachEffect([&](auto e) {
      using E = decltype(e);
      if constexpr (E::kKind == EffectKind::kMotion) {
        const auto it = cfg.effects.find(E::kName);
        if (it == cfg.effects.end()) return;
        E inst{};
        if constexpr (std::is_same_v<E, effects::WheelEccentricity>) inst = ecc;
        if constexpr (std::is_same_v<E, effects::RegionScale>) inst = region;
        if constexpr (std::is_base_of_v<effects::PerWheel, E>) inst.wheelbase = wheels.wheelbase;
        Eigen::Matrix3d d_in;
        Eigen::Matrix<double, 3, E::kParams> d_p;
        inc = inst.apply(inc, it->second.data(), ctx, d_in, d_p);
      }
    });
    if (!cfg.features.empty()) {
      Eigen::Matrix3d d_in;
      Eigen::Matrix<double, 3, 4> d_p;
      inc = feature_truth.apply(inc, feature_coef, ctx, d_in, d_p);
    }
    const double turn_noise = q_turn > 0 ? std::sqrt(q_turn * std::abs(inc.theta)) * n01(rng) : 0.0;
    ctx.advance(drive_inc.rho, sync ? da : 0.5 * (da + db));
    ctx.advanceHistory(drive_inc.rho, drive_inc.theta, kDt);
    if (!sync) {  // each wheel's own reversal odometer (per-wheel effects)
      double r, l;
      wheels.wheels(drive_inc, &r, &l);
      ctx.wheel_r.advance(r);
      ctx.wheel_l.advance(l);
    }
    inc.rho += noise.rho;
    inc.theta += noise.theta + turn_noise;
    inc.side += noise.side;
    truth = applyIncrement(truth, inc);
    history.push_back(truth);
    line("enc %.2f %lld %lld\n", t, static_cast<long long>(cnt_a), static_cast<long long>(cnt_b));
    if (k % kScanEvery == 0) {
      // The scan stamped t was taken at t - tau.
      const double ts = std::max(0.0, t - tau) / kDt;
      const std::size_t i0 = std::min(history.size() - 1, static_cast<std::size_t>(ts));
      const std::size_t i1 = std::min(history.size() - 1, i0 + 1);
      const double f = ts - double(i0);
      const Pose<double>& a = history[i0];
      const Pose<double>& b = history[i1];
      const Pose<double> at{a.x + f * (b.x - a.x), a.y + f * (b.y - a.y),
                            wrapAngle(a.theta + f * wrapAngle(b.theta - a.theta))};
      const double c = std::cos(at.theta), s = std::sin(at.theta);
      const double lx = at.x + c * mount_x - s * mount_y;
      const double ly = at.y + s * mount_x + c * mount_y;
      out += "scan ";
      line("%.2f", t);
      for (int i = 0; i < laser.beams; ++i) {
        const RayHit<double> h = true_map.cast(lx, ly, at.theta + mount_yaw + laser.angle_min + i * laser.angle_inc);
        const double r = h.hit ? h.range * (1 + scale) + bias + laser.sigma * n01(rng) : std::numeric_limits<double>::quiet_NaN();
        if (std::isfinite(r) && r > 0 && r <= laser.range_max) {
          line(" %.4f", r);
        } else {
          out += " nan";
        }
      }
      out += "\n";
    }
    line("truth %.2f %.6f %.6f %.7f\n", t, truth.x, truth.y, truth.theta);
  }
  return true;
}

}  // namespace odoerr::sim
