// core_replay: reads tape.bin, replays it through the float estimator, writes out.bin.
// Host build: stdio files named on the command line. Target build (mps2-an386): the same
// names in the working directory through semihosting; the exit code is the result.
#include <cstdint>

#include "odoerr/fw/core_replay.hpp"

#if defined(ODOERR_TARGET_MPS2)
#include "board.hpp"
#include "semihosting.hpp"
namespace io {
using odoerr::board::FileMode;
struct File {
  int h = -1;
};
inline File openRead(const char* p) { return {odoerr::board::shOpen(p, FileMode::kReadBinary)}; }
inline File openWrite(const char* p) { return {odoerr::board::shOpen(p, FileMode::kWriteBinary)}; }
inline bool valid(const File& f) { return f.h >= 0; }
inline std::size_t read(File& f, void* b, std::size_t n) { return odoerr::board::shRead(f.h, b, n); }
inline std::size_t write(File& f, const void* b, std::size_t n) { return odoerr::board::shWrite(f.h, b, n); }
inline void close(File& f) { odoerr::board::shClose(f.h); }
inline std::uint32_t (*stackProbe())() { return &odoerr::board::stackHighWaterBytes; }
}  // namespace io
#else
#include <cstdio>
namespace io {
struct File {
  std::FILE* f = nullptr;
};
inline File openRead(const char* p) { return {std::fopen(p, "rb")}; }
inline File openWrite(const char* p) { return {std::fopen(p, "wb")}; }
inline bool valid(const File& f) { return f.f != nullptr; }
inline std::size_t read(File& f, void* b, std::size_t n) { return std::fread(b, 1, n, f.f); }
inline std::size_t write(File& f, const void* b, std::size_t n) { return std::fwrite(b, 1, n, f.f); }
inline void close(File& f) { std::fclose(f.f); }
inline std::uint32_t (*stackProbe())() { return nullptr; }
}  // namespace io
#endif

int main(int argc, char** argv) {
  const char* in_path = "tape.bin";
  const char* out_path = "out.bin";
#if !defined(ODOERR_TARGET_MPS2)
  if (argc >= 3) {
    in_path = argv[1];
    out_path = argv[2];
  }
#else
  (void)argc;
  (void)argv;
#endif
  io::File in = io::openRead(in_path);
  if (!io::valid(in)) return 10;
  io::File out = io::openWrite(out_path);
  if (!io::valid(out)) return 11;
  std::uint8_t hb[odoerr::fw::kTapeHeaderBytes];
  odoerr::fw::TapeHeader h;
  if (io::read(in, hb, sizeof hb) != sizeof hb || !odoerr::fw::decodeHeader(hb, &h)) return 2;
  auto rd = [&](void* b, std::size_t n) { return io::read(in, b, n); };
  auto wr = [&](const void* b, std::size_t n) { return io::write(out, b, n); };
  const int rc = h.drive == 0 ? odoerr::fw::replayTape<odoerr::SyncDrive>(h, rd, wr, io::stackProbe())
                              : odoerr::fw::replayTape<odoerr::DiffDrive>(h, rd, wr, io::stackProbe());
  io::close(in);
  io::close(out);
  return rc;
}
