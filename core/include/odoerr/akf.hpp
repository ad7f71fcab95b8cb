// odoerr core: the augmented Kalman filter (AKF) of Section 3 (after Larsen et al.).
//
// State: pose plus the systematic odometry parameters (and any composed effects), see
// model.hpp. Prediction uses the encoder increments of one cycle, with the process noise
// of the non-systematic model evaluated at the Observable Filter's current estimate.
// Observation: N laser ranges against a known segment map, fused one scalar beam at a
// time, each re-predicted at the state updated by the beams before it.
#pragma once

#include <cstdint>

#include "odoerr/map.hpp"
#include "odoerr/model.hpp"

namespace odoerr {

/// Why a step or a beam was not applied. Every rejection is counted, never silent.
enum class Status : std::uint8_t {
  kOk = 0,
  kBadInput,       ///< a non-finite input
  kNoReturn,       ///< beam had no valid return (nan, <= 0 or beyond range_max)
  kNoMapHit,       ///< the predicted beam hits no wall
  kGrazing,        ///< incidence on the predicted wall beyond the limit
  kGated,          ///< normalised innovation squared above the gate
  kBadInnovation,  ///< innovation variance not finite or not above the measurement variance
  kBadCovariance,  ///< the update would make a variance non-positive or non-finite
};

/// Health counters (monotonic; the firmware publishes them as telemetry).
struct AkfCounters {
  std::uint32_t predictions = 0;
  std::uint32_t bad_inputs = 0;
  std::uint32_t bad_predictions = 0;
  std::uint32_t beams_used = 0;
  std::uint32_t no_return = 0;
  std::uint32_t no_map_hit = 0;
  std::uint32_t grazing = 0;
  std::uint32_t gated = 0;
  std::uint32_t bad_innovation = 0;
  std::uint32_t bad_covariance = 0;
};

template <typename S>
struct AkfConfig {
  /// Beams whose incidence angle on the predicted wall exceeds this are skipped: near
  /// grazing incidence dr/dtheta grows like tan(incidence) and one beam can wreck the
  /// heading. 75 degrees by default.
  S max_incidence_rad = S(75.0 / 180.0) * kPi<S>;
  /// Gate on the normalised innovation squared (nu^2 / S) of one beam: 25 = 5 sigma.
  S gate_nis = S(25);
};

/// Per-scan summary for statistics.
template <typename S>
struct ScanStats {
  int used = 0;
  int skipped = 0;
  S nis_sum = S(0);  ///< sum of nu^2/S over the used beams
};

template <typename ModelT>
class Akf {
 public:
  using Model = ModelT;
  using S = typename Model::Scalar;
  using Input = typename Model::Input;
  using NonSysVec = typename Model::NonSysVec;
  static constexpr int N = Model::kStates;
  using StateVec = typename Model::StateVec;
  using StateMat = typename Model::StateMat;

  Akf() = default;
  explicit Akf(const Model& m, const AkfConfig<S>& cfg = {}) : model_(m), cfg_(cfg) {}

  void init(const StateVec& x0, const StateMat& p0) {
    x_ = x0;
    p_ = p0;
  }

  const StateVec& state() const { return x_; }
  const StateMat& covariance() const { return p_; }
  Pose<S> pose() const { return {x_[PoseIdx::kX], x_[PoseIdx::kY], x_[PoseIdx::kTheta]}; }
  const AkfCounters& counters() const { return counters_; }
  const Model& model() const { return model_; }
  const AkfConfig<S>& config() const { return cfg_; }

  /// Prediction with the encoder increments of one cycle; k = current non-systematic
  /// estimate (the OF's), which sets the process noise.
  [[nodiscard]] Status predict(const Input& u, const NonSysVec& k) {
    if (!Model::Drive::inputFinite(u) || !k.allFinite()) {
      ++counters_.bad_inputs;
      return Status::kBadInput;
    }
    Eigen::Matrix<S, 3, N> f_pose;
    Eigen::Matrix<S, 3, Model::kNoise> g_pose;
    const Pose<S> next = transition(model_, x_, u, &f_pose, &g_pose);
    const typename Model::NoiseVec q = model_.drive.noiseVariance(u, k);

    // P' = F P F^T + G Q G^T, with F = [f_pose; 0 I] and G = [g_pose; 0].
    // Rows/cols of the parameter block are unchanged except through f_pose.
    const Eigen::Matrix<S, 3, N> fp = f_pose * p_;  // 3 x N
    StateMat pn = p_;
    pn.template topRows<3>() = fp;
    pn.template leftCols<3>() = fp.transpose();
    pn.template topLeftCorner<3, 3>() =
        fp * f_pose.transpose() + g_pose * q.asDiagonal() * g_pose.transpose();
    symmetrise(pn);
    if (!covarianceHealthy(pn)) {
      ++counters_.bad_predictions;
      return Status::kBadCovariance;
    }
    p_ = pn;
    x_[PoseIdx::kX] = next.x;
    x_[PoseIdx::kY] = next.y;
    x_[PoseIdx::kTheta] = next.theta;
    ++counters_.predictions;
    return Status::kOk;
  }

  /// The state transition f_a of one cycle at the mean input: the next pose, and the pose
  /// rows of F_a = d f_a / d X_a (3 x N; the parameter rows are identity) and of
  /// G_a = d f_a / d nu (3 x kNoise; the parameter rows are zero).
  static Pose<S> transition(const Model& model, const StateVec& x, const Input& u,
                            Eigen::Matrix<S, 3, N>* f_pose,
                            Eigen::Matrix<S, 3, Model::kNoise>* g_pose) {
    Eigen::Matrix<S, 3, N> d_state;
    Eigen::Matrix<S, 3, Model::kNoise> d_noise;
    const typename Model::NoiseVec zero = Model::NoiseVec::Zero();
    const Increment<S> inc = model.increment(u, x, zero, &d_state, &d_noise);
    IncrementJacobians<S> jp;
    const Pose<S> p{x[PoseIdx::kX], x[PoseIdx::kY], x[PoseIdx::kTheta]};
    const Pose<S> next = applyIncrement(p, inc, &jp);
    *f_pose = jp.d_inc * d_state;
    (*f_pose)(0, PoseIdx::kX) += S(1);
    (*f_pose)(1, PoseIdx::kY) += S(1);
    (*f_pose)(2, PoseIdx::kTheta) += S(1);
    (*f_pose)(0, PoseIdx::kTheta) += jp.dx_dth;
    (*f_pose)(1, PoseIdx::kTheta) += jp.dy_dth;
    *g_pose = jp.d_inc * d_noise;
    return next;
  }

  /// Fuses one scan (ranges in beam order, nan = no return) against the map.
  template <int MaxWalls>
  ScanStats<S> updateScan(const SegmentMap<S, MaxWalls>& map, const LaserConfig<S>& laser,
                          const S* ranges) {
    ScanStats<S> st;
    for (int i = 0; i < laser.beams; ++i) {
      S nis = S(0);
      const Status s = updateBeam(map, laser, i, ranges[i], &nis);
      if (s == Status::kOk) {
        ++st.used;
        st.nis_sum += nis;
      } else {
        ++st.skipped;
      }
    }
    return st;
  }

  /// One scalar range update of beam i. On success returns kOk and the beam's NIS.
  template <int MaxWalls>
  [[nodiscard]] Status updateBeam(const SegmentMap<S, MaxWalls>& map, const LaserConfig<S>& laser,
                                  int i, S measured, S* nis_out = nullptr) {
    if (!isFinite(measured) || !(measured > S(0)) || measured > laser.range_max) {
      ++counters_.no_return;
      return Status::kNoReturn;
    }
    Eigen::Matrix<S, 1, 3> h;
    S predicted = S(0);
    const Status ps = predictBeam(map, laser, i, &predicted, &h);
    if (ps != Status::kOk) return ps;

    const S r = laser.sigma * laser.sigma;
    // P H^T: only the pose columns of H are non-zero.
    const StateVec pht = p_.template leftCols<3>() * h.transpose();
    const S s = h * pht.template head<3>() + r;
    if (!isFinite(s) || !(s > r)) {
      ++counters_.bad_innovation;
      return Status::kBadInnovation;
    }
    const S nu = measured - predicted;
    const S nis = nu * nu / s;
    if (!(nis <= cfg_.gate_nis)) {
      ++counters_.gated;
      return Status::kGated;
    }
    // Check the covariance update before applying it: diag(P - pht pht^T / s) > 0.
    const StateVec new_diag = p_.diagonal() - pht.cwiseAbs2() / s;
    if (!(new_diag.array() > S(0)).all() || !new_diag.allFinite()) {
      ++counters_.bad_covariance;
      return Status::kBadCovariance;
    }
    const StateVec gain = pht / s;
    x_ += gain * nu;
    x_[PoseIdx::kTheta] = wrapAngle(x_[PoseIdx::kTheta]);
    p_.noalias() -= gain * pht.transpose();
    symmetrise(p_);
    ++counters_.beams_used;
    if (nis_out != nullptr) *nis_out = nis;
    return Status::kOk;
  }

  /// Expected range of beam i at the current state and its Jacobian wrt (x, y, theta).
  template <int MaxWalls>
  [[nodiscard]] Status predictBeam(const SegmentMap<S, MaxWalls>& map, const LaserConfig<S>& laser,
                                   int i, S* range, Eigen::Matrix<S, 1, 3>* h) {
    const Status s = expectedRange(map, laser, pose(), i, cfg_.max_incidence_rad, range, h);
    if (s == Status::kNoMapHit) ++counters_.no_map_hit;
    if (s == Status::kGrazing) ++counters_.grazing;
    return s;
  }

  /// Pure function: expected range of beam i from a robot pose, with dr/d(x, y, theta).
  template <int MaxWalls>
  static Status expectedRange(const SegmentMap<S, MaxWalls>& map, const LaserConfig<S>& laser,
                              const Pose<S>& p, int i, S max_incidence, S* range,
                              Eigen::Matrix<S, 1, 3>* h) {
    const S c = std::cos(p.theta);
    const S sn = std::sin(p.theta);
    const S lx = p.x + c * laser.mount_x - sn * laser.mount_y;
    const S ly = p.y + sn * laser.mount_x + c * laser.mount_y;
    const S alpha = p.theta + laser.mount_yaw + laser.angle_min + S(i) * laser.angle_inc;
    const RayHit<S> hit = map.cast(lx, ly, alpha);
    if (!hit.hit) return Status::kNoMapHit;
    if (std::abs(hit.n_dot_u) < std::cos(max_incidence)) return Status::kGrazing;
    *range = hit.range;
    if (h != nullptr) {
      // r = (n.(a - pL)) / (n.u):  dr/dpL = -n/(n.u),  dr/dalpha = -r (n.u')/(n.u)
      const S inv = S(1) / hit.n_dot_u;
      const S drdx = -hit.nx * inv;
      const S drdy = -hit.ny * inv;
      const S n_dot_du = -hit.nx * std::sin(alpha) + hit.ny * std::cos(alpha);
      const S drda = -hit.range * n_dot_du * inv;
      const S dlx = -sn * laser.mount_x - c * laser.mount_y;
      const S dly = c * laser.mount_x - sn * laser.mount_y;
      (*h) << drdx, drdy, drdx * dlx + drdy * dly + drda;
    }
    return Status::kOk;
  }

 private:
  static void symmetrise(StateMat& p) {
    for (int r = 0; r < N; ++r) {
      for (int c = r + 1; c < N; ++c) {
        const S v = S(0.5) * (p(r, c) + p(c, r));
        p(r, c) = v;
        p(c, r) = v;
      }
    }
  }
  static bool covarianceHealthy(const StateMat& p) {
    return p.allFinite() && (p.diagonal().array() > S(0)).all();
  }

  Model model_{};
  AkfConfig<S> cfg_{};
  StateVec x_ = StateVec::Zero();
  StateMat p_ = StateMat::Identity();
  AkfCounters counters_{};
};

}  // namespace odoerr
