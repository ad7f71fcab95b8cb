// odoerr core: the Observable Filter (OF) of Section 4.
//
// State: the non-systematic parameters K ([K_rho, K_theta] sync, [K_w] diff), constant in
// time (F = I, no process noise). Every j AKF cycles the observable (8) (sync) or its
// second component (diff) is formed from the AKF poses at the start and the end of the
// window and the encoder inputs in between (replayed with the AKF's current systematic
// estimate), and fused with R = Cov_Obs + pose-error term.
#pragma once

#include <cstdint>

#include "odoerr/akf.hpp"
#include "odoerr/observables.hpp"

namespace odoerr {

/// How the pose-error term of R is evaluated.
enum class PoseErrorTerm : std::uint8_t {
  kExpected = 0,  ///< its expectation under the model at the current K (default, stable)
  kLiteral = 1,   ///< the paper read literally: gradient at the observed values (collapses)
};

template <typename S>
struct OfConfig {
  /// j: at least this many AKF cycles between the two poses of one observation; a window
  /// closes at the first cycle with a fused measurement once j cycles are in.
  int window = 1;
  PoseErrorTerm pose_term = PoseErrorTerm::kExpected;
  /// K is kept at or above this fraction of its initial value (positivity).
  S min_fraction_of_initial = S(1e-6);
};

struct OfCounters {
  std::uint32_t updates = 0;
  std::uint32_t rejected = 0;       ///< innovation covariance not positive definite / not finite
  std::uint32_t clamped = 0;        ///< K hit its positivity floor
  std::uint32_t broken_windows = 0; ///< a window discarded because an AKF step failed
};

template <typename ModelT, int MaxWindow = 32>
class ObservableFilter {
 public:
  using Model = ModelT;
  using Drive = typename Model::Drive;
  using S = typename Model::Scalar;
  using Input = typename Model::Input;
  static constexpr int M = Drive::kNonSys;
  using KVec = Eigen::Matrix<S, M, 1>;
  using KMat = Eigen::Matrix<S, M, M>;
  static constexpr bool kSync = std::is_same_v<Drive, SyncDrive<S>>;
  static constexpr int kObs = kSync ? 2 : 1;
  using ObsVec = Eigen::Matrix<S, kObs, 1>;
  using ObsMat = Eigen::Matrix<S, kObs, kObs>;

  ObservableFilter() = default;
  explicit ObservableFilter(const OfConfig<S>& cfg) : cfg_(cfg) {
    if (cfg_.window < 1) cfg_.window = 1;
    if (cfg_.window > MaxWindow) cfg_.window = MaxWindow;
  }

  void init(const KVec& k0, const KMat& p0) {
    k_ = k0;
    p_ = p0;
    floor_ = k0 * cfg_.min_fraction_of_initial;
    count_ = 0;
    open_ = false;
  }

  const KVec& estimate() const { return k_; }
  const KMat& covariance() const { return p_; }
  const OfCounters& counters() const { return counters_; }
  const OfConfig<S>& config() const { return cfg_; }
  /// The last observation and its predicted mean (for diagnostics).
  const ObsVec& lastObservation() const { return last_z_; }
  const ObsVec& lastPredicted() const { return last_m_; }
  /// Innovation variances of the last observation (diagonal of H P H^T + R).
  const ObsVec& lastVariance() const { return last_s_; }

  /// Starts a window at the AKF's current pose. Called once after the AKF is initialised.
  template <typename AkfT>
  void begin(const AkfT& akf) {
    start_ = akf.pose();
    p_start_ = akf.covariance().template topLeftCorner<3, 3>();
    count_ = 0;
    open_ = true;
  }

  /// Records the input of an AKF cycle that was predicted successfully.
  void addInput(const Input& u) {
    if (!open_) return;
    if (count_ < MaxWindow) {
      inputs_[count_++] = u;
    } else {
      ++counters_.broken_windows;  // the window overflowed: it can no longer be replayed
      open_ = false;
    }
  }

  /// Signals that the last AKF cycle failed: the window cannot be closed honestly.
  template <typename AkfT>
  void breakWindow(const AkfT& akf) {
    ++counters_.broken_windows;
    begin(akf);
  }

  /// After a cycle: closes the window when at least j inputs are in AND the cycle fused a
  /// measurement (a window ending on a prediction-only pose carries no information: its
  /// observable is exactly zero), fuses the observation, and opens the next window. A
  /// window that outgrows MaxWindow inputs without a measurement is discarded (counted).
  /// Returns true when an OF update happened.
  template <typename AkfT>
  bool step(const AkfT& akf, bool measured = true) {
    if (!open_) {  // never begun, or overflowed in addInput: restart at this pose
      begin(akf);
      return false;
    }
    if (!measured || count_ < cfg_.window) {
      if (count_ >= MaxWindow) breakWindow(akf);
      return false;
    }
    const bool fused = fuse(akf);
    begin(akf);
    return fused;
  }

 private:
  template <typename AkfT>
  bool fuse(const AkfT& akf) {
    const auto& x = akf.state();
    const Model& model = akf.model();
    // Replay the window's inputs from the start pose with the current systematic estimate.
    const typename Model::NoiseVec zero = Model::NoiseVec::Zero();
    Pose<S> pe = start_;
    S len = S(0);
    S rot = S(0);
    S path_r = S(0);
    S path_l = S(0);
    for (int i = 0; i < count_; ++i) {
      const Increment<S> inc = model.increment(inputs_[i], x, zero);
      pe = applyIncrement(pe, inc);
      rot += inc.theta;
      len += Drive::pathLength(inputs_[i]);
      if constexpr (!kSync) {
        path_r += std::abs(inputs_[i].right);
        path_l += std::abs(inputs_[i].left);
      }
    }
    const Pose<S> end = akf.pose();
    const Eigen::Matrix<S, 3, 3> p_end = akf.covariance().template topLeftCorner<3, 3>();
    const S dx = (end.x - start_.x) - (pe.x - start_.x);
    const S dy = (end.y - start_.y) - (pe.y - start_.y);
    const S e = wrapAngle(end.theta - pe.theta);

    ObsVec z;
    ObsVec m;
    Eigen::Matrix<S, kObs, M> h;
    ObsMat r;
    if constexpr (kSync) {
      SyncSegment<S> seg;
      seg.length = len;
      seg.rotation = rot;
      seg.delta_rho = x[Model::kDriveOffset + Drive::kDeltaRho];
      const SyncMean<S> mean = syncObservableMean(seg, k_[0], k_[1]);
      const Eigen::Matrix<S, 3, 3> wl = syncNoiseMoments(seg, k_[0], k_[1]);
      const Eigen::Matrix<S, 3, 3> ww = rotateMoments(wl, start_.theta);
      Eigen::Matrix<S, 3, 3> wpose = ww;
      if (cfg_.pose_term == PoseErrorTerm::kLiteral) {
        const Eigen::Matrix<S, 3, 1> wobs(dx, dy, e);
        wpose = wobs * wobs.transpose();
      }
      z << dx * dx + dy * dy, e * e;
      m << mean.z1, mean.z2;
      h << mean.dz1_dkrho, mean.dz1_dktheta, S(0), mean.dz2_dktheta;
      r = syncObservableCovariance(wl) +
          syncPoseErrorTerm(wpose, p_start_, p_end, pe.x - start_.x, pe.y - start_.y);
    } else {
      const S dd = x[Model::kDriveOffset + Drive::kDeltaD];
      const DiffMoments<S> mo =
          diffObservableMoments(path_r, path_l, model.drive.wheelbase, dd, k_[0]);
      const S w2 = cfg_.pose_term == PoseErrorTerm::kLiteral ? e * e : mo.mean;
      z << e * e;
      m << mo.mean;
      h << mo.dmean_dkw;
      r << mo.variance + S(4) * w2 * (p_start_(2, 2) + p_end(2, 2));
    }
    last_z_ = z;
    last_m_ = m;

    const ObsMat s = h * p_ * h.transpose() + r;
    last_s_ = s.diagonal();
    ObsMat s_inv;
    if (!invertSpd(s, &s_inv)) {
      ++counters_.rejected;
      return false;
    }
    const Eigen::Matrix<S, M, kObs> gain = p_ * h.transpose() * s_inv;
    const KVec k_new = k_ + gain * (z - m);
    KMat p_new = p_ - gain * h * p_;
    p_new = S(0.5) * (p_new + p_new.transpose()).eval();
    if (!k_new.allFinite() || !p_new.allFinite() || !(p_new.diagonal().array() > S(0)).all()) {
      ++counters_.rejected;
      return false;
    }
    k_ = k_new;
    p_ = p_new;
    for (int i = 0; i < M; ++i) {
      if (k_[i] < floor_[i]) {
        k_[i] = floor_[i];
        ++counters_.clamped;
      }
    }
    ++counters_.updates;
    return true;
  }

  /// Checked inverse of a 1x1 or 2x2 symmetric positive-definite matrix.
  static bool invertSpd(const ObsMat& s, ObsMat* out) {
    if constexpr (kObs == 1) {
      if (!isFinite(s(0, 0)) || !(s(0, 0) > S(0))) return false;
      (*out)(0, 0) = S(1) / s(0, 0);
      return true;
    } else {
      // Scale to a correlation matrix first: the entries are ~K^2 L^2, far below 1, and a
      // raw determinant would underflow in float.
      if (!isFinite(s(0, 0)) || !isFinite(s(1, 1)) || !isFinite(s(0, 1))) return false;
      if (!(s(0, 0) > S(0)) || !(s(1, 1) > S(0))) return false;
      const S d0 = std::sqrt(s(0, 0));
      const S d1 = std::sqrt(s(1, 1));
      const S rho = s(0, 1) / (d0 * d1);
      const S one_minus = S(1) - rho * rho;
      if (!(one_minus > S(1e-6))) return false;
      (*out) << S(1) / (s(0, 0) * one_minus), -rho / (d0 * d1 * one_minus),
          -rho / (d0 * d1 * one_minus), S(1) / (s(1, 1) * one_minus);
      return true;
    }
  }

  OfConfig<S> cfg_{};
  KVec k_ = KVec::Ones();
  KMat p_ = KMat::Identity();
  KVec floor_ = KVec::Zero();
  Pose<S> start_{};
  Eigen::Matrix<S, 3, 3> p_start_ = Eigen::Matrix<S, 3, 3>::Zero();
  Input inputs_[MaxWindow]{};
  int count_ = 0;
  bool open_ = false;
  ObsVec last_z_ = ObsVec::Zero();
  ObsVec last_m_ = ObsVec::Zero();
  ObsVec last_s_ = ObsVec::Zero();
  OfCounters counters_{};
};

}  // namespace odoerr
