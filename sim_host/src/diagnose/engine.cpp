// diagnose, the filter runs over a log: the members of Engine that run the estimator
// (prepare, makeModel, run, recordPosterior, nearCorner), defined here and instantiated
// here only for the four engines diagnose uses. engine.hpp declares them with `extern
// template`, so no other file instantiates the estimator with the whole catalogue again
// (docs/performance.md, "The two commands").
#include "engine.hpp"

namespace odoerr::sim::diag {

template <template <typename> class DriveT, typename Effects>
bool Engine<DriveT, Effects>::prepare(std::string* error) {
  if (log_.has_laser && log_.laser.beams > Est::LaserT::kMaxBeams) {
    *error = log_.path + ": the laser has " + std::to_string(log_.laser.beams) + " beams; diagnose supports " +
             std::to_string(Est::LaserT::kMaxBeams);
    return false;
  }
  if (!log_.has_init) {
    *error = log_.path + ": diagnose needs an 'init' record (the prior on the initial pose)";
    return false;
  }
  if (log_.enc.size() < 2) {
    *error = log_.path + ": diagnose needs at least two 'enc' records";
    return false;
  }
  if (log_.scans.empty() && log_.poses.empty()) {
    *error = log_.path + ": diagnose needs measurements: 'scan' or 'pose' records";
    return false;
  }
  const DriveConstants dc = driveConstants(log_, kSync);
  ticks_a_ = dc.ticks_a;
  ticks_b_ = dc.ticks_b;
  if constexpr (!kSync) drive_.wheelbase = dc.wheelbase;
  std::string map_err;
  if (!host_map_.build(log_.walls, opt_.map_index_cell_m, &map_err)) {
    *error = log_.path + ": " + map_err;
    return false;
  }
  map_ = host_map_.view();
  if (log_.has_laser) {
    lc_ = {log_.laser.beams, log_.laser.angle_min, log_.laser.angle_inc, log_.laser.range_max,
           opt_.tuning.rangeSigma(log_.laser.sigma), log_.laser.mount_x, log_.laser.mount_y, log_.laser.mount_yaw};
  } else {
    lc_.beams = 0;
  }
  if (!laser_.init(lc_)) {
    *error = log_.path + ": the laser set-up is not usable";
    return false;
  }
  buildEffects();
  events_ = buildEvents<Drive>(log_, ticks_a_, ticks_b_, opt_.cycle_m, lc_.beams > 0);
  t0_ = events_.front().t;
  t1_ = events_.back().t;
  std::vector<double> times(events_.size());
  for (std::size_t k = 0; k < events_.size(); ++k) times[k] = events_[k].t;
  heldout_ = HeldoutBlocks(times, opt_.warmup_s, opt_.gap_s, opt_.block_s, opt_.folds);
  return true;
}

template <template <typename> class DriveT, typename Effects>
auto Engine<DriveT, Effects>::makeModel() const -> M {
  M m(drive_);
  effects::setWheelbase(m.effects, kSync ? 0.0 : log_.param("wheelbase_m", 0.5));  // per-wheel effects: none on sync
  auto& ecc = std::get<effects::WheelEccentricity>(m.effects);
  ecc.wheel_radius = log_.param("wheel_radius_m", 0.05);
  auto& reg = std::get<effects::RegionScale>(m.effects);
  if (!log_.walls.empty()) {
    reg.x_min = reg.y_min = std::numeric_limits<double>::infinity();
    reg.x_max = reg.y_max = -std::numeric_limits<double>::infinity();
    for (const auto& w : log_.walls) {
      reg.x_min = std::min({reg.x_min, w.x1, w.x2});
      reg.x_max = std::max({reg.x_max, w.x1, w.x2});
      reg.y_min = std::min({reg.y_min, w.y1, w.y2});
      reg.y_max = std::max({reg.y_max, w.y1, w.y2});
    }
  } else {  // no map: the box around the initial pose
    reg.x_min = log_.init.x - 5;
    reg.x_max = log_.init.x + 5;
    reg.y_min = log_.init.y - 5;
    reg.y_max = log_.init.y + 5;
  }
  if constexpr (!std::is_same_v<Effects, Catalogue>) {
    auto& fm = std::get<FeatureMotionE>(m.effects);
    if constexpr (!kSync) fm.wheelbase = drive_.wheelbase;
    fm.xc = 0.5 * (reg.x_min + reg.x_max);
    fm.yc = 0.5 * (reg.y_min + reg.y_max);
    // the filter's history counts time from the first event; a change point is in log time
    fm.t_change = slots_.t_change - (events_.empty() ? 0.0 : events_.front().t);
    for (std::size_t i = 0; i < slots_.motion.size() && i < FeatureSlots::kMax; ++i) {
      const auto& q = slots_.motion[i];
      (void)fm.configure(static_cast<int>(i), q.f, q.t, q.prior, q.ref);
    }
    auto& fr = std::get<FeatureRangeE>(m.effects);
    for (std::size_t i = 0; i < slots_.beam.size() && i < FeatureSlots::kMax; ++i) {
      const auto& q = slots_.beam[i];
      (void)fr.configure(static_cast<int>(i), q.f, q.prior, q.ref);
    }
  }
  return m;
}

template <template <typename> class DriveT, typename Effects>
auto Engine<DriveT, Effects>::run(const RunSpec& spec) const -> RunOut {
  const fw::FilterSetup setup = opt_.tuning.setup();
  Est est(makeModel(), map_, laser_, opt_.tuning.akfConfig<S>(setup), setup.of);
  StateVec x0 = StateVec::Zero();
  x0[0] = log_.init.x;
  x0[1] = log_.init.y;
  x0[2] = log_.init.theta;
  M::setNominal(x0);
  StateVec sig = StateVec::Zero();
  sig[0] = log_.init.sx;
  sig[1] = log_.init.sy;
  sig[2] = log_.init.stheta;
  for (int i = 0; i < Drive::kParams; ++i) {
    sig[kD + i] = spec.hold_drive ? kHeld : setup.sigma_scale;
    if (spec.hold_drive) x0[kD + i] = spec.drive_val[i];
  }
  if constexpr (kSync) {
    if (!spec.hold_drive) sig[kD + 1] = setup.sigma_e_theta;
  }
  for (int i = 0; i < M::kEffectParams; ++i) {
    x0[kE + i] = spec.eff_val[i];
    sig[kE + i] = spec.eff_sig[i];
  }
  KMat pk0 = (spec.k * setup.nonsys_rel_sigma).cwiseAbs2().asDiagonal();
  StateMat p0 = sig.cwiseAbs2().asDiagonal();
  if (spec.carry_x != nullptr && spec.carry_p != nullptr) {
    constexpr int np = M::kStates - kD;
    x0.template tail<np>() = spec.carry_x->template tail<np>();
    p0.template bottomRightCorner<np, np>() = spec.carry_p->template bottomRightCorner<np, np>();
  }
  if (spec.carry_pk != nullptr) pk0 = *spec.carry_pk;
  est.init(x0, p0, spec.k, pk0);
  est.freezeNonSystematic(!spec.of_free);

  RunOut out;
  std::vector<double> ranges(std::max(1, lc_.beams));
  TruthCursor truth{log_.truth};
  // The pose's NEES against the truth at t, when the log has truth there (else unchanged).
  auto neesAt = [&truth](double t, const StateVec& x, const StateMat& p, double* nees) {
    double tx, ty, tth;
    if (!truth.at(t, &tx, &ty, &tth)) return;
    const Eigen::Vector3d e(x[0] - tx, x[1] - ty, wrapAngle(x[2] - tth));
    *nees = e.dot(p.template topLeftCorner<3, 3>().ldlt().solve(e));
  };
  double dist = 0;
  double last_anchor = -1e300;
  std::optional<Est> fork;  // kEval: the copy that predicts a held-out block from its anchor
  double lost_since = -1;   // time of the first scan of the current lost stretch (-1: tracking)
  const double c_m = lc_.mount_x, s_m = lc_.mount_y;
  for (const Event& ev : events_) {
    const typename Drive::Input u{ev.a, ev.b};
    dist += Drive::pathLength(u);
    if (est.predictStep(u, ev.dt) != Status::kOk) continue;
    const bool held = spec.mode != Mode::kFull && heldout_.inHeldout(ev.t, spec.fold);
    bool use = true;      // fuse this event's measurement
    bool score = spec.mode == Mode::kFull;
    bool evaluate = false;  // held-out evaluation (predict, do not fuse)
    if (spec.mode == Mode::kFit) {
      use = !held && !heldout_.nearHeldout(ev.t, spec.fold);
      score = use;
    }
    // Evaluation: the main filter fuses everything; at an anchor (a held-out block's first
    // measurement, then one per reanchor_s) a copy of it is taken, and the copy predicts
    // the block's other measurements from the data up to its anchor only. A bad
    // prediction never feeds back into the tracking.
    if (spec.mode == Mode::kEval) {
      if (!held) {
        fork.reset();
      } else if (fork && fork->predictStep(u, ev.dt) != Status::kOk) {
        fork.reset();
      }
      evaluate = held && fork && (ev.scan >= 0 || ev.pose >= 0) && ev.t - last_anchor < opt_.reanchor_s;
    }
    Est& pe = evaluate ? *fork : est;  // the filter whose prediction is scored
    const int held_scan = static_cast<int>(out.ho_scans.size());  // the HeldEvent this event's beams belong to
    const auto& akf = pe.akf();
    const StateVec xm = akf.state();
    if (ev.scan >= 0) {
      const OdologScan& sc = log_.scans[static_cast<std::size_t>(ev.scan)];
      for (int i = 0; i < lc_.beams; ++i) ranges[i] = sc.ranges[static_cast<std::size_t>(i)];
      ScanRec rec{};
      const double c = std::cos(xm[2]), sn = std::sin(xm[2]);
      const double lx = xm[0] + c * c_m - sn * s_m, ly = xm[1] + sn * c_m + c * s_m;
      const std::size_t key0 = static_cast<std::size_t>(ev.scan) * static_cast<std::size_t>(lc_.beams);
      auto observe = [&](const typename Est::AkfT::BeamRecord& r) {
        const std::size_t key = key0 + static_cast<std::size_t>(r.beam);
        if (!(r.variance > 0)) {
          // a scored beam this run cannot predict costs what an outlier costs
          if (score && spec.scored != nullptr && (*spec.scored)[key]) {
            out.loglik += -0.5 * (std::log(2 * kPi<double> * lc_.sigma * lc_.sigma) + kCap);
            ++out.n_innov;
          }
          if (evaluate) out.ho_beams.push_back({static_cast<long long>(key), held_scan, 0, 0, 0, false, false});
          return;
        }
        const double nu = r.measured - r.predicted;
        const double nis = nu * nu / r.variance;
        if (score && spec.make_scored != nullptr) {
          (*spec.make_scored)[key] = nis < kCap && !nearCorner(xm, r.beam, r.predicted);
        }
        if (score && (spec.scored == nullptr || (*spec.scored)[key]) &&
            (spec.make_scored == nullptr || (*spec.make_scored)[key])) {
          out.loglik += -0.5 * (std::log(2 * kPi<double> * r.variance) + std::min(nis, kCap));
          ++out.n_innov;
        }
        if (evaluate) {
          const double nll = 0.5 * (std::log(2 * kPi<double> * r.variance) + std::min(nis, kCap));
          // the innovation error counts beams inside the gate (an outlier's size says nothing)
          out.ho_beams.push_back(
              {static_cast<long long>(key), held_scan, std::min(nis, kCap), nll, nu * nu, true, nis < kCap});
        }
        if (spec.record) {
          rec.nis_sum += std::min(nis, kCap);
          rec.sum_norm += nu / std::sqrt(r.variance);
          ++rec.dof;
          const double a = xm[2] + lc_.mount_yaw + lc_.angle_min + r.beam * lc_.angle_inc;
          out.beams.push_back({ev.t, r.beam, r.status, lx + r.measured * std::cos(a), ly + r.measured * std::sin(a),
                               nu, r.variance});
        }
      };
      if (evaluate) {
        fork->evaluateScan(ranges.data(), observe);
        (void)fork->measureStep(nullptr, typename Est::AkfT::NoObserver{});
        (void)est.measureStep(ranges.data(), typename Est::AkfT::NoObserver{});
      } else if (use) {
        const auto res = est.measureStep(ranges.data(), observe);
        if (4 * res.scan.used < lc_.beams) {
          if (lost_since < 0) lost_since = ev.t;
          out.lost_s = std::max(out.lost_s, ev.t - lost_since);
        } else {
          lost_since = -1;
        }
      } else {
        // Not fusing (a held-out block or its gap) leaves a lost stretch open: a fit that
        // was lost before a block is still lost after it (fused stretches between one
        // fold's blocks last only ~6 s, so resetting here hid a fit lost for 205 s).
        (void)est.measureStep(nullptr, typename Est::AkfT::NoObserver{});
      }
      if (spec.residuals && use && !evaluate) recordPosterior(est, ev, &out, ranges.data());
      if (spec.record && use && !evaluate) {
        const StateVec& xp = akf.state();
        const auto& ctx = akf.motionContext();
        rec.t = ev.t;
        rec.dist = dist;
        rec.x = xm[0];
        rec.y = xm[1];
        rec.th = xm[2];
        rec.x1 = xp[0];
        rec.y1 = xp[1];
        rec.th1 = xp[2];
        rec.v = std::hypot(akf.velocityX(), akf.velocityY()) * (ctx.last_sign < 0 ? -1.0 : 1.0);
        rec.w = akf.turnRate();
        rec.s_rev = ctx.s_rev;
        rec.s_signed = ctx.s_enc;
        neesAt(ev.t, xp, akf.covariance(), &rec.nees);
        out.scans.push_back(rec);
      }
    } else if (ev.pose >= 0) {
      const OdologPose& q = log_.poses[static_cast<std::size_t>(ev.pose)];
      const Eigen::Vector3d nu(q.x - xm[0], q.y - xm[1], wrapAngle(q.theta - xm[2]));
      const Eigen::Matrix3d sm = akf.covariance().template topLeftCorner<3, 3>() +
                                 Eigen::Vector3d(q.sx * q.sx, q.sy * q.sy, q.stheta * q.stheta).asDiagonal().toDenseMatrix();
      const auto ldlt = sm.ldlt();
      const double nis = nu.dot(ldlt.solve(nu));
      const double logdet = ldlt.vectorD().array().log().sum();
      if (score && std::isfinite(nis) && std::isfinite(logdet)) {
        out.loglik += -0.5 * (3 * std::log(2 * kPi<double>) + logdet + std::min(nis, 3 * kCap));
        out.n_innov += 3;
      }
      if (evaluate) {
        const bool ok = std::isfinite(nis) && std::isfinite(logdet);
        const double nll = ok ? 0.5 * (3 * std::log(2 * kPi<double>) + logdet + std::min(nis, 3 * kCap)) / 3 : 0.0;
        out.ho_beams.push_back({-(static_cast<long long>(ev.pose) + 1), held_scan, ok ? std::min(nis, 3 * kCap) / 3 : 0.0,
                                nll, (nu[0] * nu[0] + nu[1] * nu[1]) / 2, ok, ok && nis < 3 * kCap});
      }
      if (spec.record && use && !evaluate && std::isfinite(nis)) {
        PoseFixRec fr{};
        const auto& ctx = akf.motionContext();
        fr.t = ev.t;
        fr.dist = dist;
        fr.x = xm[0];
        fr.y = xm[1];
        fr.th = xm[2];
        for (int i = 0; i < 3; ++i) fr.nu[i] = nu[i];
        for (int i = 0; i < 3; ++i)
          for (int k = 0; k < 3; ++k) fr.s[3 * i + k] = sm(i, k);
        fr.nis = nis;
        fr.v = std::hypot(akf.velocityX(), akf.velocityY()) * (ctx.last_sign < 0 ? -1.0 : 1.0);
        fr.w = akf.turnRate();
        neesAt(ev.t, xm, akf.covariance(), &fr.nees);
        out.fixes.push_back(fr);
      }
      const PoseFix<S> fix{q.x, q.y, q.theta, q.sx, q.sy, q.stheta};
      if (evaluate) (void)fork->measureStep(nullptr, typename Est::AkfT::NoObserver{});
      (void)est.measureStep(nullptr, typename Est::AkfT::NoObserver{}, use ? &fix : nullptr);
      if (spec.residuals && use && !evaluate) recordPosterior(est, ev, &out, nullptr);
    } else {
      if (fork) (void)fork->measureStep(nullptr, typename Est::AkfT::NoObserver{});
      (void)est.measureStep(nullptr, typename Est::AkfT::NoObserver{});
    }
    if (spec.of_free && est.of().counters().updates > out.obs.size()) {
      const auto& of = est.of();
      std::array<double, 2> o{std::nan(""), std::nan("")};
      for (int i = 0; i < of.lastObservation().size() && i < 2; ++i) {
        o[i] = (of.lastObservation()[i] - of.lastPredicted()[i]) / std::sqrt(of.lastVariance()[i]);
      }
      out.obs.push_back(o);
    }
    if (spec.mode == Mode::kEval && held && (ev.scan >= 0 || ev.pose >= 0) && !evaluate) {
      fork.emplace(est);  // an anchor
      last_anchor = ev.t;
    }
    // Truth comparison: held-out pose error at each predicted measurement (eval), and the
    // trajectory (record).
    if (evaluate) {
      double tx, ty, tth, err = std::nan("");
      if (truth.at(ev.t, &tx, &ty, &tth)) {
        const auto& x = fork->akf().state();
        const double e2 = (x[0] - tx) * (x[0] - tx) + (x[1] - ty) * (x[1] - ty);
        out.ho_pos_sq += e2;
        out.ho_head_sq += wrapAngle(x[2] - tth) * wrapAngle(x[2] - tth);
        ++out.ho_nt;
        err = std::sqrt(e2);
      }
      out.ho_scans.push_back({ev.t, err});
    }
    if (spec.record) {
      const auto& x = est.akf().state();
      TrajRec tr{ev.t, x[0], x[1], x[2], 0, 0, 0, false};
      tr.truth = truth.at(ev.t, &tr.tx, &tr.ty, &tr.tth);
      out.traj.push_back(tr);
    }
  }
  out.x = est.akf().state();
  out.p = est.akf().covariance();
  out.k = est.of().estimate();
  out.pk = est.of().covariance();
  return out;
}

template <template <typename> class DriveT, typename Effects>
void Engine<DriveT, Effects>::recordPosterior(const Est& est, const Event& ev, RunOut* out, const double* ranges) const {
  const auto& akf = est.akf();
  const StateVec& xp = akf.state();
  const auto& ctx = akf.motionContext();
  const int post = static_cast<int>(out->post.size());
  out->post.push_back({static_cast<int>(&ev - events_.data()), ev.t, xp[0], xp[1], xp[2],
                       std::hypot(akf.velocityX(), akf.velocityY()) * (ctx.last_sign < 0 ? -1.0 : 1.0),
                       akf.turnRate()});
  if (ranges == nullptr) return;
  est.evaluateScan(ranges, [&](const typename Est::AkfT::BeamRecord& r) {
    if (r.variance > 0) out->post_beams.push_back({post, r.beam, r.measured - r.predicted});
  });
}

template <template <typename> class DriveT, typename Effects>
bool Engine<DriveT, Effects>::nearCorner(const StateVec& x, int beam, double range) const {
  const double c = std::cos(x[2]), sn = std::sin(x[2]);
  const double lx = x[0] + c * lc_.mount_x - sn * lc_.mount_y, ly = x[1] + sn * lc_.mount_x + c * lc_.mount_y;
  const double a = x[2] + lc_.mount_yaw + lc_.angle_min + beam * lc_.angle_inc;
  const double hx = lx + range * std::cos(a), hy = ly + range * std::sin(a);
  for (const auto& w : log_.walls) {
    if (std::hypot(hx - w.x1, hy - w.y1) < 0.05 || std::hypot(hx - w.x2, hy - w.y2) < 0.05) return true;
  }
  return false;
}
template class Engine<SyncDrive>;
template class Engine<DiffDrive>;
template class Engine<SyncDrive, Featured>;
template class Engine<DiffDrive, Featured>;

}  // namespace odoerr::sim::diag
