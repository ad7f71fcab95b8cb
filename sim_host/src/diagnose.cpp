#include "odoerr/sim/diagnose.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <thread>

#include <Eigen/Dense>

#include "odoerr/effects/catalogue.hpp"
#include "odoerr/estimator.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/sim/stats.hpp"

namespace odoerr::sim {

namespace {

using json = nlohmann::ordered_json;
using effects::Catalogue;

template <typename D, typename Tuple>
struct ModelOf;
template <typename D, typename... E>
struct ModelOf<D, std::tuple<E...>> {
  using type = Model<D, E...>;
};

constexpr double kCap = 25.0;     // NIS cap of one innovation in the likelihood (= the gate)
constexpr double kAlpha = 1e-3;    // test level of one candidate's likelihood ratio (before the BIC condition)
constexpr double kAlphaWald = 1e-2;  // test level of its Wald statistic (the estimate against its own sigma)
constexpr double kInformed = 0.7;  // a parameter is informed when the drive shrinks its prior sigma below this
constexpr double kHeld = 0.0;     // prior sigma of a parameter held at a value (exactly constant)
constexpr double kLostS = 10.0;   // a fit that fused scans with under a quarter of their beams this long lost the robot
                                  // (a model that misfits loses beams for a few seconds in a turn and recovers)

/// Advice for a parameter or effect that the drive cannot determine.
const char* adviceFor(const std::string& name) {
  if (name == "delta_d" || name == "delta_R" || name == "delta_L")
    return "drive turns of different radii in both directions (a figure-eight), not one constant circle";
  if (name == "delta_rho") return "drive straight segments of a few metres towards and away from walls";
  if (name == "E_theta") return "drive longer distances between turns; the bound falls as 1/sqrt(distance)";
  if (name == "turn_slip") return "turn at several speeds (v*w must vary), both ways";
  if (name == "rotation_slip") return "turn at several turn rates, both ways";
  if (name == "speed_scale") return "drive the same paths at clearly different speeds";
  if (name == "wheel_eccentricity") return "drive several wheel revolutions in straight lines between scans";
  if (name == "backlash") return "reverse the direction of travel many times";
  if (name == "region_scale") return "drive through every part of the room";
  if (name == "radius_drift") return "drive longer (the effect grows with distance)";
  if (name == "turn_noise") return "turn more, and also drive straight, so turning noise separates from wheel noise";
  if (name == "range_bias" || name == "range_scale")
    return "drive close to and far from the walls (ranges must vary), in a map whose size is certain";
  if (name == "laser_mount_xy" || name == "laser_mount_yaw") return "turn in place and along curves near walls";
  if (name == "scan_latency") return "turn and drive at higher speed (latency shows only while moving)";
  if (name == "wall_offset") return "see every wall from several distances and angles";
  return "vary the motion";
}

struct EffectInfo {
  std::string name, description;
  EffectKind kind;
  int offset, n;
  std::vector<double> prior, ref;
  std::vector<std::string> pnames;
};

/// One predicted (not fused) held-out measurement in a run: its time and the predicting
/// copy's pose error against truth (NaN without truth).
struct HeldEvent {
  double t, pose_err;
};

/// The same after the comparison: with the NIS and negative log-likelihood per degree of
/// freedom over the beams that both runs predicted.
struct HeldScan {
  double t, nis, nll, pose_err;
};

/// One beam (or pose fix) of a predicted held-out measurement. Before and after are
/// compared on the beams both predicted (matched by key), so that a model cannot improve
/// its mean by leaving hard beams unpredicted.
struct HeldBeam {
  long long key;  ///< scan * 64 + beam; a pose fix: -(index + 1)
  int scan;       ///< its HeldEvent in the run
  double nis, nll, nu2;
  bool ok;        ///< predicted (a variance and a wall)
  bool inside;    ///< inside the gate (its innovation counts in the innovation RMS)
};

struct Event {
  double t, dt, a, b;
  int scan = -1, pose = -1;
};

enum class Mode { kFull, kFit, kEval };

template <template <typename> class DriveT>
class Engine {
 public:
  using S = double;
  using Drive = DriveT<S>;
  using M = typename ModelOf<Drive, Catalogue>::type;
  using Est = Estimator<M, 16, 32, 64>;
  using StateVec = typename M::StateVec;
  using StateMat = typename M::StateMat;
  using KVec = typename Est::OfT::KVec;
  using KMat = typename Est::OfT::KMat;
  using VecX = Eigen::VectorXd;
  static constexpr bool kSync = std::is_same_v<Drive, SyncDrive<S>>;
  static constexpr int kD = M::kDriveOffset;
  static constexpr int kE = kD + Drive::kParams;  // first effect parameter

  struct RunSpec {
    VecX eff_val, eff_sig;  // size M::kEffectParams
    bool hold_drive = false;
    Eigen::Matrix<S, Drive::kParams, 1> drive_val = Drive::nominal();
    bool of_free = false;
    KVec k;
    Mode mode = Mode::kFull;
    int fold = 0;  ///< kFit / kEval: the cross-validation fold held out
    bool record = false;
    /// The beams the likelihood is scored on (scan * beams + beam); the baseline run
    /// chooses them (make_scored) and every other run scores the same set.
    const std::vector<std::uint8_t>* scored = nullptr;
    std::vector<std::uint8_t>* make_scored = nullptr;
  };
  struct RunOut {
    double loglik = 0;
    long n_innov = 0;
    StateVec x;
    StateMat p;
    KVec k;
    double ho_pos_sq = 0, ho_head_sq = 0;
    long ho_nt = 0;                  ///< kEval: truth samples at the predicted measurements
    std::vector<HeldEvent> ho_scans;  ///< kEval: every predicted held-out scan or fix
    std::vector<HeldBeam> ho_beams;  ///< kEval: their beams
    std::vector<ScanRec> scans;
    std::vector<BeamRec> beams;
    std::vector<TrajRec> traj;
    std::vector<std::array<double, 2>> obs;  // OF observable (z - m) / sqrt(s), per component
    /// The longest time the filter fused scans with under a quarter of their beams used
    /// (every other one gated or unpredictable): it had lost the robot.
    double lost_s = 0;
  };

  Engine(const Odolog& log, const DiagnoseOptions& opt) : log_(log), opt_(opt) {}

  bool prepare(std::string* error) {
    if (log_.walls.size() > 16) {
      *error = log_.path + ": the map has " + std::to_string(log_.walls.size()) + " walls; diagnose supports 16";
      return false;
    }
    if (log_.has_laser && log_.laser.beams > 64) {
      *error = log_.path + ": the laser has " + std::to_string(log_.laser.beams) + " beams; diagnose supports 64";
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
    if constexpr (kSync) {
      ticks_a_ = log_.param("ticks_per_m", 1);
      ticks_b_ = log_.param("ticks_per_rad", 1);
    } else {
      drive_.wheelbase = log_.param("wheelbase_m", 0.5);
      ticks_a_ = ticks_b_ = log_.param("ticks_per_rev", 1) / (2 * kPi<double> * log_.param("wheel_radius_m", 1));
    }
    for (const auto& w : log_.walls) (void)map_.add({w.x1, w.y1, w.x2, w.y2});
    if (log_.has_laser) {
      lc_ = {log_.laser.beams, log_.laser.angle_min, log_.laser.angle_inc, log_.laser.range_max,
             log_.laser.sigma, log_.laser.mount_x, log_.laser.mount_y, log_.laser.mount_yaw};
    } else {
      lc_.beams = 0;
    }
    if (!laser_.init(lc_)) {
      *error = log_.path + ": the laser set-up is not usable";
      return false;
    }
    buildEffects();
    buildEvents();
    t0_ = events_.front().t;
    t1_ = events_.back().t;
    // Held-out blocks: after the warm-up, the drive cut into short blocks (the fit
    // dead-reckons through a block and its gaps, so a block must be short enough to
    // relocalise after); fold f holds out blocks f, f + folds, ...
    blocks_start_ = t0_ + opt_.warmup_s + opt_.gap_s;
    const double span = t1_ - blocks_start_;
    const int nb = opt_.block_s > 0 && span > 0 ? static_cast<int>(span / opt_.block_s) : 0;
    for (int b = 0; b < nb; ++b)
      blocks_.push_back({blocks_start_ + b * opt_.block_s, blocks_start_ + (b + 1) * opt_.block_s});
    folds_ = std::max(0, std::min(opt_.folds, nb));
    return true;
  }

  const std::vector<EffectInfo>& effects() const { return effects_; }

  /// The model: the drive and every catalogue effect, configured from the log.
  M makeModel() const {
    M m(drive_);
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
    return m;
  }

  /// A spec with every effect held at nominal.
  RunSpec nominalSpec(const KVec& k, bool of_free) const {
    RunSpec s;
    s.eff_val = VecX::Zero(M::kEffectParams);
    s.eff_sig = VecX::Constant(M::kEffectParams, kHeld);
    s.k = k;
    s.of_free = of_free;
    return s;
  }
  /// Frees effect e (prior sigma) in a spec.
  void freeEffect(RunSpec* s, int e) const {
    const EffectInfo& fi = effects_[e];
    for (int i = 0; i < fi.n; ++i) s->eff_sig[fi.offset - kE + i] = fi.prior[i];
  }

  KVec initialK() const {
    KVec k0;
    if constexpr (kSync) {
      k0 << opt_.k0_rho, opt_.k0_theta;
    } else {
      k0 << opt_.k0_w;
    }
    return k0;
  }

  RunOut run(const RunSpec& spec) const {
    fw::FilterSetup setup;
    Est est(makeModel(), map_, laser_, {S(setup.akf.max_incidence_rad), S(setup.akf.gate_nis)}, setup.of);
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
    const KMat pk0 = (spec.k * setup.nonsys_rel_sigma).cwiseAbs2().asDiagonal();
    est.init(x0, sig.cwiseAbs2().asDiagonal(), spec.k, pk0);
    est.freezeNonSystematic(!spec.of_free);

    RunOut out;
    std::vector<double> ranges(std::max(1, lc_.beams));
    TruthCursor truth{log_.truth};
    double dist = 0;
    double last_anchor = -1e300;
    std::optional<Est> fork;  // kEval: the copy that predicts a held-out block from its anchor
    double lost_since = -1;   // time of the first scan of the current lost stretch (-1: tracking)
    const double c_m = lc_.mount_x, s_m = lc_.mount_y;
    for (const Event& ev : events_) {
      const typename Drive::Input u{ev.a, ev.b};
      dist += Drive::pathLength(u);
      if (est.predictStep(u, ev.dt) != Status::kOk) continue;
      const bool held = spec.mode != Mode::kFull && inHeldout(ev.t, spec.fold);
      bool use = true;      // fuse this event's measurement
      bool score = spec.mode == Mode::kFull;
      bool evaluate = false;  // held-out evaluation (predict, do not fuse)
      if (spec.mode == Mode::kFit) {
        use = !held && !nearHeldout(ev.t, spec.fold);
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
          double tx, ty, tth;
          if (truth.at(ev.t, &tx, &ty, &tth)) {
            const Eigen::Vector3d e(xp[0] - tx, xp[1] - ty, wrapAngle(xp[2] - tth));
            const Eigen::Matrix3d pp = akf.covariance().template topLeftCorner<3, 3>();
            rec.nees = e.dot(pp.ldlt().solve(e));
          }
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
        const PoseFix<S> fix{q.x, q.y, q.theta, q.sx, q.sy, q.stheta};
        if (evaluate) (void)fork->measureStep(nullptr, typename Est::AkfT::NoObserver{});
        (void)est.measureStep(nullptr, typename Est::AkfT::NoObserver{}, use ? &fix : nullptr);
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
    return out;
  }

  /// A beam whose predicted hit lies within 5 cm of a wall's end: its prediction can jump
  /// to another wall with a tiny change of pose, so it says little about a smooth effect.
  bool nearCorner(const StateVec& x, int beam, double range) const {
    const double c = std::cos(x[2]), sn = std::sin(x[2]);
    const double lx = x[0] + c * lc_.mount_x - sn * lc_.mount_y, ly = x[1] + sn * lc_.mount_x + c * lc_.mount_y;
    const double a = x[2] + lc_.mount_yaw + lc_.angle_min + beam * lc_.angle_inc;
    const double hx = lx + range * std::cos(a), hy = ly + range * std::sin(a);
    for (const auto& w : log_.walls) {
      if (std::hypot(hx - w.x1, hy - w.y1) < 0.05 || std::hypot(hx - w.x2, hy - w.y2) < 0.05) return true;
    }
    return false;
  }
  std::size_t scoredSize() const { return log_.scans.size() * static_cast<std::size_t>(std::max(0, lc_.beams)); }

  /// The block that holds time t (-1: none).
  int blockAt(double t) const {
    if (blocks_.empty() || t < blocks_start_) return -1;
    const int b = static_cast<int>((t - blocks_start_) / opt_.block_s);
    return b < static_cast<int>(blocks_.size()) ? b : -1;
  }
  bool heldBlock(int b, int fold) const { return b >= 0 && folds_ > 0 && b % folds_ == fold; }
  bool inHeldout(double t, int fold) const { return heldBlock(blockAt(t), fold); }
  /// Within gap_s of a block held out in this fold (the fit does not use it either).
  bool nearHeldout(double t, int fold) const {
    if (blocks_.empty()) return false;
    const double lo = std::floor((t - opt_.gap_s - blocks_start_) / opt_.block_s);
    const double hi = std::floor((t + opt_.gap_s - blocks_start_) / opt_.block_s);
    const int last = static_cast<int>(blocks_.size()) - 1;
    for (int b = static_cast<int>(std::max(0.0, lo)); b <= std::min(double(last), hi); ++b)
      if (heldBlock(b, fold)) return true;
    return false;
  }
  const std::vector<std::pair<double, double>>& blocks() const { return blocks_; }
  int folds() const { return folds_; }
  double duration() const { return t1_ - t0_; }
  const Drive& drive() const { return drive_; }

 private:
  template <std::size_t... I>
  void buildEffectsImpl(std::index_sequence<I...>) {
    (addEffect<std::tuple_element_t<I, Catalogue>>(), ...);
  }
  template <typename E>
  void addEffect() {
    EffectInfo fi;
    fi.name = E::kName;
    fi.description = E::kDescription;
    fi.kind = E::kKind;
    fi.offset = M::template offsetOf<E>();
    fi.n = E::kParams;
    for (int i = 0; i < E::kParams; ++i) {
      fi.prior.push_back(effects::priorSigma<E>(i));
      fi.ref.push_back(effects::referenceSize<E>(i));
      fi.pnames.push_back(E::kParamNames[i]);
    }
    effects_.push_back(fi);
  }
  void buildEffects() { buildEffectsImpl(std::make_index_sequence<std::tuple_size_v<Catalogue>>{}); }

  /// The log as filter events: one per cm of encoder travel, one per scan and pose fix at
  /// its own stamp (encoder counts interpolated to it), as `odoerr replay` does.
  void buildEvents() {
    const auto& e = log_.enc;
    EncCursor enc(e);
    auto countsAt = [&](double t, double* a, double* b) {
      const CountsAt c = enc.at(t);
      *a = c.a;
      *b = c.b;
    };
    double fa = double(e.front().a), fb = double(e.front().b), ft = e.front().t;
    auto push = [&](double t, double a, double b, int scan, int pose) {
      Event ev{t, t - ft, (a - fa) / ticks_a_, (b - fb) / ticks_b_, scan, pose};
      events_.push_back(ev);
      fa = a;
      fb = b;
      ft = t;
    };
    std::size_t ie = 0, is = 0, ip = 0;
    const double inf = std::numeric_limits<double>::infinity();
    while (ie < e.size() || is < log_.scans.size() || ip < log_.poses.size()) {
      const double te = ie < e.size() ? e[ie].t : inf;
      const double ts = is < log_.scans.size() ? log_.scans[is].t : inf;
      const double tp = ip < log_.poses.size() ? log_.poses[ip].t : inf;
      if (te <= ts && te <= tp) {
        const OdologEnc& r = e[ie++];
        const typename Drive::Input u{(double(r.a) - fa) / ticks_a_, (double(r.b) - fb) / ticks_b_};
        if (Drive::pathLength(u) >= opt_.cycle_m) push(r.t, double(r.a), double(r.b), -1, -1);
      } else if (ts <= tp) {
        const double t = log_.scans[is].t;
        if (t >= ft && lc_.beams > 0) {
          double a, b;
          countsAt(t, &a, &b);
          push(t, a, b, static_cast<int>(is), -1);
        }
        ++is;
      } else {
        const double t = log_.poses[ip].t;
        if (t >= ft) {
          double a, b;
          countsAt(t, &a, &b);
          push(t, a, b, -1, static_cast<int>(ip));
        }
        ++ip;
      }
    }
    if (events_.empty()) events_.push_back({ft, 0, 0, 0, -1, -1});
  }

  const Odolog& log_;
  DiagnoseOptions opt_;
  Drive drive_{};
  double ticks_a_ = 1, ticks_b_ = 1;
  typename Est::MapT map_;
  LaserConfig<S> lc_{};
  typename Est::LaserT laser_;
  std::vector<EffectInfo> effects_;
  std::vector<Event> events_;
  double t0_ = 0, t1_ = 0;
  std::vector<std::pair<double, double>> blocks_;  ///< held-out blocks; block b in fold b % folds_
  double blocks_start_ = 0;
  int folds_ = 0;
};

/// Runs tasks on `threads` workers.
void runParallel(std::vector<std::function<void()>>& tasks, int threads) {
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t i = next++; i < tasks.size(); i = next++) tasks[i]();
  };
  std::vector<std::thread> pool;
  for (int i = 1; i < std::max(1, threads); ++i) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
}

template <template <typename> class DriveT>
bool diagnoseDrive(const Odolog& log, const DiagnoseOptions& opt, json* out, std::string* error) {
  using En = Engine<DriveT>;
  using RunSpec = typename En::RunSpec;
  using RunOut = typename En::RunOut;
  using Drive = typename En::Drive;
  constexpr int kD = En::kD;
  constexpr int kE = En::kE;
  constexpr bool kSync = En::kSync;
  En en(log, opt);
  if (!en.prepare(error)) return false;
  const auto& fx = en.effects();
  const int ne = static_cast<int>(fx.size());
  std::vector<int> with_idx;
  for (const auto& w : opt.with) {
    int found = -1;
    for (int e = 0; e < ne; ++e)
      if (fx[e].name == w) found = e;
    if (found < 0) {
      std::string names;
      for (const auto& f : fx) names += (names.empty() ? "" : ", ") + f.name;
      *error = "--with: unknown effect '" + w + "' (the catalogue: " + names + ")";
      return false;
    }
    with_idx.push_back(found);
  }

  // 1. The model as the user has it: drive parameters and K estimated (the OF free).
  //    And the joint run: every augmentable candidate free, the OF free. Its K cannot have
  //    been inflated to absorb a systematic effect (the effect is in its model); every
  //    scoring run holds K there, so the OF is not free to hide an effect by inflating noise.
  //    Its covariance also gives the information structure (confusable pairs).
  RunOut base_free, joint;
  {
    std::vector<std::function<void()>> first;
    first.push_back([&] { base_free = en.run(en.nominalSpec(en.initialK(), true)); });
    first.push_back([&] {
      RunSpec s = en.nominalSpec(en.initialK(), true);
      for (int e = 0; e < ne; ++e)
        if (fx[e].kind != EffectKind::kNoise) en.freeEffect(&s, e);
      joint = en.run(s);
    });
    runParallel(first, opt.threads);
  }
  const auto k_hat = joint.k;
  // 2. The reference for scoring, K held (the OF may not hide an effect by inflating noise).
  //    It also fixes the set of beams every run is scored on.
  RunSpec base_spec = en.nominalSpec(k_hat, false);
  base_spec.record = true;
  std::vector<std::uint8_t> scored(en.scoredSize(), 0);
  base_spec.make_scored = &scored;
  const RunOut base = en.run(base_spec);
  const long n_innov = std::max(1L, base.n_innov);
  const double l0 = base.loglik;
  // 3. Every candidate scored against a reference spec: an augmented run (its parameters
  //    join the state) gives the estimate and the sigma the drive achieves; a held run (the
  //    parameters fixed at the informed estimates) gives the profile likelihood. A noise
  //    effect cannot be augmented: its profile is taken over a grid, with the OF free in
  //    every run (K and the noise effect compete for the same variance).
  struct Cand {
    Eigen::VectorXd est, sig;
    std::vector<bool> informed;
    double ll = 0, ll_ref = 0;
    int k = 0;
    double k_mult = 1, q_best = 0;  ///< noise effect: its best profile point (whose likelihood is ll)
    double wald = 0;                ///< Wald statistic of the informed parameters (k degrees of freedom)
    /// Noise effect: its profile, {q, best log-likelihood over K, its K multiplier, the
    /// parabola's peak over log K} per q.
    std::vector<std::array<double, 4>> profile;
  };
  // A noise effect competes with K for the same variance, and the K the OF gives has
  // absorbed that noise where the effect is real: so its profile is two-dimensional. At
  // each q the likelihood is maximised over a K multiplier (steps of 1.25, extended while
  // the best is at an edge); a coarse q grid finds the region and two more points (half and
  // twice the best q) refine it. The likelihood ratio compares the best q > 0 with q = 0.
  const double q_grid[4] = {0.0, 0.5, 2.0, 8.0};
  auto profileAtQ = [&](const RunSpec& ref, int e, double q) {
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
  };
  auto augmentTasks = [&](const RunSpec& ref, double ll_ref, int e, Cand* c, RunOut* aug,
                          std::vector<std::function<void()>>* tasks) {
    c->ll_ref = ll_ref;
    if (fx[e].kind == EffectKind::kNoise) {
      c->profile.assign(4, {});
      for (int g = 0; g < 4; ++g)
        tasks->push_back([&, ref, e, g, c] { c->profile[g] = profileAtQ(ref, e, q_grid[g] * fx[e].ref[0]); });
      return;
    }
    tasks->push_back([&, ref, e, aug] {
      RunSpec s = ref;
      en.freeEffect(&s, e);
      *aug = en.run(s);
    });
  };
  // After the augmented runs: estimates, informed parameters, and the held run's task.
  auto heldTasks = [&](const RunSpec& ref, int e, Cand* c, const RunOut& aug, std::vector<std::function<void()>>* tasks) {
    const EffectInfo& f = fx[e];
    c->est = Eigen::VectorXd::Zero(f.n);
    c->sig = Eigen::VectorXd::Zero(f.n);
    c->informed.assign(f.n, false);
    if (f.kind == EffectKind::kNoise) {
      tasks->push_back([&, ref, e, c] {
        const EffectInfo& fe = fx[e];
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
    tasks->push_back([&, ref, e, c] {
      RunSpec s = ref;
      for (int i = 0; i < fx[e].n; ++i)
        if (c->informed[i]) s.eff_val[fx[e].offset - kE + i] = c->est[i];
      c->ll = en.run(s).loglik;
    });
  };
  RunSpec ref0 = en.nominalSpec(k_hat, false);
  ref0.scored = &scored;
  std::vector<Cand> cand(ne);
  std::vector<RunOut> aug(ne);
  std::vector<std::function<void()>> tasks;
  for (int e = 0; e < ne; ++e) augmentTasks(ref0, l0, e, &cand[e], &aug[e], &tasks);
  runParallel(tasks, opt.threads);
  tasks.clear();
  for (int e = 0; e < ne; ++e) heldTasks(ref0, e, &cand[e], aug[e], &tasks);
  runParallel(tasks, opt.threads);
  tasks.clear();

  // 5. Held-out comparison (--with), cross-validated over time: in each fold, fit on the
  //    kept data (OF free), then evaluate with everything fitted held, predicting the
  //    fold's held-out blocks. Before (the model as it is) and after (with the effects).
  const int folds = en.folds();
  std::vector<RunOut> fit_before(folds), fit_after(folds), ev_before(folds), ev_after(folds);
  std::vector<RunSpec> fit_after_spec(folds);
  if (!with_idx.empty()) {
    for (int f = 0; f < folds; ++f) {
      tasks.push_back([&, f] {
        RunSpec fit = en.nominalSpec(en.initialK(), true);
        fit.mode = Mode::kFit;
        fit.fold = f;
        fit_before[f] = en.run(fit);
      });
      tasks.push_back([&, f] {
        RunSpec fit = en.nominalSpec(en.initialK(), true);
        fit.mode = Mode::kFit;
        fit.fold = f;
        for (int e : with_idx)
          if (fx[e].kind != EffectKind::kNoise) en.freeEffect(&fit, e);
        // A noise effect cannot be augmented: its fit is the profile over the kept data.
        for (int e : with_idx) {
          if (fx[e].kind != EffectKind::kNoise) continue;
          double best = -std::numeric_limits<double>::infinity(), best_q = 0;
          for (double g : q_grid) {
            RunSpec s = fit;
            s.eff_val[fx[e].offset - kE] = g * fx[e].ref[0];
            const RunOut r = en.run(s);  // scored on the kept data only
            if (r.loglik > best) {
              best = r.loglik;
              best_q = g * fx[e].ref[0];
            }
          }
          fit.eff_val[fx[e].offset - kE] = best_q;
        }
        fit_after_spec[f] = fit;
        fit_after[f] = en.run(fit);
      });
    }
    runParallel(tasks, opt.threads);
    tasks.clear();
    auto evalSpec = [&](const RunOut& f, int fold) {
      RunSpec ev = en.nominalSpec(f.k, false);
      ev.mode = Mode::kEval;
      ev.fold = fold;
      ev.hold_drive = true;
      ev.drive_val = f.x.template segment<Drive::kParams>(kD);
      return ev;
    };
    for (int f = 0; f < folds; ++f) {
      tasks.push_back([&, f] { ev_before[f] = en.run(evalSpec(fit_before[f], f)); });
      tasks.push_back([&, f] {
        RunSpec ev = evalSpec(fit_after[f], f);
        for (int e : with_idx)
          for (int i = 0; i < fx[e].n; ++i) {
            const int k = fx[e].offset + i;
            ev.eff_val[k - kE] = fx[e].kind == EffectKind::kNoise ? fit_after_spec[f].eff_val[k - kE] : fit_after[f].x[k];
          }
        ev_after[f] = en.run(ev);
      });
    }
    runParallel(tasks, opt.threads);  // here: the tasks use evalSpec, local to this block
    tasks.clear();
  }

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

  // Ranking: by p-value of the profile likelihood ratio with k informed parameters.
  struct Row {
    int e;
    double dll, lr, bic, p;
    int k;
    bool detectable, significant;
    double cond_p = -1;  ///< conditional test given the best effect (-1: not run)
    double wald_p = 1;   ///< the Wald test's p-value
  };
  const double ln_n = std::log(double(n_innov));
  auto test = [&](const Cand& c, Row* r) {
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
    return r->k > 0 && r->p < kAlpha && r->bic > 0 && r->wald_p < kAlphaWald;
  };
  std::vector<Row> rows;
  for (int e = 0; e < ne; ++e) {
    Row r{e, 0, 0, 0, 1, 0, false, false};
    r.significant = test(cand[e], &r);
    for (int i = 0; i < fx[e].n; ++i)
      r.detectable = r.detectable || (cand[e].informed[i] && cand[e].sig[i] < fx[e].ref[i] / 3);
    rows.push_back(r);
  }
  auto better = [](const Row& a, const Row& b) {
    if (a.significant != b.significant) return a.significant;
    if (a.p != b.p) return a.p < b.p;
    return a.bic > b.bic;
  };
  std::sort(rows.begin(), rows.end(), better);
  // Conditional tests: each of `others` scored against a reference that has `given` in
  // the model at its estimate (a noise effect with its K multiplier too).
  auto conditional = [&](int given, const std::vector<int>& others) {
    RunSpec ref1 = ref0;
    for (int i = 0; i < fx[given].n; ++i)
      if (cand[given].informed[i]) ref1.eff_val[fx[given].offset - kE + i] = cand[given].est[i];
    if (fx[given].kind == EffectKind::kNoise) {
      ref1.eff_val[fx[given].offset - kE] = cand[given].q_best;
      ref1.k = ref0.k * cand[given].k_mult;
    }
    std::vector<Cand> c2(ne);
    std::vector<RunOut> aug2(ne);
    for (int e : others) augmentTasks(ref1, cand[given].ll, e, &c2[e], &aug2[e], &tasks);
    runParallel(tasks, opt.threads);
    tasks.clear();
    for (int e : others) heldTasks(ref1, e, &c2[e], aug2[e], &tasks);
    runParallel(tasks, opt.threads);
    tasks.clear();
    std::vector<Row> res(ne);
    for (int e : others) {
      res[e] = Row{e, 0, 0, 0, 1, 0, false, false};
      res[e].significant = test(c2[e], &res[e]);
    }
    return res;
  };
  // The best two, each given the other: when the first loses its evidence once the second
  // is in the model but the second keeps its own, the second explains the data and goes
  // first (a noise effect that soaks up a systematic drift, for one); when each explains
  // the other away, the two are reported as confusable. Then forward selection, one step:
  // a further effect is named only if it still explains the data once the best one is in
  // the model (the others of a big effect's residue are not).
  std::vector<std::vector<int>> mutual(ne);
  if (rows.size() > 1 && rows[0].significant) {
    auto significantAfterTop = [&] {
      std::vector<int> v;
      for (std::size_t i = 1; i < rows.size(); ++i)
        if (rows[i].significant) v.push_back(rows[i].e);
      return v;
    };
    std::vector<int> second = significantAfterTop();
    std::vector<Row> given_top = conditional(rows[0].e, second);
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
    for (Row& r : rows) {
      if (std::find(second.begin(), second.end(), r.e) == second.end()) continue;
      r.significant = given_top[r.e].significant;
      r.cond_p = given_top[r.e].p;
    }
    std::stable_sort(rows.begin() + 1, rows.end(), better);
  }
  json ranking = json::array();
  for (const Row& r : rows) {
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
    const Cand& c = cand[r.e];
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
    if (f.kind == EffectKind::kNoise) {
      json prof = json::array();
      for (const auto& pt : c.profile) prof.push_back({{"q", pt[0]}, {"loglik", pt[1]}, {"k_multiplier", pt[2]}});
      ranking.back()["profile"] = prof;
    }
  }

  // Excitation: achievable sigmas of the drive parameters (the free baseline) and of each
  // candidate (its augmented run), with warnings.
  json ex_params = json::array();
  json warnings = json::array();
  fw::FilterSetup setup;
  for (int i = 0; i < Drive::kParams; ++i) {
    const int k = kD + i;
    const double prior = (kSync && i == 1) ? setup.sigma_e_theta : setup.sigma_scale;
    const double s = std::sqrt(base_free.p(k, k));
    ex_params.push_back({{"name", Drive::kParamNames[i]}, {"sigma_achievable", s}, {"prior_sigma", prior},
                         {"determined", s < 0.25 * prior}});
  }
  for (int i = 0; i < Drive::kParams; ++i) {
    for (int j = i + 1; j < Drive::kParams; ++j) {
      const int a = kD + i, b = kD + j;
      // with the others marginalised: solve for the combination that the drive cannot fix
      const double c = base_free.p(a, b) / std::sqrt(base_free.p(a, a) * base_free.p(b, b));
      if (std::abs(c) > 0.95) {
        warnings.push_back(std::string("This drive cannot separate ") + Drive::kParamNames[i] + " from " +
                           Drive::kParamNames[j] + " (correlation " + std::to_string(c).substr(0, 5) + "): " +
                           adviceFor(Drive::kParamNames[j]) + ".");
      }
    }
  }
  for (int i = 0; i < Drive::kParams; ++i) {
    const double prior = (kSync && i == 1) ? setup.sigma_e_theta : setup.sigma_scale;
    const double s = std::sqrt(base_free.p(kD + i, kD + i));
    if (!(s < 0.25 * prior)) {
      warnings.push_back(std::string("This drive leaves ") + Drive::kParamNames[i] + " poorly determined (sigma " +
                         std::to_string(s) + "): " + adviceFor(Drive::kParamNames[i]) + ".");
    }
  }
  for (int e = 0; e < ne; ++e) {
    const EffectInfo& f = fx[e];
    bool det = false;
    for (int i = 0; i < f.n; ++i) {
      const double s = cand[e].sig[i];
      ex_params.push_back({{"name", f.name + "." + f.pnames[i]}, {"sigma_achievable", s},
                           {"prior_sigma", f.prior[i]}, {"reference_size", f.ref[i]},
                           {"determined", cand[e].informed[i] && s < f.ref[i] / 3}});
      det = det || (cand[e].informed[i] && s < f.ref[i] / 3);
    }
    if (!det) {
      warnings.push_back("This drive cannot detect " + f.name + " of a typical size (" + std::to_string(f.ref[0]) +
                         "): " + adviceFor(f.name) + ".");
    }
  }

  // Statistics of the baseline (K held) and the verdict.
  const DriveStats st = computeStats(base.scans, base.beams, base.obs.empty() ? base_free.obs : base.obs,
                                     log.param("wheel_radius_m", 0.05));
  json tests = st.tests;
  // Parameter NEES against the logged truth (meta truth_param NAME VALUE).
  {
    std::vector<int> idx;
    std::vector<double> tv;
    for (const auto& [k, v] : log.meta) {
      if (k != "truth_param") continue;
      char name[64];
      double val;
      if (std::sscanf(v.c_str(), "%63s %lf", name, &val) != 2) continue;
      for (int i = 0; i < Drive::kParams; ++i)
        if (std::string(name) == Drive::kParamNames[i]) {
          idx.push_back(kD + i);
          tv.push_back(val);
        }
    }
    if (!idx.empty()) {
      Eigen::VectorXd e(idx.size());
      Eigen::MatrixXd p(idx.size(), idx.size());
      for (std::size_t a = 0; a < idx.size(); ++a) {
        e[a] = base_free.x[idx[a]] - tv[a];
        for (std::size_t b = 0; b < idx.size(); ++b) p(a, b) = base_free.p(idx[a], idx[b]);
      }
      tests["nees_params"] = e.dot(p.ldlt().solve(e));
      tests["nees_params_dof"] = idx.size();
    } else {
      tests["nees_params"] = nullptr;
    }
  }
  bool any_sig = false;
  for (const Row& r : rows) any_sig = any_sig || r.significant;
  const bool consistent = !any_sig && st.consistent;

  json heldout = nullptr;
  std::vector<HeldScan> held_before, held_after;  // every fold's predicted held-out scans
  if (!with_idx.empty()) {
    // Before and after over the beams both predicted (matched by key), fold by fold.
    struct Sums {
      double nis = 0, nll = 0, sq = 0, pos_sq = 0, head_sq = 0;
      long n = 0, nsq = 0, nt = 0;
    } before, after;
    using PerScan = std::vector<std::array<double, 3>>;  // NIS sum, NLL sum, beams
    auto take = [](const HeldBeam& h, Sums* sm, PerScan* per) {
      sm->nis += h.nis;
      sm->nll += h.nll;
      ++sm->n;
      if (h.inside) {
        sm->sq += h.nu2;
        ++sm->nsq;
      }
      auto& q = (*per)[static_cast<std::size_t>(h.scan)];
      q[0] += h.nis;
      q[1] += h.nll;
      q[2] += 1;
    };
    auto scans = [](const RunOut& r, const PerScan& per, Sums* sm, std::vector<HeldScan>* dst) {
      for (std::size_t k = 0; k < r.ho_scans.size(); ++k) {
        if (per[k][2] == 0) continue;
        dst->push_back({r.ho_scans[k].t, per[k][0] / per[k][2], per[k][1] / per[k][2], r.ho_scans[k].pose_err});
      }
      sm->pos_sq += r.ho_pos_sq;
      sm->head_sq += r.ho_head_sq;
      sm->nt += r.ho_nt;
    };
    auto common = [&](RunOut& rb, RunOut& ra) {
      auto byKey = [](const HeldBeam& x, const HeldBeam& y) { return x.key < y.key; };
      std::sort(rb.ho_beams.begin(), rb.ho_beams.end(), byKey);
      std::sort(ra.ho_beams.begin(), ra.ho_beams.end(), byKey);
      PerScan pb(rb.ho_scans.size(), {0, 0, 0}), pa(ra.ho_scans.size(), {0, 0, 0});
      for (std::size_t i = 0, j = 0; i < rb.ho_beams.size() && j < ra.ho_beams.size();) {
        const HeldBeam &x = rb.ho_beams[i], &y = ra.ho_beams[j];
        if (x.key < y.key) {
          ++i;
        } else if (y.key < x.key) {
          ++j;
        } else {
          if (x.ok && y.ok) {
            take(x, &before, &pb);
            take(y, &after, &pa);
          }
          ++i;
          ++j;
        }
      }
      scans(rb, pb, &before, &held_before);
      scans(ra, pa, &after, &held_after);
    };
    // A fold whose fit lost the robot (dead-reckoning through a held-out block) has no
    // meaningful parameters: it is left out of both sides and reported.
    json fits = json::array(), failed = json::array();
    for (int f = 0; f < folds; ++f) {
      json est_after = json::object();
      for (int e : with_idx) {
        std::vector<double> v;
        for (int i = 0; i < fx[e].n; ++i) {
          const int k = fx[e].offset + i;
          v.push_back(fx[e].kind == EffectKind::kNoise ? fit_after_spec[f].eff_val[k - kE] : fit_after[f].x[k]);
        }
        est_after[fx[e].name] = v;
      }
      const bool ok = fit_before[f].lost_s < kLostS && fit_after[f].lost_s < kLostS;
      fits.push_back({{"fold", f}, {"used", ok}, {"lost_s_before", fit_before[f].lost_s},
                      {"lost_s_after", fit_after[f].lost_s}, {"after_estimate", est_after}});
      if (!ok) {
        failed.push_back(f);
        continue;
      }
      common(ev_before[f], ev_after[f]);
    }
    auto byTime = [](const HeldScan& a, const HeldScan& b) { return a.t < b.t; };
    std::sort(held_before.begin(), held_before.end(), byTime);
    std::sort(held_after.begin(), held_after.end(), byTime);
    auto metrics = [](const Sums& r) {
      json m;
      m["nis_mean"] = r.n > 0 ? json(r.nis / double(r.n)) : json(nullptr);
      m["nll_mean"] = r.n > 0 ? json(r.nll / double(r.n)) : json(nullptr);
      m["innovation_rms_m"] = r.nsq > 0 ? json(std::sqrt(r.sq / double(r.nsq))) : json(nullptr);
      m["pose_rmse_m"] = r.nt > 0 ? json(std::sqrt(r.pos_sq / double(r.nt))) : json(nullptr);
      m["heading_rmse_rad"] = r.nt > 0 ? json(std::sqrt(r.head_sq / double(r.nt))) : json(nullptr);
      return m;
    };
    // Paired by block: each block's mean after minus before, of the NIS, the NLL and the pose
    // error. A consistent change over the blocks (not one lucky block) is what an effect
    // that is really there gives: z is the mean change over its standard error.
    const auto& bl = en.blocks();
    auto paired = [&](double HeldScan::*field) {
      std::vector<double> sb(bl.size(), 0), sa(bl.size(), 0);
      std::vector<int> cb(bl.size(), 0), ca(bl.size(), 0);
      for (const HeldScan& h : held_before)
        if (const int k = en.blockAt(h.t); k >= 0 && std::isfinite(h.*field)) sb[k] += h.*field, ++cb[k];
      for (const HeldScan& h : held_after)
        if (const int k = en.blockAt(h.t); k >= 0 && std::isfinite(h.*field)) sa[k] += h.*field, ++ca[k];
      std::vector<double> d;
      int improved = 0;
      for (std::size_t k = 0; k < bl.size(); ++k) {
        if (cb[k] == 0 || ca[k] == 0) continue;
        d.push_back(sa[k] / ca[k] - sb[k] / cb[k]);
        improved += d.back() < 0 ? 1 : 0;
      }
      double dm = 0, dv = 0;
      for (double x : d) dm += x / double(d.size());
      for (double x : d) dv += (x - dm) * (x - dm) / std::max(1.0, double(d.size()) - 1);
      json r = {{"blocks", d.size()},
                {"blocks_better", improved},
                {"change_mean", d.empty() ? json(nullptr) : json(dm)},
                {"change_z", d.size() > 1 && dv > 0 ? json(dm / std::sqrt(dv / double(d.size()))) : json(nullptr)}};
      return r;
    };
    json blocks = json::array();
    for (const auto& h : bl) blocks.push_back({h.first, h.second});
    heldout = {{"with", opt.with},
               {"folds", folds},
               {"folds_failed", failed},
               {"fits", fits},
               {"blocks", blocks},
               {"gap_s", opt.gap_s},
               {"reanchor_s", opt.reanchor_s},
               {"before", metrics(before)},
               {"after", metrics(after)},
               {"paired", {{"nis", paired(&HeldScan::nis)}, {"nll", paired(&HeldScan::nll)},
                           {"pose_err_m", paired(&HeldScan::pose_err)}}}};
    if (folds == 0) {
      char note[160];
      std::snprintf(note, sizeof note, "no held-out block: the drive is shorter than warm-up + gap + one block (%.1f s)",
                    opt.warmup_s + opt.gap_s + opt.block_s);
      heldout["note"] = note;
    }
  }

  json walls = json::array();
  for (const auto& w : log.walls) walls.push_back({w.x1, w.y1, w.x2, w.y2});
  json& j = *out;
  j = json::object();
  j["log"] = log.path;
  j["drive"] = log.drive;
  j["verdict"] = consistent ? "consistent" : "inconsistent";
  j["tests"] = tests;
  j["ranking"] = ranking;
  j["heldout"] = heldout;
  j["excitation"] = {{"parameters", ex_params}, {"warnings", warnings}};
  j["bins"] = st.bins;
  j["cusum"] = st.cusum;
  j["baseline"] = {{"innovations", n_innov},
                   {"loglik", l0},
                   {"k_estimate", std::vector<double>(base_free.k.data(), base_free.k.data() + base_free.k.size())},
                   {"k_held", std::vector<double>(k_hat.data(), k_hat.data() + k_hat.size())},
                   {"parameters", [&] {
                      json p = json::object();
                      for (int i = 0; i < Drive::kParams; ++i)
                        p[Drive::kParamNames[i]] = {{"estimate", base_free.x[kD + i]},
                                                    {"sigma", std::sqrt(base_free.p(kD + i, kD + i))}};
                      return p;
                    }()}};
  j["map"] = {{"walls", walls}};

  if (!opt.out_dir.empty()) {
    if (!writeDiagnoseCsv(opt.out_dir, base.scans, base.beams, base.traj, error)) return false;
    if (!with_idx.empty()) {
      for (const auto& [name, rows_] : {std::pair{"heldout_before.csv", &held_before}, {"heldout_after.csv", &held_after}}) {
        std::ofstream f(std::filesystem::path(opt.out_dir) / name);
        f << "t,nis,nll,pose_err_m\n";
        char buf[96];
        for (const HeldScan& h : *rows_) {
          std::snprintf(buf, sizeof buf, "%.3f,%.4f,%.4f,%.5f\n", h.t, h.nis, h.nll, h.pose_err);
          f << buf;
        }
        if (!f) {
          *error = "cannot write '" + (std::filesystem::path(opt.out_dir) / name).string() + "'";
          return false;
        }
      }
    }
  }
  return true;
}

}  // namespace

std::vector<std::string> diagnoseEffectNames() {
  std::vector<std::string> v;
  std::apply([&](auto... e) { (v.push_back(decltype(e)::kName), ...); }, Catalogue{});
  return v;
}

bool diagnoseOdolog(const Odolog& log, const DiagnoseOptions& opt, json* out, std::string* error) {
  return log.drive == "sync" ? diagnoseDrive<SyncDrive>(log, opt, out, error)
                             : diagnoseDrive<DiffDrive>(log, opt, out, error);
}

}  // namespace odoerr::sim
