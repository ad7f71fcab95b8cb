#include "odoerr/sim/replay.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <limits>

#include <nlohmann/json.hpp>

#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/sim/odolog_json.hpp"
#include "odoerr/sim/host_map.hpp"
#include "odoerr/sim/relocalise.hpp"
#include "odoerr/sim/stats.hpp"

namespace odoerr::sim {

namespace {

template <template <typename> class DriveT>
bool run(const Odolog& log, const ReplayOptions& opt, ReplaySummary* sum, std::string* error) {
  using S = double;
  using M = typename fw::PaperTypes<S, DriveT>::ModelT;
  using Est = HostEstimator<M>;
  constexpr bool kSync = fw::PaperTypes<S, DriveT>::kSync;
  if (log.has_laser && log.laser.beams > Est::LaserT::kMaxBeams) {
    *error = log.path + ": the laser has " + std::to_string(log.laser.beams) + " beams; the replay supports " +
             std::to_string(Est::LaserT::kMaxBeams);
    return false;
  }
  if (!log.has_init) {
    *error = log.path + ": the replay needs an 'init' record (the prior on the initial pose)";
    return false;
  }
  if (log.enc.size() < 2) {
    *error = log.path + ": the replay needs at least two 'enc' records";
    return false;
  }
  // The estimator from the log: drive constants, map, laser, initial pose prior.
  DriveT<S> drive;
  const DriveConstants dc = driveConstants(log, kSync);
  const double ticks_a = dc.ticks_a, ticks_b = dc.ticks_b;
  if constexpr (!kSync) drive.wheelbase = S(dc.wheelbase);
  HostMap<S> map;
  std::string map_err;
  if (!map.build(log.walls, opt.map_cell_m, &map_err)) {
    *error = log.path + ": " + map_err;
    return false;
  }
  // Lost-track detection and relocalisation (relocalise.hpp): the map's likelihood field.
  const TrackingRules rules;
  LikelihoodField field;
  const bool tracking = opt.relocalise && log.has_laser;
  if (tracking && !field.build(log.walls, rules.field_cell_m, 4 * rules.sigma_m, &map_err)) {
    *error = log.path + ": --relocalise: " + map_err;
    return false;
  }
  LaserConfig<S> lc;
  if (log.has_laser) {
    lc = {log.laser.beams, log.laser.angle_min, log.laser.angle_inc, log.laser.range_max,
          opt.tuning.rangeSigma(log.laser.sigma), log.laser.mount_x, log.laser.mount_y, log.laser.mount_yaw};
  }
  typename Est::LaserT laser;
  if (!laser.init(lc, opt.beams_used)) {
    *error = log.path + ": the laser set-up is not usable";
    return false;
  }
  const fw::FilterSetup setup = opt.tuning.setup();
  const AkfConfig<S> akf_cfg = opt.tuning.akfConfig<S>(setup);
  Est est(M(drive), map.view(), laser, akf_cfg, setup.of);
  typename M::StateVec x0 = M::StateVec::Zero();
  x0[0] = log.init.x;
  x0[1] = log.init.y;
  x0[2] = log.init.theta;
  M::setNominal(x0);
  typename M::StateVec sig;
  sig.setConstant(setup.sigma_scale);
  sig[0] = log.init.sx;
  sig[1] = log.init.sy;
  sig[2] = log.init.stheta;
  if constexpr (kSync) sig[M::kDriveOffset + 1] = setup.sigma_e_theta;
  typename Est::OfT::KVec k0;
  if constexpr (kSync) {
    k0 << opt.k0_rho, opt.k0_theta;
  } else {
    k0 << opt.k0_w;
  }
  const typename Est::OfT::KMat pk0 = (k0 * setup.nonsys_rel_sigma).cwiseAbs2().asDiagonal();
  est.init(x0, sig.cwiseAbs2().asDiagonal(), k0, pk0);

  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(opt.out_dir, ec);
  const fs::path dir(opt.out_dir);
  std::ofstream tum(dir / "trajectory.tum");
  std::ofstream csv(dir / "estimates.csv");
  std::ofstream inn(dir / "innovations.csv");
  std::ofstream trk;
  if (tracking) {
    trk.open(dir / "tracking.csv");
    trk << "t,x,y,theta,fit,state\n";
  }
  if (!tum || !csv || !inn || (tracking && !trk)) {
    *error = "cannot write to '" + opt.out_dir + "': " + std::strerror(errno);
    return false;
  }
  csv << "t,x,y,theta,sigma_x,sigma_y,sigma_theta";
  for (const char* n : DriveT<S>::kParamNames) csv << "," << n << "," << n << "_sigma";
  for (const char* n : DriveT<S>::kNonSysNames) csv << "," << n << "," << n << "_sigma";
  csv << ",truth_x,truth_y,truth_theta\n";
  inn << "t,beam,status,measured,predicted,innovation,variance,nis\n";
  char buf[256];

  TruthCursor truth{log.truth};
  double sq_pos = 0, sq_head = 0;
  std::size_t n_truth = 0;
  // At the truth records' own times (no interpolation; a log with sparse truth, such as a
  // SLAM trajectory at its scans, is judged there): the last estimate recorded at each.
  double rec_sq_pos = 0, rec_sq_head = 0, rec_t = -1, rec_pos = 0, rec_head = 0;
  std::size_t n_rec = 0;
  auto commitRecord = [&]() {
    if (rec_t < 0) return;
    rec_sq_pos += rec_pos;
    rec_sq_head += rec_head;
    ++n_rec;
  };
  double nis_sum = 0;
  std::size_t nis_n = 0;
  auto record = [&](double t) {
    const auto& x = est.akf().state();
    const auto& p = est.akf().covariance();
    std::snprintf(buf, sizeof buf, "%.6f %.6f %.6f 0 0 0 %.9f %.9f\n", t, x[0], x[1], std::sin(0.5 * x[2]),
                  std::cos(0.5 * x[2]));
    tum << buf;
    std::snprintf(buf, sizeof buf, "%.6f,%.6f,%.6f,%.7f,%.6g,%.6g,%.6g", t, x[0], x[1], x[2], std::sqrt(p(0, 0)),
                  std::sqrt(p(1, 1)), std::sqrt(p(2, 2)));
    csv << buf;
    for (int i = 0; i < DriveT<S>::kParams; ++i) {
      const int k = M::kDriveOffset + i;
      std::snprintf(buf, sizeof buf, ",%.8g,%.6g", x[k], std::sqrt(p(k, k)));
      csv << buf;
    }
    for (int i = 0; i < DriveT<S>::kNonSys; ++i) {
      std::snprintf(buf, sizeof buf, ",%.6g,%.6g", est.of().estimate()[i], std::sqrt(est.of().covariance()(i, i)));
      csv << buf;
    }
    double tx, ty, tth;
    if (truth.at(t, &tx, &ty, &tth)) {
      std::snprintf(buf, sizeof buf, ",%.6f,%.6f,%.7f\n", tx, ty, tth);
      sq_pos += (x[0] - tx) * (x[0] - tx) + (x[1] - ty) * (x[1] - ty);
      if (truth.onRecord(t)) {
        if (t != rec_t) commitRecord();
        rec_t = t;
        rec_pos = (x[0] - tx) * (x[0] - tx) + (x[1] - ty) * (x[1] - ty);
        rec_head = wrapAngle(x[2] - tth) * wrapAngle(x[2] - tth);
      }
      sq_head += wrapAngle(x[2] - tth) * wrapAngle(x[2] - tth);
      ++n_truth;
    } else {
      std::snprintf(buf, sizeof buf, ",,,\n");
    }
    csv << buf;
  };

  EncCursor enc(log.enc);
  CountsAt filt = enc.at(log.enc.front().t);
  double t_f = log.enc.front().t;
  auto inputTo = [&](const CountsAt& c) {
    return typename DriveT<S>::Input{(c.a - filt.a) / ticks_a, (c.b - filt.b) / ticks_b};
  };
  auto observer = [&](double t) {
    return [&, t](const typename Est::AkfT::BeamRecord& r) {
      const double nu = r.measured - r.predicted;
      const bool predicted = r.variance > 0;
      if (predicted) {
        nis_sum += nu * nu / r.variance;
        ++nis_n;
        std::snprintf(buf, sizeof buf, "%.6f,%d,%s,%.5f,%.5f,%.5f,%.6g,%.5f\n", t, r.beam, statusName(r.status),
                      r.measured, r.predicted, nu, r.variance, nu * nu / r.variance);
      } else {
        std::snprintf(buf, sizeof buf, "%.6f,%d,%s,%.5f,,,,\n", t, r.beam, statusName(r.status), r.measured);
      }
      inn << buf;
    };
  };
  auto cycleTo = [&](double t, const S* ranges, const PoseFix<S>* fix = nullptr) {
    const CountsAt c = enc.at(t);
    const auto u = inputTo(c);
    (void)est.cycle(u, ranges, observer(t), fix);
    filt = c;
    t_f = t;
    ++sum->cycles;
    record(t);
  };

  // Every scan's fit at the filter's pose; a poor fit that a local search beats by
  // rules.gain (or a very poor one), rules.lost_after scans in a row, declares the track
  // lost; a search of a
  // widening window finds the robot again, and the estimator restarts from its state
  // before the loss (parameters, K) at the found pose, so nothing of the lost stretch
  // reaches the calibration (docs/calibrate.md, "Lost and found").
  // The estimator `from` (its parameters, K) restarted at the matched pose, its pose
  // uncorrelated with the rest, a field cell and 0.02 rad its sigmas.
  auto setPose = [&](Est& to, const ScanMatch& m, const Est& from) {
    typename M::StateVec xs = from.akf().state();
    typename M::StateMat ps = from.akf().covariance();
    xs[0] = m.x;
    xs[1] = m.y;
    xs[2] = m.theta;
    for (int i = 0; i < 3; ++i) {
      ps.row(i).setZero();
      ps.col(i).setZero();
    }
    ps(0, 0) = ps(1, 1) = S(rules.field_cell_m * rules.field_cell_m);
    ps(2, 2) = S(0.02 * 0.02);
    const typename Est::OfT::KVec k = from.of().estimate();
    const typename Est::OfT::KMat pk = from.of().covariance();
    if (&to != &from) to = from;
    to.init(xs, ps, k, pk);
  };
  std::deque<Est> good;  // the estimator after the last good scans, oldest first
  // A track lost before any good scan (a wrong start) kept fusing beams at the wrong place:
  // its recovery restarts from the priors, not from that.
  const Est initial = est;
  std::vector<double> fits;  // the fit of every scan checked while tracked
  auto medianFit = [&fits]() {
    if (fits.empty()) return -1.0;
    std::vector<double> f = fits;
    std::nth_element(f.begin(), f.begin() + std::ptrdiff_t(f.size() / 2), f.end());
    return f[f.size() / 2];
  };
  int evidence = 0, failed = 0;
  bool lost = false;
  bool stopped = false;  // opt.stop_when_lost and a loss was declared
  auto track = [&](const OdologScan& sc) {
    const std::vector<ScanPoint> pts = scanPoints(log.laser, sc.ranges.data(), rules.max_points);
    const auto& x = est.akf().state();
    const double fit = scanFit(field, pts, x[0], x[1], x[2], rules.sigma_m);
    const char* state = "tracked";
    if (pts.size() < 10) {
      state = "too_few_returns";
    } else if (!lost) {
      ++sum->scans_checked;
      fits.push_back(fit);
      bool bad = false;
      if (fit < rules.poor_fit) {
        ++sum->scans_poor;
        const ScanMatch m = matchScan(field, pts, x[0], x[1], x[2], rules.check_m, rules.check_rad, rules.sigma_m);
        if (m.fit >= fit + rules.gain && m.fit >= rules.accept_fit && m.fit - m.runner_up >= rules.distinct) {
          // A clear better pose close by: fused as a pose fix (the filter weighs it against
          // its own covariance; the parameters stay correlated as they were).
          // A displacement past rules.reset_sigmas of the fix's sigmas is no correction but
          // a filter gone astray: the pose is set there (the parameters kept).
          const double d_m = std::hypot(m.x - x[0], m.y - x[1]), d_rad = std::fabs(wrapAngle(m.theta - x[2]));
          if (d_m > rules.reset_sigmas * rules.fix_sigma_m || d_rad > rules.reset_sigmas * rules.fix_sigma_rad) {
            setPose(est, m, est);
          } else {
            const PoseFix<S> pf{S(m.x), S(m.y), S(m.theta), S(rules.fix_sigma_m), S(rules.fix_sigma_m),
                                S(rules.fix_sigma_rad)};
            (void)est.measureStep(nullptr, typename Est::AkfT::NoObserver{}, &pf);
          }
          ++sum->pose_corrections;
          state = "corrected";
        } else {
          bad = fit < rules.very_poor_fit;
          state = bad ? "very_poor" : "poor";
        }
      }
      evidence = bad ? evidence + 1 : 0;
      if (!bad) {
        good.push_back(est);
        if (int(good.size()) > rules.snapshots) good.pop_front();
      }
      if (evidence >= rules.lost_after) {
        lost = true;
        failed = 0;
        LostEpisode ep;
        ep.t_lost = sc.t;
        ep.fit_lost = fit;
        sum->episodes.push_back(ep);
        state = "lost";
        stopped = opt.stop_when_lost;
      }
    }
    // While lost, the search runs on every rules.widen_after-th scan (a wide window costs
    // about a second), and on any scan that fits well at the filter's pose.
    if (lost && failed % rules.widen_after != 0 && fit < rules.poor_fit) {
      ++failed;
      state = "lost";
    } else if (lost && !stopped) {
      const int widen = failed / rules.widen_after;
      const double reach = rules.window_m * double(1 << std::min(widen, 8));
      const bool whole_map = rules.global && reach > rules.max_window_m;
      const double wm = std::min(rules.max_window_m, reach);
      const double wr = std::min(rules.max_window_rad, rules.window_rad * double(1 << std::min(widen, 8)));
      // Found: a pose that fits well, clearly better than the filter's and than any other
      // candidate of the search (not a corridor's twin), or the filter's own pose fitting
      // well again.
      // After a loss the bar is the log's own: rules.found_share of the median fit of the
      // scans tracked so far (a building whose scans fit at 0.9 does not take 0.55).
      // Past the widest window the whole map is searched (its coarse step opens only what
      // could reach 0.8 of the bar with the doubled sigma).
      const double bar = std::max(rules.accept_fit, rules.found_share * medianFit());
      const ScanMatch m = whole_map ? matchGlobal(field, pts, rules.sigma_m, 0.8 * bar)
                                    : matchScan(field, pts, x[0], x[1], x[2], wm, wr, rules.sigma_m);
      if (whole_map) ++sum->episodes.back().map_searches;
      if (pts.size() >= 10 && m.fit >= bar && m.fit - m.runner_up >= rules.distinct &&
          (m.fit >= fit + rules.gain || fit >= rules.poor_fit)) {
        LostEpisode& ep = sum->episodes.back();
        ep.found_on_map = whole_map;
        ep.t_recovered = sc.t;
        ep.fit_recovered = m.fit;
        ep.jump_m = std::hypot(m.x - x[0], m.y - x[1]);
        ep.jump_rad = wrapAngle(m.theta - x[2]);
        const Est& restart = good.empty() ? initial : good.front();
        setPose(est, m, restart);
        good.clear();
        lost = false;
        evidence = 0;
        state = "recovered";
      } else {
        ++failed;
        state = "lost";
      }
    }
    const auto& xn = est.akf().state();
    std::snprintf(buf, sizeof buf, "%.6f,%.4f,%.4f,%.5f,%.4f,%s\n", sc.t, xn[0], xn[1], xn[2], fit, state);
    trk << buf;
  };

  // Merge the time-ordered streams: enc (travel cycles), scans and pose fixes (fused at
  // their own stamps). At equal times: encoders first, then scans, then pose fixes.
  std::size_t ie = 0, is = 0, ip = 0;
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<S> ranges(log.has_laser ? log.laser.beams : 0);
  while (!stopped && (ie < log.enc.size() || is < log.scans.size() || ip < log.poses.size())) {
    const double te = ie < log.enc.size() ? log.enc[ie].t : inf;
    const double ts = is < log.scans.size() ? log.scans[is].t : inf;
    const double tp = ip < log.poses.size() ? log.poses[ip].t : inf;
    if (te <= ts && te <= tp) {
      const OdologEnc& e = log.enc[ie++];
      const CountsAt c{double(e.a), double(e.b)};
      if (DriveT<S>::pathLength(inputTo(c)) >= opt.cycle_m) cycleTo(e.t, nullptr);
    } else if (ts <= tp) {
      const OdologScan& s = log.scans[is++];
      if (s.t < t_f) {
        ++sum->scans_late;
        continue;
      }
      for (std::size_t i = 0; i < ranges.size(); ++i) ranges[i] = s.ranges[i];
      cycleTo(s.t, ranges.data());
      ++sum->scans;
      if (tracking) track(s);
    } else {
      const OdologPose& q = log.poses[ip++];
      if (q.t < t_f) {
        ++sum->poses_late;
        continue;
      }
      const PoseFix<S> fix{q.x, q.y, q.theta, q.sx, q.sy, q.stheta};
      cycleTo(q.t, nullptr, &fix);
      ++sum->poses;
    }
  }
  if (tracking) sum->fit_median = medianFit();
  sum->lost_at_end = lost;
  sum->stopped_when_lost = stopped;
  if (lost && !good.empty()) est = good.front();  // the parameters from before the loss
  const auto& c = est.akf().counters();
  sum->beams_used = c.beams_used;
  sum->beams_gated = c.gated;
  sum->beams_skipped = c.no_return + c.no_map_hit + c.grazing + c.too_close;
  sum->nis_mean = nis_n > 0 ? nis_sum / double(nis_n) : 0;
  commitRecord();
  sum->truth_records_scored = n_rec;
  sum->pose_rmse_at_records_m = n_rec > 0 ? std::sqrt(rec_sq_pos / double(n_rec)) : -1;
  sum->heading_rmse_at_records_rad = n_rec > 0 ? std::sqrt(rec_sq_head / double(n_rec)) : -1;
  sum->pose_rmse_m = n_truth > 0 ? std::sqrt(sq_pos / double(n_truth)) : -1;
  sum->heading_rmse_rad = n_truth > 0 ? std::sqrt(sq_head / double(n_truth)) : -1;
  const auto& x = est.akf().state();
  const auto& p = est.akf().covariance();
  for (int i = 0; i < DriveT<S>::kParams; ++i) {
    const int k = M::kDriveOffset + i;
    sum->params.push_back({DriveT<S>::kParamNames[i], x[k], std::sqrt(p(k, k))});
  }
  for (int i = 0; i < DriveT<S>::kNonSys; ++i) {
    sum->params.push_back({DriveT<S>::kNonSysNames[i], est.of().estimate()[i], std::sqrt(est.of().covariance()(i, i))});
  }
  return true;
}

}  // namespace

bool replayOdolog(const Odolog& log, const ReplayOptions& opt, ReplaySummary* sum, std::string* error) {
  *sum = ReplaySummary{};
  const bool ok = log.drive == "sync" ? run<SyncDrive>(log, opt, sum, error) : run<DiffDrive>(log, opt, sum, error);
  if (!ok) return false;
  using json = nlohmann::ordered_json;
  json j;
  j["log"] = log.path;
  j["drive"] = log.drive;
  j["encoder_rejections"] = rejectionsJson(log);
  j["cycles"] = sum->cycles;
  j["scans_fused"] = sum->scans;
  j["scans_late"] = sum->scans_late;
  j["pose_fixes"] = sum->poses;
  j["beams_used"] = sum->beams_used;
  j["beams_gated"] = sum->beams_gated;
  j["beams_skipped"] = sum->beams_skipped;
  j["nis_mean_all_innovations"] = sum->nis_mean;
  j["unknown_records"] = log.unknown_records;
  j["pose_rmse_m"] = sum->pose_rmse_m >= 0 ? json(sum->pose_rmse_m) : json(nullptr);
  j["heading_rmse_rad"] = sum->heading_rmse_rad >= 0 ? json(sum->heading_rmse_rad) : json(nullptr);
  j["truth_records_scored"] = sum->truth_records_scored;
  j["pose_rmse_at_truth_records_m"] = sum->pose_rmse_at_records_m >= 0 ? json(sum->pose_rmse_at_records_m) : json(nullptr);
  j["heading_rmse_at_truth_records_rad"] =
      sum->heading_rmse_at_records_rad >= 0 ? json(sum->heading_rmse_at_records_rad) : json(nullptr);
  if (opt.relocalise) {
    json tr;
    tr["scans_checked"] = sum->scans_checked;
    tr["scans_poor"] = sum->scans_poor;
    tr["pose_corrections"] = sum->pose_corrections;
    tr["stopped_when_lost"] = sum->stopped_when_lost;
    tr["fit_median"] = sum->fit_median >= 0 ? json(sum->fit_median) : json(nullptr);
    std::size_t recovered = 0;
    json eps = json::array();
    for (const LostEpisode& e : sum->episodes) {
      recovered += e.t_recovered >= 0;
      eps.push_back({{"t_lost", e.t_lost},
                     {"t_recovered", e.t_recovered >= 0 ? json(e.t_recovered) : json(nullptr)},
                     {"fit_lost", e.fit_lost},
                     {"fit_recovered", e.fit_recovered},
                     {"jump_m", e.jump_m},
                     {"jump_rad", e.jump_rad},
                     {"map_searches", e.map_searches},
                     {"found_by", e.t_recovered < 0 ? json(nullptr) : json(e.found_on_map ? "map" : "window")}});
    }
    tr["lost_episodes"] = sum->episodes.size();
    tr["recovered"] = recovered;
    tr["lost"] = sum->lost_at_end;
    tr["episodes"] = eps;
    j["tracking"] = tr;
  }
  json params = json::object();
  for (const auto& p : sum->params) params[p.name] = {{"estimate", p.value}, {"sigma", p.sigma}};
  j["final"] = params;
  std::ofstream f(std::filesystem::path(opt.out_dir) / "replay.json");
  f << j.dump(2) << "\n";
  if (!f) {
    *error = "cannot write '" + opt.out_dir + "/replay.json'";
    return false;
  }
  return true;
}

}  // namespace odoerr::sim
