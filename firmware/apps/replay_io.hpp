// File I/O for the replay applications: stdio-free POSIX calls on the host, semihosting on
// the boards under QEMU (mps2-an386, STM32F405): same names, tape in, results out, in the
// working directory.
#pragma once

#include <cstddef>
#include <cstdint>

#include "odoerr/fw/tape.hpp"

#if defined(ODOERR_TARGET_MPS2) || defined(ODOERR_BOARD_STM32F405)
#define ODOERR_REPLAY_SEMIHOSTING 1
#include "semihosting.hpp"
#include "stack_paint.hpp"
#else
#include <fcntl.h>
#include <unistd.h>
#endif

namespace odoerr::replay_io {

#if defined(ODOERR_REPLAY_SEMIHOSTING)
inline int openRead(const char* p) { return board::shOpen(p, board::FileMode::kReadBinary); }
inline int openWrite(const char* p) { return board::shOpen(p, board::FileMode::kWriteBinary); }
inline std::size_t read(int h, void* b, std::size_t n) { return board::shRead(h, b, n); }
inline std::size_t write(int h, const void* b, std::size_t n) { return board::shWrite(h, b, n); }
inline void close(int h) { board::shClose(h); }
/// Stack high-water mark (bytes) where the board measures it, else 0.
inline std::uint32_t stackHighWater() { return board::stackHighWaterBytes(); }
#else
inline int openRead(const char* p) { return ::open(p, O_RDONLY); }
inline int openWrite(const char* p) { return ::open(p, O_WRONLY | O_CREAT | O_TRUNC, 0644); }
inline std::size_t read(int h, void* b, std::size_t n) {
  const ssize_t r = ::read(h, b, n);
  return r < 0 ? 0 : static_cast<std::size_t>(r);
}
inline std::size_t write(int h, const void* b, std::size_t n) {
  const ssize_t r = ::write(h, b, n);
  return r < 0 ? 0 : static_cast<std::size_t>(r);
}
inline void close(int h) { ::close(h); }
inline std::uint32_t stackHighWater() { return 0; }
#endif

/// The input and output paths: fixed names on the board, optional arguments on the host.
struct Paths {
  const char* in;
  const char* out;
};
inline Paths paths(int argc, char** argv, const char* in, const char* out) {
#if !defined(ODOERR_REPLAY_SEMIHOSTING)
  if (argc >= 3) return {argv[1], argv[2]};
#else
  (void)argc;
  (void)argv;
#endif
  return {in, out};
}

/// A tape replay's files: the tape (its header read) and the results file.
struct TapeFiles {
  int in = -1;
  int out = -1;
  fw::TapeHeader h{};
  std::size_t read(void* b, std::size_t n) const { return replay_io::read(in, b, n); }
  std::size_t write(const void* b, std::size_t n) const { return replay_io::write(out, b, n); }
  void close() const {
    replay_io::close(in);
    replay_io::close(out);
  }
};

/// Opens the tape and the results file (paths()) and reads the tape's header. 0, or the
/// replay applications' exit code: 10 no tape, 11 no results file, 2 not a tape header
/// (or one with more than max_beams beams).
inline int openTape(int argc, char** argv, TapeFiles* t, int max_beams = 64) {
  const Paths p = paths(argc, argv, "tape.bin", "out.bin");
  t->in = openRead(p.in);
  if (t->in < 0) return 10;
  t->out = openWrite(p.out);
  if (t->out < 0) return 11;
  std::uint8_t hb[fw::kTapeHeaderBytes];
  if (read(t->in, hb, sizeof hb) != sizeof hb || !fw::decodeHeader(hb, &t->h, max_beams)) return 2;
  return 0;
}

}  // namespace odoerr::replay_io
