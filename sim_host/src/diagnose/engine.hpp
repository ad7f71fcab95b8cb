// diagnose, the filter runs over a log: Engine prepares a log (its filter events,
// events.hpp; its held-out blocks and folds, heldout_blocks.hpp; the model and its effects)
// and Engine::run runs the estimator with the whole effect catalogue composed in over
// those events in one of three modes (full, fit with a fold held out, evaluate a fold's
// held-out blocks from anchors). Every other part of diagnose (ranking, held-out
// comparison, excitation, discovery) is built from such runs. The members that run the
// estimator are defined in engine.cpp, which instantiates the four engines; every other
// file sees them `extern` and compiles none of the estimator's templates.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "events.hpp"
#include "heldout_blocks.hpp"
#include "odoerr/effects/catalogue.hpp"
#include "odoerr/effects/feature_effects.hpp"
#include "odoerr/estimator.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/sim/diagnose.hpp"
#include "odoerr/sim/host_map.hpp"
#include "odoerr/sim/stats.hpp"
#include "parallel.hpp"
#include "run_types.hpp"

namespace odoerr::sim::diag {

template <template <typename> class DriveT, typename Effects = Catalogue>
class Engine {
 public:
  using S = double;
  using Drive = DriveT<S>;
  using M = typename ModelOf<Drive, Effects>::type;
  using Est = HostEstimator<M>;
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
    bool residuals = false;  ///< record the posterior poses and beam residuals (discovery)
    /// The beams the likelihood is scored on (scan * beams + beam); the baseline run
    /// chooses them (make_scored) and every other run scores the same set.
    const std::vector<std::uint8_t>* scored = nullptr;
    std::vector<std::uint8_t>* make_scored = nullptr;
    /// Carried from a previous log (odoerr evaluate): the parameter block (drive and
    /// effects, index >= kD) of the state and covariance, and K with its covariance; the
    /// pose is re-initialised from the log's init. Null: the priors above.
    const StateVec* carry_x = nullptr;
    const StateMat* carry_p = nullptr;
    const KMat* carry_pk = nullptr;
  };
  struct RunOut {
    double loglik = 0;
    long n_innov = 0;
    StateVec x;
    StateMat p;
    KVec k;
    KMat pk;  ///< K's covariance at the end
    double ho_pos_sq = 0, ho_head_sq = 0;
    long ho_nt = 0;                  ///< kEval: truth samples at the predicted measurements
    std::vector<HeldEvent> ho_scans;  ///< kEval: every predicted held-out scan or fix
    std::vector<HeldBeam> ho_beams;  ///< kEval: their beams
    std::vector<ScanRec> scans;
    std::vector<BeamRec> beams;
    std::vector<PoseFixRec> fixes;  ///< record: every fused pose fix's innovation
    std::vector<TrajRec> traj;
    std::vector<PostPose> post;       ///< residuals: the posterior at every fused measurement
    std::vector<PostBeam> post_beams;  ///< residuals: the beams of the fused scans at their posterior
    std::vector<std::array<double, 2>> obs;  // OF observable (z - m) / sqrt(s), per component
    /// The longest time the filter fused scans with under a quarter of their beams used
    /// (every other one gated or unpredictable): it had lost the robot.
    double lost_s = 0;
  };

  Engine(const Odolog& log, const DiagnoseOptions& opt, FeatureSlots slots = {})
      : log_(log), opt_(opt), slots_(std::move(slots)) {}
  Engine(const Engine&) = delete;  // map_ points into host_map_
  Engine& operator=(const Engine&) = delete;

  bool prepare(std::string* error);

  const std::vector<EffectInfo>& effects() const { return effects_; }

  /// The model: the drive and every catalogue effect, configured from the log.
  M makeModel() const;
  const FeatureSlots& slots() const { return slots_; }

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

  RunOut run(const RunSpec& spec) const;

  /// Discovery's residuals after a fused measurement: the posterior pose, and for a scan
  /// every beam predicted again at the posterior (measurement effects included).
  void recordPosterior(const Est& est, const Event& ev, RunOut* out, const double* ranges) const;

  /// A beam whose predicted hit lies within 5 cm of a wall's end: its prediction can jump
  /// to another wall with a tiny change of pose, so it says little about a smooth effect.
  bool nearCorner(const StateVec& x, int beam, double range) const;
  std::size_t scoredSize() const { return log_.scans.size() * static_cast<std::size_t>(std::max(0, lc_.beams)); }

  /// The held-out block that holds time t (-1: none).
  int blockAt(double t) const { return heldout_.blockAt(t); }
  const std::vector<std::pair<double, double>>& blocks() const { return heldout_.blocks(); }
  const std::vector<Event>& events() const { return events_; }
  const typename Est::MapT& map() const { return map_; }
  const typename Est::LaserT& laser() const { return laser_; }
  const Odolog& log() const { return log_; }
  int folds() const { return heldout_.folds(); }
  double duration() const { return t1_ - t0_; }
  const Drive& drive() const { return drive_; }

 private:
  template <std::size_t... I>
  void buildEffectsImpl(const M& m, std::index_sequence<I...>) {
    (addEffect(std::get<I>(m.effects)), ...);
  }
  template <typename E>
  void addEffect(const E& e) {
    EffectInfo fi;
    fi.name = E::kName;
    fi.description = E::kDescription;
    fi.kind = E::kKind;
    fi.offset = M::template offsetOf<E>();
    fi.n = E::kParams;
    for (int i = 0; i < E::kParams; ++i) {
      fi.prior.push_back(effects::priorSigma(e, i));  // a feature effect's: its configured slots (0: unused)
      fi.ref.push_back(effects::referenceSize(e, i));
      fi.pnames.push_back(E::kParamNames[i]);
    }
    effects_.push_back(fi);
  }
  void buildEffects() { buildEffectsImpl(makeModel(), std::make_index_sequence<std::tuple_size_v<Effects>>{}); }

  const Odolog& log_;
  DiagnoseOptions opt_;
  FeatureSlots slots_;
  Drive drive_{};
  double ticks_a_ = 1, ticks_b_ = 1;
  HostMap<S> host_map_;
  typename Est::MapT map_;  ///< a view of host_map_
  LaserConfig<S> lc_{};
  typename Est::LaserT laser_;
  std::vector<EffectInfo> effects_;
  std::vector<Event> events_;
  double t0_ = 0, t1_ = 0;
  HeldoutBlocks heldout_;
};

extern template class Engine<SyncDrive>;
extern template class Engine<DiffDrive>;
extern template class Engine<SyncDrive, Featured>;
extern template class Engine<DiffDrive, Featured>;

}  // namespace odoerr::sim::diag
