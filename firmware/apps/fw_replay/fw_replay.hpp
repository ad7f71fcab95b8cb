// The firmware application (fw/app.hpp) over a HAL tape (fw/hal_tape.hpp): the clock and
// both counters are what the devices showed at each poll; the laser's bytes of each poll come
// through a feed. Shared by fw_replay (host and mps2-an386: the bytes straight from the tape)
// and the STM32F405 board's fw_board (the bytes through USART1's receive interrupt).
#pragma once

#include <cstddef>
#include <cstdint>
#include <new>

#include "odoerr/fw/app.hpp"
#include "odoerr/fw/hal_tape.hpp"
#include "odoerr/fw/paper_setup.hpp"
#include "odoerr/hal/fake_param_store.hpp"

#include "../replay_io.hpp"

namespace odoerr::fw_replay {

/// Exit codes of the replay (beside replay_io's 10, 11 and 2): 3 the tape ends early or holds
/// a poll of more than 1024 bytes; 5 the application refused to boot; 6 no cycle ran; 7 the
/// feed could not deliver a poll's bytes.
enum Exit : int { kOk = 0, kTapeShort = 3, kBootRefused = 5, kNoCycle = 6, kFeedFailed = 7 };

/// The clock and a counter as the tape says they were at the current poll.
class TapeClock final : public hal::Clock {
 public:
  std::uint64_t now = 0;

 private:
  std::uint64_t DoNowUs() const override { return now; }
};

class TapeCounter final : public hal::EncoderCounter {
 public:
  explicit TapeCounter(std::uint8_t bits) : bits_(bits) {}
  std::uint32_t raw = 0;

 private:
  hal::Status DoRead(std::uint32_t* c) override {
    *c = raw;
    return hal::Status::kOk;
  }
  std::uint8_t DoBits() const override { return bits_; }
  std::uint8_t bits_;
};

/// The feed of fw_replay: each poll's bytes, read from the tape into its buffer, are what the
/// port returns.
class TapeFeed final : public hal::SerialPort {
 public:
  hal::SerialPort& port() { return *this; }
  /// Where the tape's `n` bytes of the next poll are read to; nullptr when they do not fit.
  std::uint8_t* receive(std::size_t n) { return n <= sizeof buf_ ? buf_ : nullptr; }
  /// The next poll's bytes are the `n` received.
  bool deliver(std::size_t n) {
    n_ = n;
    pos_ = 0;
    return true;
  }

 private:
  hal::Status DoRead(std::uint8_t* out, std::size_t cap, std::size_t* got) override {
    while (*got < cap && pos_ < n_) out[(*got)++] = buf_[pos_++];
    return hal::Status::kOk;
  }
  hal::Status DoWrite(const std::uint8_t*, std::size_t k, std::size_t* w) override {
    *w = k;
    return hal::Status::kOk;
  }
  std::uint8_t buf_[1024];
  std::size_t n_ = 0;
  std::size_t pos_ = 0;
};

/// Telemetry frames into a file (replay_io's handle).
class FileTelemetry final : public hal::TelemetrySink {
 public:
  explicit FileTelemetry(int handle) : handle_(handle) {}

 private:
  hal::Status DoSend(const std::uint8_t* f, std::size_t k) override {
    return replay_io::write(handle_, f, k) == k ? hal::Status::kOk : hal::Status::kResourceExhausted;
  }
  int handle_;
};

/// Static storage for an object constructed in place and never destroyed (as firmware
/// state is: no atexit registration, no heap); it lives in .bss, not on the stack.
template <typename T>
struct Static {
  alignas(T) unsigned char bytes[sizeof(T)];
  template <typename... A>
  T& make(A&&... args) {
    return *new (bytes) T(static_cast<A&&>(args)...);
  }
};

/// Replays the tape's polls (after its header, h) through the application. Feed (TapeFeed,
/// or the board's): `hal::SerialPort& port()`, the laser's port the application reads;
/// `std::uint8_t* receive(std::size_t n)`, where the tape's bytes of a poll are read to; and
/// `bool deliver(std::size_t n)`, called before the poll: the port must then return them. Writes fwstats.bin: u32 stack high-water (0 on the host) | u32 sizeof
/// estimator | u32 sizeof application (drivers, queues, parser buffers) | u32 cycles.
template <template <typename> class DriveT, typename Feed>
int run(int in, const fw::HalTapeHeader& h, Feed& feed, hal::TelemetrySink& tm) {
  using Est = typename fw::PaperTypes<float, DriveT>::EstimatorT;
  using AppT = fw::App<Est>;
  using Store = hal::FakeParamStore<4096, 1024>;
  static Static<Est> est_mem;
  static Static<Store> store_mem;
  static Static<AppT> app_mem;
  typename DriveT<float>::NonSysVec k0;
  for (int i = 0; i < k0.size(); ++i) k0[i] = h.k0[i];
  fw::FilterSetup setup;
  const Pose<double> start{static_cast<double>(h.x0), static_cast<double>(h.y0), static_cast<double>(h.theta0)};
  Est& est = est_mem.make(fw::makePaperEstimator<float, DriveT>(setup, start, k0));
  TapeClock clock;
  TapeCounter a(static_cast<std::uint8_t>(h.counter_bits));
  TapeCounter b(static_cast<std::uint8_t>(h.counter_bits));
  Store& store = store_mem.make();  // RAM-backed flash (the boards' flash is not emulated)
  fw::AppConfig ac;
  ac.ticks_per_unit_a = h.ticks_a;
  ac.ticks_per_unit_b = h.ticks_b;
  ac.drive_id = static_cast<std::uint8_t>(h.drive);
  drivers::EncoderConfig ec;
  ec.max_ticks_per_s = 60000;
  drivers::Lms2xxConfig lc;
  lc.baud = h.baud;
  AppT& app = app_mem.make(a, b, feed.port(), clock, store, tm, est, ac, ec, lc);
  std::uint8_t rec[fw::kHalTapePollBytes];
  for (std::uint32_t k = 0; k < h.polls; ++k) {
    if (replay_io::read(in, rec, sizeof rec) != sizeof rec) return kTapeShort;
    clock.now = std::uint64_t(fw::getU32(rec)) | (std::uint64_t(fw::getU32(rec + 4)) << 32);
    a.raw = fw::getU32(rec + 8);
    b.raw = fw::getU32(rec + 12);
    const std::size_t n = std::size_t(rec[16]) | (std::size_t(rec[17]) << 8);
    std::uint8_t* bytes = feed.receive(n);
    if (bytes == nullptr || replay_io::read(in, bytes, n) != n) return kTapeShort;
    if (!feed.deliver(n)) return kFeedFailed;
    if (k == 0) {
      if (!hal::ok(app.boot())) return kBootRefused;
    } else {
      app.poll();
    }
  }
  std::uint8_t st[16];
  fw::putU32(st, replay_io::stackHighWater());
  fw::putU32(st + 4, static_cast<std::uint32_t>(sizeof(Est)));
  fw::putU32(st + 8, static_cast<std::uint32_t>(sizeof(app)));
  fw::putU32(st + 12, app.health().cycles);
  const int sf = replay_io::openWrite("fwstats.bin");
  if (sf >= 0) {
    (void)replay_io::write(sf, st, sizeof st);
    replay_io::close(sf);
  }
  return app.health().cycles > 0 ? kOk : kNoCycle;
}

/// Reads the tape's header from `in`: false when it is not a HAL tape.
inline bool readHeader(int in, fw::HalTapeHeader* h) {
  std::uint8_t hb[fw::kHalTapeHeaderBytes];
  return replay_io::read(in, hb, sizeof hb) == sizeof hb && fw::decodeHalTapeHeader(hb, h);
}

}  // namespace odoerr::fw_replay
