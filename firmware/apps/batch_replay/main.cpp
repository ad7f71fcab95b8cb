// batch_replay: the tape through the textbook batch EKF (fw/batch_ekf.hpp), for instruction
// counts beside core_replay on the same target. Output: the final state (N floats).
#include <cstdint>

#include "odoerr/fw/batch_ekf.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/fw/tape.hpp"

#include "../replay_io.hpp"

namespace io = odoerr::replay_io;

using namespace odoerr;

#include <new>

namespace {
using M = Model<DiffDrive<float>>;
// Static storage, constructed in place and never destroyed (no atexit registration): the
// 36x36 matrices do not belong on a 16 KB stack.
alignas(fw::BatchEkf<M>) unsigned char g_storage[sizeof(fw::BatchEkf<M>)];
}  // namespace

int main() {
  const int in = io::openRead("tape.bin");
  if (in < 0) return 10;
  std::uint8_t hb[fw::kTapeHeaderBytes];
  fw::TapeHeader h;
  if (io::read(in, hb, sizeof hb) != sizeof hb || !fw::decodeHeader(hb, &h) || h.drive != 1) return 2;
  DiffDrive<float>::NonSysVec k0;
  k0 << h.k0[0];
  // The batch filter has no OF: it gets the true K (the tape starts the OF 100x below).
  const DiffDrive<float>::NonSysVec k_true = k0 * 100.0f;
  fw::FilterSetup setup;
  const Pose<double> start{static_cast<double>(h.x0), static_cast<double>(h.y0), static_cast<double>(h.theta0)};
  auto est = fw::makePaperEstimator<float, DiffDrive>(setup, start, k0);
  auto& g_batch = *new (g_storage) fw::BatchEkf<M>();
  g_batch.init(est.akf().state(), est.akf().covariance());
  std::uint8_t buf[4 * (2 + 64)];
  float ranges[64];
  for (std::uint32_t c = 0; c < h.cycles; ++c) {
    if (io::read(in, buf, 4 * (2 + h.beams)) != 4 * (2 + h.beams)) return 3;
    const DiffDrive<float>::Input u{fw::getF32(buf), fw::getF32(buf + 4)};
    for (std::uint32_t i = 0; i < h.beams; ++i) ranges[i] = fw::getF32(buf + 8 + 4 * i);
    if (!h.dry) {
      g_batch.cycle(est.akf().model(), u, k_true, est.map(), est.laser(), ranges,
                    float(setup.akf.max_incidence_rad));
    }
  }
  const int out = io::openWrite("out.bin");
  if (out < 0) return 11;
  std::uint8_t ob[4 * M::kStates];
  for (int i = 0; i < M::kStates; ++i) fw::putF32(ob + 4 * i, g_batch.state()[i]);
  return io::write(out, ob, sizeof ob) == sizeof ob ? 0 : 4;
}
