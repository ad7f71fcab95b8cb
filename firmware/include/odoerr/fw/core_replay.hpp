// Replays a tape through the float estimator; the same code runs on the host and on the
// Cortex-M4F. I/O goes through two callables so the board decides where bytes come from.
#pragma once

#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/k_ml_driver.hpp"
#include "odoerr/fw/tape.hpp"

namespace odoerr::fw {

/// Replays the tape's cycles through `est` (diff or sync as the estimator's model).
/// Read(void*, n) -> bytes read; Write(const void*, n) -> bytes written.
/// Returns 0 on success, a non-zero code naming the failure otherwise.
template <int MaxTapeBeams, typename Est, typename Read, typename Write>
int replayThrough(Est& est, const TapeHeader& h, Read&& read, Write&& write, std::uint32_t (*stack_probe)()) {
  using M = typename Est::Model;
  using Drive = typename M::Drive;
  constexpr int N = M::kStates;
  constexpr int K = M::kNonSys;
  if (h.beams > std::uint32_t(MaxTapeBeams)) return 5;
  std::uint8_t buf[4 * (2 + MaxTapeBeams)];
  const std::size_t cycle_bytes = 4 * (2 + h.beams);
  float ranges[MaxTapeBeams];
  std::uint8_t rec[4 * (1 + 2 * N + 2 * K)];
  auto emit = [&](std::uint32_t cycle) {
    const auto& x = est.akf().state();
    const auto& p = est.akf().covariance();
    putU32(rec, cycle);
    for (int i = 0; i < N; ++i) {
      putF32(rec + 4 + 4 * i, x[i]);
      putF32(rec + 4 + 4 * (N + i), std::sqrt(p(i, i)));
    }
    for (int i = 0; i < K; ++i) {
      putF32(rec + 4 + 8 * N + 4 * i, est.of().estimate()[i]);
      putF32(rec + 4 + 8 * N + 4 * (K + i), std::sqrt(est.of().covariance()(i, i)));
    }
    return write(rec, sizeof rec) == sizeof rec;
  };
  for (std::uint32_t c = 1; c <= h.cycles; ++c) {
    if (read(buf, cycle_bytes) != cycle_bytes) return 3;  // truncated tape
    typename Drive::Input u;
    u = {getF32(buf), getF32(buf + 4)};
    for (std::uint32_t i = 0; i < h.beams; ++i) ranges[i] = getF32(buf + 8 + 4 * i);
    if (!h.dry) {
      (void)est.cycle(u, ranges);
    } else {
      volatile float keep = getF32(buf) + ranges[0];  // the decoding must not be optimised away
      (void)keep;
    }
    if ((c % h.record_every == 0 || c == h.cycles) && !emit(c)) return 4;
  }
  const auto& ac = est.akf().counters();
  std::uint8_t tail[24];
  putU32(tail, 0xFFFFFFFFu);
  putU32(tail + 4, ac.beams_used);
  putU32(tail + 8, ac.no_return + ac.no_map_hit + ac.grazing + ac.too_close + ac.gated + ac.bad_innovation + ac.bad_covariance);
  putU32(tail + 12, est.of().counters().updates);
  putU32(tail + 16, stack_probe != nullptr ? stack_probe() : 0u);
  putU32(tail + 20, static_cast<std::uint32_t>(sizeof(Est)));  // both filters' state
  return write(tail, sizeof tail) == sizeof tail ? 0 : 4;
}

/// The paper's estimator (its room and 36 beams) over a tape of the paper's drive.
/// The paper's float estimator started where the tape says (pose, K), for replayTapeMl.
template <template <typename> class DriveT>
typename PaperTypes<float, DriveT>::EstimatorT tapeEstimator(const TapeHeader& h) {
  typename DriveT<float>::NonSysVec k0;
  for (int i = 0; i < DriveT<float>::kNonSys; ++i) k0[i] = h.k0[i];
  return makePaperEstimator<float, DriveT>(FilterSetup{}, Pose<double>{double(h.x0), double(h.y0), double(h.theta0)},
                                           k0);
}

/// (It builds its estimator inline, not through tapeEstimator: through the helper GCC laid
/// the filter out differently, and the cycle footprint.json measures rose by 182.)
template <template <typename> class DriveT, typename Read, typename Write>
int replayTape(const TapeHeader& h, Read&& read, Write&& write, std::uint32_t (*stack_probe)()) {
  using S = float;
  using Est = typename PaperTypes<S, DriveT>::EstimatorT;
  using M = typename Est::Model;
  constexpr int K = M::kNonSys;
  typename DriveT<S>::NonSysVec k0;
  for (int i = 0; i < K; ++i) k0[i] = h.k0[i];
  FilterSetup setup;
  Est est = makePaperEstimator<S, DriveT>(setup, Pose<double>{double(h.x0), double(h.y0), double(h.theta0)}, k0);
  return replayThrough<64>(est, h, read, write, stack_probe);
}

/// The estimator of replayThrough with the recursive ML estimator of K (MlDriver) in the
/// Observable Filter's place: of() reads K, its covariance and its steps (as "updates").
template <typename Est>
class MlReplay {
 public:
  using Model = typename Est::Model;
  using Drv = MlDriver<Est>;
  struct OfView {
    const typename Drv::MlT* ml;
    typename Drv::MlT::KVec estimate() const { return ml->estimate(); }
    typename Drv::MlT::KMat covariance() const { return ml->covariance(); }
    struct Counters {
      std::uint32_t updates;
    };
    Counters counters() const { return {ml->counters().steps}; }
  };

  MlReplay(const Est& est, const KMlConfig<typename Model::Scalar>& cfg) : drv_(est, cfg) {}
  const typename Drv::AkfT& akf() const { return drv_.akf(); }
  OfView of() const { return {&drv_.ml()}; }
  Status cycle(const typename Model::Input& u, const typename Model::Scalar* ranges) {
    drv_.cycle(u, ranges);
    return Status::kOk;
  }

 private:
  Drv drv_;
};

/// replayTape with the recursive ML estimator of K (k_ml.hpp, its default settings) in the
/// OF's place: the firmware image that measures its cost (core_replay_ml).
template <template <typename> class DriveT, typename Read, typename Write>
int replayTapeMl(const TapeHeader& h, Read&& read, Write&& write, std::uint32_t (*stack_probe)()) {
  using Est = typename PaperTypes<float, DriveT>::EstimatorT;
  MlReplay<Est> ml(tapeEstimator<DriveT>(h), KMlConfig<float>{});
  return replayThrough<64>(ml, h, read, write, stack_probe);
}

}  // namespace odoerr::fw
