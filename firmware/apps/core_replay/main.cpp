// core_replay: reads tape.bin, replays it through the float estimator, writes out.bin.
// Host build: stdio files named on the command line. Target build (mps2-an386): the same
// names in the working directory through semihosting; the exit code is the result.
#include <cstdint>

#include "odoerr/fw/core_replay.hpp"

#include "../replay_io.hpp"

namespace io = odoerr::replay_io;

// It opens its tape itself rather than through replay_io::openTape (which map_replay
// uses): with openTape GCC laid out the inlined filter differently, and the cycle this
// image measures (footprint.json) rose by 254 instructions.
int main(int argc, char** argv) {
  const io::Paths p = io::paths(argc, argv, "tape.bin", "out.bin");
  const int in = io::openRead(p.in);
  if (in < 0) return 10;
  const int out = io::openWrite(p.out);
  if (out < 0) return 11;
  std::uint8_t hb[odoerr::fw::kTapeHeaderBytes];
  odoerr::fw::TapeHeader h;
  if (io::read(in, hb, sizeof hb) != sizeof hb || !odoerr::fw::decodeHeader(hb, &h)) return 2;
  auto rd = [&](void* b, std::size_t n) { return io::read(in, b, n); };
  auto wr = [&](const void* b, std::size_t n) { return io::write(out, b, n); };
#ifdef ODOERR_REPLAY_OF_ML  // core_replay_ml: the ML estimator of K in the OF's place
  const int rc = h.drive == 0 ? odoerr::fw::replayTapeMl<odoerr::SyncDrive>(h, rd, wr, &io::stackHighWater)
                              : odoerr::fw::replayTapeMl<odoerr::DiffDrive>(h, rd, wr, &io::stackHighWater);
#else
  const int rc = h.drive == 0 ? odoerr::fw::replayTape<odoerr::SyncDrive>(h, rd, wr, &io::stackHighWater)
                              : odoerr::fw::replayTape<odoerr::DiffDrive>(h, rd, wr, &io::stackHighWater);
#endif
  io::close(in);
  io::close(out);
  return rc;
}
