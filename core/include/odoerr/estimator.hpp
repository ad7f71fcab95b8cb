// odoerr core: one filter cycle = AKF predict, AKF scan update, OF step.
// Hardware-free: the caller passes the encoder increments of the cycle and, when a scan
// is available for this cycle, its ranges.
#pragma once

#include "odoerr/of.hpp"

namespace odoerr {

template <typename S>
struct CycleResult {
  Status predict = Status::kOk;
  ScanStats<S> scan{};
  bool of_updated = false;
};

/// An absolute pose fix (e.g. motion capture, beacons) fused at the end of a cycle.
template <typename S>
struct PoseFix {
  S x, y, theta, sx, sy, stheta;
};

/// MapArg: a SegmentMap (owns its walls; copied with the estimator) or a MapView (the tables
/// live elsewhere, e.g. in flash; they must outlive the estimator).
/// kOrderable: the estimator can fuse a scan's beams most consistent first when its
/// AkfConfig asks (order_by_prior_nis; the host's estimators). Off, that code is not
/// compiled in, and the flag is ignored (the firmware: its cycle and flash are unchanged).
template <typename ModelT, typename MapArg = SegmentMap<typename ModelT::Scalar, 16>, int MaxWindow = 32,
          int MaxBeams = 64, bool kOrderable = false>
class Estimator {
 public:
  using Model = ModelT;
  using S = typename Model::Scalar;
  using Input = typename Model::Input;
  using AkfT = Akf<Model>;
  using OfT = ObservableFilter<Model, MaxWindow>;
  using MapT = MapArg;
  using LaserT = LaserGeometry<S, MaxBeams>;

  /// The laser geometry must have been initialised (LaserGeometry::init returned true).
  Estimator(const Model& model, const MapT& map, const LaserT& laser,
            const AkfConfig<S>& akf_cfg = {}, const OfConfig<S>& of_cfg = {})
      : akf_(model, akf_cfg), of_(of_cfg), map_(map), laser_(laser) {}

  void init(const typename AkfT::StateVec& x0, const typename AkfT::StateMat& p0,
            const typename OfT::KVec& k0, const typename OfT::KMat& pk0) {
    akf_.init(x0, p0);
    of_.init(k0, pk0);
    of_.begin(akf_);
  }

  /// One cycle. ranges may be nullptr (no scan this cycle).
  CycleResult<S> cycle(const Input& u, const S* ranges) {
    return cycle(u, ranges, typename AkfT::NoObserver{});
  }

  /// One cycle reporting every beam to `observe` (see Akf::BeamRecord); `fix` (may be
  /// nullptr) is an absolute pose fix fused after the scan.
  template <typename Observer>
  CycleResult<S> cycle(const Input& u, const S* ranges, Observer&& observe,
                       const PoseFix<S>* fix = nullptr) {
    return cycle(u, S(0), ranges, observe, fix);
  }

  /// The same with the cycle's duration dt (s), which speed-dependent effects need.
  template <typename Observer>
  CycleResult<S> cycle(const Input& u, S dt, const S* ranges, Observer&& observe,
                       const PoseFix<S>* fix = nullptr) {
    CycleResult<S> res;
    res.predict = predictStep(u, dt);
    if (res.predict != Status::kOk) return res;
    return measureStep(ranges, observe, fix);
  }

  /// The first half of a cycle: the AKF prediction (the OF window takes the input).
  [[nodiscard]] Status predictStep(const Input& u, S dt) {
    const Status st = akf_.predict(u, of_.estimate(), dt);
    if (st != Status::kOk) {
      of_.breakWindow(akf_);
      return st;
    }
    of_.addInput(u);
    return st;
  }

  /// The second half: the scan (may be nullptr), the pose fix (may be nullptr), the OF.
  template <typename Observer>
  CycleResult<S> measureStep(const S* ranges, Observer&& observe, const PoseFix<S>* fix = nullptr) {
    CycleResult<S> res;
    if (ranges != nullptr) {
      if constexpr (kOrderable) {
        res.scan = akf_.config().order_by_prior_nis ? akf_.updateScanOrdered(map_, laser_, ranges, observe)
                                                    : akf_.updateScan(map_, laser_, ranges, observe);
      } else {
        res.scan = akf_.updateScan(map_, laser_, ranges, observe);
      }
    }
    bool measured = res.scan.used > 0;
    if (fix != nullptr) {
      measured = akf_.updatePose(fix->x, fix->y, fix->theta, fix->sx, fix->sy, fix->stheta) == Status::kOk ||
                 measured;
    }
    res.of_updated = !freeze_k_ && of_.step(akf_, measured);
    return res;
  }

  /// Predicts a scan at the current state without fusing it (see Akf::evaluateScan).
  template <typename Observer>
  void evaluateScan(const S* ranges, Observer&& observe) const {
    akf_.evaluateScan(map_, laser_, ranges, observe);
  }

  /// Holds the non-systematic parameters at their current estimate (the OF stops), so
  /// that a diagnosis cannot let inflated noise hide a systematic effect.
  void freezeNonSystematic(bool on) { freeze_k_ = on; }

  const AkfT& akf() const { return akf_; }
  const OfT& of() const { return of_; }
  const MapT& map() const { return map_; }
  const LaserT& laser() const { return laser_; }

 private:
  AkfT akf_;
  OfT of_;
  MapT map_;
  LaserT laser_;
  bool freeze_k_ = false;
};

}  // namespace odoerr
