// odoerr core: the augmented Kalman filter (AKF) of Section 3 (after Larsen et al.).
//
// State: pose plus the systematic odometry parameters (and any composed effects), see
// model.hpp. Prediction uses the encoder increments of one cycle, with the process noise
// of the non-systematic model evaluated at the Observable Filter's current estimate.
// Observation: N laser ranges against a known segment map, fused one scalar beam at a
// time, each re-predicted at the state updated by the beams before it.
#pragma once

#include <cstdint>
#include <limits>
#include <type_traits>

#include "odoerr/akf_types.hpp"
#include "odoerr/map.hpp"
#include "odoerr/model.hpp"

namespace odoerr {

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
  /// Columns of a beam's H that can be non-zero: the pose, or every state when measurement
  /// effects are composed in.
  static constexpr int kHCols = Model::kHasMeasurementEffects ? N : 3;

  Akf() = default;
  explicit Akf(const Model& m, const AkfConfig<S>& cfg = {})
      : model_(m), cfg_(cfg), min_cos_incidence_(std::cos(cfg.max_incidence_rad)) {}

  void init(const StateVec& x0, const StateMat& p0) {
    x_ = x0;
    p_ = p0;
    cache_theta_ = std::numeric_limits<S>::quiet_NaN();
  }

  const StateVec& state() const { return x_; }
  const StateMat& covariance() const { return p_; }
  Pose<S> pose() const { return {x_[PoseIdx::kX], x_[PoseIdx::kY], x_[PoseIdx::kTheta]}; }
  const AkfCounters& counters() const { return counters_; }
  const Model& model() const { return model_; }
  const AkfConfig<S>& config() const { return cfg_; }

  /// Scales the rows and columns of P of the states after the pose by d[j] (j >= 3; d[j] > 0):
  /// P <- D P D, a congruence, so P stays symmetric and positive definite. What the filter
  /// knew of those states counts for less: MlDriver discounts the systematic parameters so
  /// when the K it predicts with rises (docs/nonsystematic.md: what the AKF learnt under a
  /// K too small was overconfident, and held E_theta at its first metre's value).
  ODOERR_NOINLINE void scaleParameterCovariance(const S* d) {
    for (int j = 3; j < N; ++j) {
      for (int k = 0; k < N; ++k) {
        p_(j, k) *= d[j];
        p_(k, j) *= d[j];
      }
    }
  }

  /// Prediction with the encoder increments of one cycle; k = current non-systematic
  /// estimate (the OF's), which sets the process noise; dt = the cycle's duration (s), used
  /// only by effects that depend on speed (0 = unknown).
  [[nodiscard]] Status predict(const Input& u, const NonSysVec& k, S dt = S(0)) {
    return predict(u, k, dt, NoPredictObserver{});
  }

  /// The Jacobians of a prediction, for an observer: f_pose, g_pose as in transition(), at
  /// the state before it. NoPredictObserver reports nothing and compiles to nothing.
  struct NoPredictObserver {
    void operator()(const Eigen::Matrix<S, 3, N>&, const Eigen::Matrix<S, 3, Model::kNoise>&) const {}
  };

  /// predict that hands the prediction's Jacobians to `observe(f_pose, g_pose)` once it has
  /// them (before P and x change; not on a bad input): KMaxLikelihood carries its
  /// sensitivities through them instead of computing the transition again.
  template <typename PredictObserver>
  [[nodiscard]] Status predict(const Input& u, const NonSysVec& k, S dt, PredictObserver&& observe);

  /// Fuses an absolute pose fix (x, y, theta) with standard deviations, as three scalar
  /// updates (H a unit row each; the heading innovation wrapped), gated like a beam.
  /// Returns kOk if all three were used, else the first refusal (the others may be used).
  // Out of line and cold: pose fixes are rare, and their code must not change how the
  // per-beam hot path is compiled.
  [[nodiscard]] __attribute__((noinline, cold)) Status updatePose(S x, S y, S theta, S sx, S sy,
                                                                   S stheta) {
    const S z[3] = {x, y, theta};
    const S r[3] = {sx * sx, sy * sy, stheta * stheta};
    Status first = Status::kOk;
    for (int j = 0; j < 3; ++j) {
      Status st = Status::kOk;
      if (!isFinite(z[j]) || !isFinite(r[j]) || !(r[j] > S(0))) {
        st = Status::kBadInput;
      } else {
        const S s = p_(j, j) + r[j];
        S nu = z[j] - x_[j];
        if (j == PoseIdx::kTheta) nu = wrapAngle(nu);
        const S inv_s = S(1) / s;
        if (!isFinite(s) || !(s > r[j])) {
          st = Status::kBadInnovation;
        } else if (!(nu * nu * inv_s <= cfg_.gate_nis)) {
          st = Status::kGated;
        } else {
          StateVec pht = p_.col(j);
          for (int k = 0; k < N; ++k) {
            if (!(p_(k, k) - pht[k] * pht[k] * inv_s > S(0)) && !heldState(k, pht[k])) {
              st = Status::kBadCovariance;
            }
          }
          if (st == Status::kOk) {
            x_ += pht * (nu * inv_s);
            x_[PoseIdx::kTheta] = wrapAngle(x_[PoseIdx::kTheta]);
            const StateVec g = pht * std::sqrt(inv_s);
            p_.noalias() -= g * g.transpose();
          }
        }
      }
      if (st == Status::kOk) {
        ++counters_.pose_fixes_used;
      } else {
        ++counters_.pose_fixes_rejected;
        if (first == Status::kOk) first = st;
      }
    }
    return first;
  }

  /// The state transition f_a of one cycle at the mean input: the next pose, and the pose
  /// rows of F_a = d f_a / d X_a (3 x N; the parameter rows are identity) and of
  /// G_a = d f_a / d nu (3 x kNoise; the parameter rows are zero).
  static Pose<S> transition(const Model& model, const StateVec& x, const Input& u,
                            Eigen::Matrix<S, 3, N>* f_pose,
                            Eigen::Matrix<S, 3, Model::kNoise>* g_pose);

  /// The same in a motion context, with cos/sin of the heading given; also returns the
  /// increment and, optionally, d pose / d increment and the drive model's increment
  /// before the effects.
  static Pose<S> transitionCS(const Model& model, const StateVec& x, const Input& u,
                              const typename Model::Context& ctx, S c, S sn, Eigen::Matrix<S, 3, N>* f_pose,
                              Eigen::Matrix<S, 3, Model::kNoise>* g_pose, Increment<S>* inc_out,
                              Eigen::Matrix<S, 3, 3>* d_inc_out = nullptr, Increment<S>* drive_inc = nullptr);

  /// Fuses one scan (ranges in beam order, nan = no return) against the map, one scalar
  /// beam at a time. The heading's (cos, sin) is carried through the sequential updates
  /// by exact small-angle rotations, so the loop makes no library trigonometry calls.
  template <typename MapT, int MaxBeams>
  ScanStats<S> updateScan(const MapT& map,
                          const LaserGeometry<S, MaxBeams>& laser, const S* ranges) {
    return updateScan(map, laser, ranges, NoObserver{});
  }

  /// One beam's outcome, for diagnostics: every beam, gated ones included (predicted and
  /// variance are 0 where the beam could not be predicted).
  struct BeamRecord {
    int beam;
    Status status;
    S measured;
    S predicted;
    S variance;  ///< innovation variance S = H P H^T + R
  };

  /// The default observer: reports nothing, and compiles to nothing.
  struct NoObserver {
    void operator()(const BeamRecord&) const {}
  };

  /// updateScan that reports every beam to `observe(const BeamRecord&)`.
  template <typename MapT, int MaxBeams, typename Observer>
  ScanStats<S> updateScan(const MapT& map,
                          const LaserGeometry<S, MaxBeams>& laser, const S* ranges,
                          Observer&& observe) {
    ScanStats<S> st;
    S c;
    S sn;
    headingCosSin(&c, &sn);
    // The beams of this scan (LaserGeometry: beam selection): every beam, or one per slot.
    const int stride = laser.stride();
    const int phase = scan_phase_;
    if (stride > 1) scan_phase_ = phase + 1 < stride ? phase + 1 : 0;
    const S range_max = laser.config().range_max;
    for (int k = 0; k < laser.used(); ++k) {
      // slotBeamWithReturn, written out: with the call here GCC lays the firmware's cycle
      // out differently and it costs 590 more instructions on the M4F (measured).
      int i = k;
      if (stride > 1) {
        i = laser.slotBeam(k, phase);
        for (int j = 1; j < stride && !(ranges[i] > S(0) && ranges[i] <= range_max); ++j) {
          i = laser.slotBeam(k, phase + j < stride ? phase + j : phase + j - stride);
        }
      }
      S nis = S(0);
      S dth = S(0);
      constexpr bool kObserved = !std::is_same_v<std::decay_t<Observer>, NoObserver>;
      S predicted = S(0);
      S variance = S(0);
      const Status s = updateBeamCS<kObserved>(map, laser, i, ranges[i], c, sn, &nis, &dth, &predicted,
                                               &variance);
      if constexpr (kObserved) observe(BeamRecord{i, s, ranges[i], predicted, variance});
      if (s == Status::kOk) {
        ++st.used;
        st.nis_sum += nis;
        rotate(&c, &sn, dth);
      } else {
        ++st.skipped;
      }
    }
    if (st.used > 0) {
      storeHeadingCosSin(c, sn);
      mirrorUpper();
    }
    return st;
  }

  /// updateScan with the scan's beams fused most consistent first
  /// (AkfConfig::order_by_prior_nis; the Estimator calls it when that is set). The same
  /// beams as updateScan, in the order of their NIS at the prior mean.
  template <typename MapT, int MaxBeams, typename Observer>
  ScanStats<S> updateScanOrdered(const MapT& map, const LaserGeometry<S, MaxBeams>& laser, const S* ranges,
                                 Observer&& observe) {
    ScanStats<S> st;
    S c;
    S sn;
    headingCosSin(&c, &sn);
    const int stride = laser.stride();
    const int phase = scan_phase_;
    if (stride > 1) scan_phase_ = phase + 1 < stride ? phase + 1 : 0;
    const S range_max = laser.config().range_max;
    auto beamOfSlot = [&](int k) { return slotBeamWithReturn(laser, ranges, k, phase, stride, range_max); };
    int order[MaxBeams];
    orderByPriorNis(map, laser, ranges, c, sn, beamOfSlot, order);
    for (int k = 0; k < laser.used(); ++k) fuseScanBeam(map, laser, order[k], ranges, &c, &sn, observe, &st);
    if (st.used > 0) {
      storeHeadingCosSin(c, sn);
      mirrorUpper();
    }
    return st;
  }

  /// One scalar range update of beam i. On success returns kOk and the beam's NIS.
  template <typename MapT, int MaxBeams>
  [[nodiscard]] Status updateBeam(const MapT& map,
                                  const LaserGeometry<S, MaxBeams>& laser, int i, S measured,
                                  S* nis_out = nullptr) {
    S c;
    S sn;
    headingCosSin(&c, &sn);
    S dth = S(0);
    S predicted = S(0);
    S variance = S(0);
    const Status st = updateBeamCS<false>(map, laser, i, measured, c, sn, nis_out, &dth, &predicted, &variance);
    if (st == Status::kOk) {
      rotate(&c, &sn, dth);
      storeHeadingCosSin(c, sn);
      mirrorUpper();
    }
    return st;
  }

  /// Expected range of beam i from a robot pose, with dr/d(x, y, theta); (c, sn) are the
  /// cosine and sine of the pose's heading. kNoMapHit / kGrazing when not usable.
  /// Always inlined, as predictBeam is: GCC had left the ray cast out of line in the ML
  /// estimator's image (a second caller, the per-beam form), and predictBeam out of line in the
  /// paper's once the cast was inlined into it; a call per beam cost the Cortex-M4F about
  /// 1,700 instructions a cycle in the one and 360 in the other (docs/performance.md).
  template <typename MapT, int MaxBeams>
  ODOERR_ALWAYS_INLINE static Status expectedRange(const MapT& map, const LaserGeometry<S, MaxBeams>& laser, S x,
                                                   S y, S c, S sn, int i, S min_cos_incidence, S* range,
                                                   Eigen::Matrix<S, 1, 3>* h, BeamContext<S>* geo = nullptr,
                                                   const RayShift<S>* shift = nullptr);

  /// Convenience form of expectedRange taking a pose and an incidence limit in radians.
  template <typename MapT, int MaxBeams>
  static Status expectedRange(const MapT& map,
                              const LaserGeometry<S, MaxBeams>& laser, const Pose<S>& p, int i,
                              S max_incidence, S* range, Eigen::Matrix<S, 1, 3>* h);

  /// Predicts every beam of a scan at the current state without fusing it (held-out
  /// evaluation): reports each beam's record to `observe` as updateScan would.
  template <typename MapT, int MaxBeams, typename Observer>
  void evaluateScan(const MapT& map, const LaserGeometry<S, MaxBeams>& laser,
                    const S* ranges, Observer&& observe) const {
    S sn;
    S c;
    sinCos(x_[PoseIdx::kTheta], &sn, &c);
    for (int i = 0; i < laser.beams(); ++i) {
      BeamRecord rec{i, Status::kNoReturn, ranges[i], S(0), S(0)};
      S hf[kHCols];
      if (isFinite(ranges[i]) && ranges[i] > S(0) && ranges[i] <= laser.config().range_max) {
        rec.status = predictBeam(map, laser, i, c, sn, &rec.predicted, hf);
        if (rec.status == Status::kOk) {
          S v = laser.config().sigma * laser.config().sigma;
          for (int j = 0; j < kHCols; ++j) {
            for (int k = 0; k < kHCols; ++k) v += hf[j] * p_(j, k) * hf[k];
          }
          rec.variance = v;
        }
      }
      observe(rec);
    }
  }

  /// The robot's velocity over the last cycle (world frame) and its turn rate; zero when
  /// the model has no effects or the cycle time is unknown.
  S velocityX() const { return vel_x_; }
  S velocityY() const { return vel_y_; }
  S turnRate() const { return vel_w_; }
  const typename Model::Context& motionContext() const { return ctx_; }

 private:
  /// A state held constant: its variance is exactly zero and so is its gain (a parameter
  /// fixed at a value, e.g. an effect a diagnosis holds). The update leaves it untouched.
  bool heldState(int j, S pht_j) const { return p_(j, j) == S(0) && pht_j == S(0); }

  /// The beam a scan fuses for slot k (LaserGeometry: beam selection): every beam when
  /// stride is 1; else the slot's beam at this scan's phase, or the next of its slot that
  /// has a return.
  template <int MaxBeams>
  static int slotBeamWithReturn(const LaserGeometry<S, MaxBeams>& laser, const S* ranges, int k, int phase, int stride,
                                S range_max) {
    if (stride <= 1) return k;
    int i = laser.slotBeam(k, phase);
    for (int j = 1; j < stride && !(ranges[i] > S(0) && ranges[i] <= range_max); ++j) {
      i = laser.slotBeam(k, phase + j < stride ? phase + j : phase + j - stride);
    }
    return i;
  }

  /// One beam of a scan update: fused (or refused and counted), reported to `observe`, and
  /// the running heading cos/sin and the scan's summary updated.
  template <typename MapT, int MaxBeams, typename Observer>
  inline void fuseScanBeam(const MapT& map, const LaserGeometry<S, MaxBeams>& laser, int i, const S* ranges, S* c,
                           S* sn, Observer& observe, ScanStats<S>* st) {
    S nis = S(0);
    S dth = S(0);
    constexpr bool kObserved = !std::is_same_v<std::decay_t<Observer>, NoObserver>;
    S predicted = S(0);
    S variance = S(0);
    const Status s = updateBeamCS<kObserved>(map, laser, i, ranges[i], *c, *sn, &nis, &dth, &predicted, &variance);
    if constexpr (kObserved) observe(BeamRecord{i, s, ranges[i], predicted, variance});
    if (s == Status::kOk) {
      ++st->used;
      st->nis_sum += nis;
      rotate(c, sn, dth);
    } else {
      ++st->skipped;
    }
  }

  /// The selected beams of a scan (beamOfSlot(k), k < laser.used()) sorted by their NIS
  /// at the prior mean, smallest first; beams that cannot be predicted go last, in slot
  /// order (their update refuses and counts them as before).
  template <typename MapT, int MaxBeams, typename BeamOfSlot>
  void orderByPriorNis(const MapT& map, const LaserGeometry<S, MaxBeams>& laser, const S* ranges, S c, S sn,
                       const BeamOfSlot& beamOfSlot, int* order) const {
    S key[MaxBeams];
    const int n = laser.used();
    const S sigma2 = laser.config().sigma * laser.config().sigma;
    for (int k = 0; k < n; ++k) {
      const int i = beamOfSlot(k);
      order[k] = i;
      key[k] = std::numeric_limits<S>::max();
      S predicted = S(0);
      S hf[kHCols];
      if (isFinite(ranges[i]) && ranges[i] > S(0) && ranges[i] <= laser.config().range_max &&
          predictBeam(map, laser, i, c, sn, &predicted, hf) == Status::kOk) {
        S v = sigma2;  // H P H^T + R from the upper triangle (the lower may be stale mid-cycle)
        for (int a = 0; a < kHCols; ++a) {
          v += hf[a] * p_(a, a) * hf[a];
          for (int b = a + 1; b < kHCols; ++b) v += S(2) * hf[a] * p_(a, b) * hf[b];
        }
        const S nu = ranges[i] - predicted;
        if (v > S(0)) key[k] = nu * nu / v;
      }
    }
    // Insertion sort: stable, in place, no allocation (a scan has at most MaxBeams beams).
    for (int k = 1; k < n; ++k) {
      const S kk = key[k];
      const int ik = order[k];
      int j = k - 1;
      for (; j >= 0 && key[j] > kk; --j) {
        key[j + 1] = key[j];
        order[j + 1] = order[j];
      }
      key[j + 1] = kk;
      order[j + 1] = ik;
    }
  }

  /// Large models (the host's diagnosis composes the whole catalogue, ~47 states, and
  /// holds most of them: zero variance, zero rows) update only the states with variance
  /// and the non-zero columns of H. Every term left out is an exact zero, so the result is
  /// the same as the dense loops'. The firmware's models are small and keep the dense,
  /// fully unrolled loops whose cost footprint.json reports.
  static constexpr bool kSparse = N > 16;

  /// Predicted range of beam i at the current state (heading cos/sin given) and the first
  /// kHCols entries of its row of H.
  template <typename MapT, int MaxBeams>
  ODOERR_ALWAYS_INLINE Status predictBeam(const MapT& map, const LaserGeometry<S, MaxBeams>& laser, int i, S c,
                                          S sn, S* predicted, S* hf) const {
    Eigen::Matrix<S, 1, 3> h;
    if constexpr (Model::kHasMeasurementEffects) {
      BeamContext<S> geo;
      const LaserConfig<S>& lc = laser.config();
      const RayContext<S> rc{c, sn, vel_x_, vel_y_, vel_w_, -sn * lc.mount_x - c * lc.mount_y,
                             c * lc.mount_x - sn * lc.mount_y};
      const RayShift<S> shift = model_.shiftRay(x_, rc);
      const Status ps = expectedRange(map, laser, x_[PoseIdx::kX], x_[PoseIdx::kY], c, sn, i,
                                      min_cos_incidence_, predicted, &h, &geo, &shift);
      if (ps != Status::kOk) return ps;
      geo.vx = vel_x_;
      geo.vy = vel_y_;
      geo.w = vel_w_;
      for (int k = 0; k < kHCols; ++k) hf[k] = S(0);
      hf[0] = h(0);
      hf[1] = h(1);
      hf[2] = h(2);
      model_.measure(x_, geo, predicted, hf);
      return Status::kOk;
    } else {
      const Status ps = expectedRange(map, laser, x_[PoseIdx::kX], x_[PoseIdx::kY], c, sn, i,
                                      min_cos_incidence_, predicted, &h);
      if (ps != Status::kOk) return ps;
      hf[0] = h(0);
      hf[1] = h(1);
      hf[2] = h(2);
      return Status::kOk;
    }
  }

  /// cos and sin of the current heading (from the cache when it is current).
  void headingCosSin(S* c, S* sn) {
    if (!(cache_theta_ == x_[PoseIdx::kTheta]) || cache_age_ >= kCacheRefresh) {
      sinCos(x_[PoseIdx::kTheta], &cache_s_, &cache_c_);
      cache_theta_ = x_[PoseIdx::kTheta];
      cache_age_ = 0;
    }
    *c = cache_c_;
    *sn = cache_s_;
  }
  /// Records cos/sin of the current heading, obtained by rotating the previous pair.
  void storeHeadingCosSin(S c, S sn) {
    cache_c_ = c;
    cache_s_ = sn;
    cache_theta_ = x_[PoseIdx::kTheta];
    ++cache_age_;
  }
  /// Copies the upper triangle of P onto the lower one.
  void mirrorUpper() {
    for (int j = 0; j < N; ++j) {
      for (int k = j + 1; k < N; ++k) p_(k, j) = p_(j, k);
    }
  }

  /// (c, s) rotated by the angle d.
  static void rotate(S* c, S* s, S d) {
    S sd;
    S cd;
    sinCos(d, &sd, &cd);
    const S c2 = *c * cd - *s * sd;
    *s = *s * cd + *c * sd;
    *c = c2;
  }

  template <bool kReport, typename MapT, int MaxBeams>
  Status updateBeamCS(const MapT& map, const LaserGeometry<S, MaxBeams>& laser,
                      int i, S measured, S c, S sn, S* nis_out, S* dtheta_out, S* predicted_out,
                      S* variance_out);

  /// kSparse: the indices of the states with variance (the others are held: zero rows and
  /// columns of P), in increasing order; returns how many.
  int statesWithVariance(int* act) const {
    int n = 0;
    for (int j = 0; j < N; ++j) {
      if (p_(j, j) != S(0)) act[n++] = j;
    }
    return n;
  }

  /// predict()'s covariance step for kSparse models: F P F^T over the states with variance
  /// only (held states have zero rows and columns), written into P in place if healthy.
  template <typename GPose, typename QVec, typename DInc>
  bool predictCovarianceSparse(const Eigen::Matrix<S, 3, N>& f_pose, const GPose& g_pose, const QVec& q,
                               const Increment<S>& inc, const DInc& d_inc) {
    int act[N];
    const int n_act = statesWithVariance(act);
    Eigen::Matrix<S, 3, N> fp = Eigen::Matrix<S, 3, N>::Zero();
    for (int b = 0; b < n_act; ++b) {
      const int j = act[b];
      for (int r = 0; r < 3; ++r) {
        S acc = S(0);
        for (int a = 0; a < n_act; ++a) acc += f_pose(r, act[a]) * p_(act[a], j);
        fp(r, j) = acc;
      }
    }
    Eigen::Matrix<S, 3, 3> block = g_pose * q.asDiagonal() * g_pose.transpose();
    for (int r = 0; r < 3; ++r) {
      for (int cc = 0; cc < 3; ++cc) {
        S acc = S(0);
        for (int a = 0; a < n_act; ++a) acc += fp(r, act[a]) * f_pose(cc, act[a]);
        block(r, cc) += acc;
      }
    }
    if constexpr (Model::kHasNoiseEffects) {
      block += d_inc * model_.extraVariance(inc, x_, ctx_).asDiagonal() * d_inc.transpose();
    } else {
      (void)d_inc;
    }
    for (int r = 0; r < 3; ++r) {
      for (int cc = r + 1; cc < 3; ++cc) {
        const S v = S(0.5) * (block(r, cc) + block(cc, r));
        block(r, cc) = v;
        block(cc, r) = v;
      }
    }
    fp.template leftCols<3>() = block;
    bool healthy = fp.allFinite();
    for (int r = 0; r < 3; ++r) healthy = healthy && block(r, r) > S(0);
    if (!healthy) return false;
    p_.template topRows<3>() = fp;
    p_.template leftCols<3>() = fp.transpose();
    return true;
  }

  template <typename Mat>
  static void symmetrisePose(Mat& p) {
    for (int r = 0; r < 3; ++r) {
      for (int c = r + 1; c < 3; ++c) {
        const S v = S(0.5) * (p(r, c) + p(c, r));
        p(r, c) = v;
        p(c, r) = v;
      }
    }
  }
  /// After a prediction only the pose rows/columns changed: they must be finite and the
  /// diagonal positive (the parameter block is untouched by construction).
  template <typename Mat>
  static bool poseRowsHealthy(const Mat& p) {
    for (int r = 0; r < 3; ++r) {
      if (!(p(r, r) > S(0))) return false;
      for (int c = 0; c < N; ++c) {
        if (!isFinite(p(r, c))) return false;
      }
    }
    return true;
  }

  Model model_{};
  AkfConfig<S> cfg_{};
  S min_cos_incidence_ = std::cos(AkfConfig<S>{}.max_incidence_rad);
  // cos/sin of the heading, carried across predictions and beam updates by exact
  // small-angle rotations; valid while cache_theta_ == the state's heading. Recomputed from
  // the library every kCacheRefresh rotations so rounding cannot accumulate.
  static constexpr int kCacheRefresh = 256;
  S cache_theta_ = std::numeric_limits<S>::quiet_NaN();
  S cache_c_ = S(1);
  S cache_s_ = S(0);
  int cache_age_ = 0;
  int scan_phase_ = 0;  ///< the first beam of each slot in the next scan (beam selection)
  StateVec x_ = StateVec::Zero();
  StateMat p_ = StateMat::Identity();
  AkfCounters counters_{};
  // What effects depend on (unused, and never touched, in a model without effects).
  typename Model::Context ctx_{};
  S vel_x_ = S(0);
  S vel_y_ = S(0);
  S vel_w_ = S(0);
};

}  // namespace odoerr

// The members defined out of the class, one responsibility a header.
#include "odoerr/akf_predict.hpp"     // NOLINT(build/include_order): Akf::predict
#include "odoerr/akf_transition.hpp"  // NOLINT(build/include_order): Akf::transition, transitionCS
#include "odoerr/akf_ray.hpp"         // NOLINT(build/include_order): Akf::expectedRange
#include "odoerr/akf_beam_update.hpp" // NOLINT(build/include_order): Akf::updateBeamCS
