// sim_host: `odoerr bound LOG` — the true path of a logged drive (its truth records and
// the cycles `odoerr replay` makes), handed to the recursions of bound_engine.hpp.
#include "odoerr/sim/bound.hpp"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "bound_engine.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/sim/host_map.hpp"
#include "odoerr/sim/runner.hpp"

namespace odoerr::sim {

namespace {

using bound_detail::PathCycle;
using bound_detail::Problem;
using bound_detail::priorCovariance;

template <template <typename> class DriveT>
bool logBound(const Odolog& log, const std::vector<std::pair<std::string, double>>& truth, double cycle_m,
              const BoundOptions& opt, BoundResult* out, std::string* error) {
  using D = DriveT<double>;
  using ModelT = Model<D>;
  constexpr bool kSync = std::is_same_v<D, SyncDrive<double>>;
  if (!log.has_laser || log.scans.empty()) {
    *error = log.path + ": no laser scans: the bound is computed from the laser's information";
    return false;
  }
  if (log.laser.beams > kHostMaxBeams) {
    *error = log.path + ": the laser has " + std::to_string(log.laser.beams) + " beams; at most " +
             std::to_string(kHostMaxBeams);
    return false;
  }
  if (!log.has_init) {
    *error = log.path + ": no 'init' record (the prior on the initial pose)";
    return false;
  }
  if (log.truth.empty()) {
    *error = log.path + ": no 'truth' records: the bound is evaluated along the true path";
    return false;
  }
  if (log.enc.size() < 2) {
    *error = log.path + ": the bound needs at least two 'enc' records";
    return false;
  }
  auto value = [&](const char* name) {
    for (const auto& [n, v] : truth)
      if (n == name) return v;
    return std::nan("");
  };
  D drive;
  const DriveConstants dc = driveConstants(log, kSync);
  if constexpr (!kSync) drive.wheelbase = dc.wheelbase;
  Problem<ModelT> pb{ModelT(drive), ModelT::StateVec::Zero(), {}, {}, 0};
  for (int i = 0; i < D::kParams; ++i) pb.truth_params[ModelT::kDriveOffset + i] = value(D::kParamNames[i]);
  for (int i = 0; i < D::kNonSys; ++i) pb.k_true[i] = value(D::kNonSysNames[i]);
  const FilterSetup setup;
  pb.p0 = priorCovariance<ModelT>(setup, log.init.sx, log.init.sy, log.init.stheta);
  pb.min_cos_incidence = std::cos(setup.akf.max_incidence_rad);
  HostMap<double> map;
  std::string map_err;
  if (!map.build(log.walls, -1, &map_err)) {
    *error = log.path + ": " + map_err;
    return false;
  }
  LaserGeometry<double, kHostMaxBeams> laser;
  const LaserConfig<double> lc{log.laser.beams, log.laser.angle_min, log.laser.angle_inc, log.laser.range_max,
                               log.laser.sigma, log.laser.mount_x, log.laser.mount_y, log.laser.mount_yaw};
  if (!laser.init(lc)) {
    *error = log.path + ": the laser set-up is not usable";
    return false;
  }

  // The cycles `odoerr replay` makes (sim_host/src/replay.cpp): one per cycle_m of encoder
  // travel and one at each scan's stamp; pose fixes are not part of the bound.
  std::vector<PathCycle<typename D::Input>> path;
  EncCursor enc(log.enc);
  TruthCursor tc{log.truth};
  CountsAt filt = enc.at(log.enc.front().t);
  double t_f = log.enc.front().t;
  Pose<double> before;
  if (!tc.at(t_f, &before.x, &before.y, &before.theta)) {
    *error = log.path + ": no truth at the first encoder record (t = " + std::to_string(t_f) + ")";
    return false;
  }
  auto inputTo = [&](const CountsAt& c) {
    return typename D::Input{(c.a - filt.a) / dc.ticks_a, (c.b - filt.b) / dc.ticks_b};
  };
  auto cycleTo = [&](double t, const OdologScan* scan) {
    PathCycle<typename D::Input> c;
    const CountsAt counts = enc.at(t);
    c.u = inputTo(counts);
    c.before = before;
    if (!tc.at(t, &c.after.x, &c.after.y, &c.after.theta)) {
      *error = log.path + ": no truth at t = " + std::to_string(t) + " (the truth records must cover the drive)";
      return false;
    }
    if (scan != nullptr) {
      c.scan = true;
      for (int i = 0; i < log.laser.beams; ++i) {
        const double z = scan->ranges[std::size_t(i)];
        if (std::isfinite(z) && z > 0 && z <= log.laser.range_max) c.beams.push_back(i);
      }
    }
    before = c.after;
    filt = counts;
    t_f = t;
    path.push_back(std::move(c));
    return true;
  };
  std::size_t ie = 0, is = 0;
  while (ie < log.enc.size() || is < log.scans.size()) {
    const double te = ie < log.enc.size() ? log.enc[ie].t : HUGE_VAL;
    const double ts = is < log.scans.size() ? log.scans[is].t : HUGE_VAL;
    if (te <= ts) {
      const OdologEnc& e = log.enc[ie++];
      if (D::pathLength(inputTo(CountsAt{double(e.a), double(e.b)})) >= cycle_m && !cycleTo(e.t, nullptr)) return false;
    } else {
      const OdologScan& s = log.scans[is++];
      if (s.t < t_f) continue;
      if (!cycleTo(s.t, &s)) return false;
    }
  }
  out->source = log.path;
  out->drive = log.drive;
  const auto view = map.view();
  return bound_detail::runBound(pb, bound_detail::beamPredictor<ModelT>(view, laser, pb.min_cos_incidence),
                                laser.config().sigma, path, opt, out, error);
}

}  // namespace

bool truthOfOdolog(const Odolog& log, const std::vector<std::string>& overrides,
                   std::vector<std::pair<std::string, double>>* truth, std::string* error) {
  truth->clear();
  auto set = [&](const std::string& name, double v) {
    for (auto& [n, old] : *truth) {
      if (n == name) {
        old = v;
        return;
      }
    }
    truth->emplace_back(name, v);
  };
  auto parsePair = [&](const std::string& item, const std::string& where) {
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0) {
      *error = where + ": '" + item + "' is not NAME=VALUE";
      return false;
    }
    const std::string v = item.substr(eq + 1);
    char* end = nullptr;
    const double x = std::strtod(v.c_str(), &end);
    if (v.empty() || end != v.c_str() + v.size() || !std::isfinite(x)) {
      *error = where + ": '" + item + "' has no finite number after '='";
      return false;
    }
    set(item.substr(0, eq), x);
    return true;
  };
  for (const auto& [key, rest] : log.meta) {
    if (key != "truth") continue;
    std::istringstream in(rest);
    std::string item;
    while (in >> item)
      if (!parsePair(item, log.path + ": meta truth")) return false;
  }
  for (const std::string& o : overrides)
    if (!parsePair(o, "--truth")) return false;
  const bool sync = log.drive == "sync";
  std::vector<std::string> need;
  if (sync) {
    need = {"delta_rho", "E_theta", "K_rho", "K_theta"};
  } else {
    need = {"delta_R", "delta_L", "delta_d", "K_w"};
  }
  std::string missing;
  for (const std::string& n : need) {
    bool found = false;
    for (const auto& [name, v] : *truth) {
      if (name != n) continue;
      found = true;
      if (n.rfind("K_", 0) == 0 && !(v > 0)) {
        *error = log.path + ": the true " + n + " must be positive (got " + std::to_string(v) + ")";
        return false;
      }
    }
    if (!found) missing += (missing.empty() ? "" : ", ") + n;
  }
  if (!missing.empty()) {
    *error = log.path + ": the true " + missing +
             " not given (a 'meta truth NAME=V ...' record in the log, or --truth NAME=V,...)";
    return false;
  }
  return true;
}

bool boundOfOdolog(const Odolog& log, const std::vector<std::pair<std::string, double>>& truth, double cycle_m,
                   const BoundOptions& opt, BoundResult* out, std::string* error) {
  if (!(opt.every_m > 0) || !(cycle_m > 0)) {
    *error = "the record spacing and the cycle length must be positive";
    return false;
  }
  *out = BoundResult{};
  const auto t0 = std::chrono::steady_clock::now();
  bool ok = false;
  if (log.drive == "sync") {
    ok = logBound<SyncDrive>(log, truth, cycle_m, opt, out, error);
  } else if (log.drive == "diff") {
    ok = logBound<DiffDrive>(log, truth, cycle_m, opt, out, error);
  } else {
    *error = log.path + ": unknown drive '" + log.drive + "'";
  }
  out->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return ok;
}

}  // namespace odoerr::sim
