// fw_replay: the firmware application (fw/app.hpp) over HAL implementations that replay a
// HAL tape (fw/hal_tape.hpp): the clock, both counters and the laser's serial bytes are
// what the devices showed at each poll. Telemetry frames go to telemetry.bin; the exit
// code is 0 on success (fw_replay.hpp lists the others). Host build: the file names are the
// first two arguments.
#include "fw_replay.hpp"

namespace io = odoerr::replay_io;
namespace fr = odoerr::fw_replay;

int main(int argc, char** argv) {
  const io::Paths p = io::paths(argc, argv, "haltape.bin", "telemetry.bin");
  const int in = io::openRead(p.in);
  if (in < 0) return 10;
  const int out = io::openWrite(p.out);
  if (out < 0) return 11;
  odoerr::fw::HalTapeHeader h;
  if (!fr::readHeader(in, &h)) return 2;
  static fr::Static<fr::TapeFeed> feed_mem;  // the tape's bytes in .bss, not on the stack
  fr::TapeFeed& feed = feed_mem.make();
  fr::FileTelemetry tm(out);
  return h.drive == 0 ? fr::run<odoerr::SyncDrive>(in, h, feed, tm) : fr::run<odoerr::DiffDrive>(in, h, feed, tm);
}
