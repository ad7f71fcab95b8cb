// odoerr driver: wrap-safe encoder deltas from a free-running hardware counter.
//
// The counter wraps at 2^bits (16 or 32). The delta between two reads is the difference of
// the counts modulo 2^bits, taken as a signed number: correct as long as the wheel moves
// less than half a counter period between reads (unsigned subtraction, then sign
// extension from bit bits-1). A delta beyond what the wheel can physically do in the
// elapsed time (max_ticks_per_s * dt plus a margin) is an encoder glitch or a missed read:
// it is rejected and counted, never integrated, and the reference count resynchronises so
// that one glitch costs one sample, not the rest of the drive.
#pragma once

#include <cstdint>

#include "odoerr/hal/encoder_counter.hpp"

namespace odoerr::drivers {

struct EncoderConfig {
  /// Fastest physically possible wheel speed in ticks per second (with headroom).
  std::uint32_t max_ticks_per_s = 100000;
  /// Ticks allowed beyond max_ticks_per_s * dt (jitter of the read time).
  std::uint32_t margin_ticks = 16;
};

struct EncoderCounters {
  std::uint32_t reads = 0;
  std::uint32_t read_errors = 0;
  std::uint32_t jumps_rejected = 0;
};

/// Signed difference of two counts of a `bits`-wide counter (modulo 2^bits).
constexpr std::int32_t wrapDelta(std::uint32_t now, std::uint32_t before, std::uint8_t bits) {
  const std::uint32_t diff = now - before;  // modulo 2^32
  if (bits >= 32) return static_cast<std::int32_t>(diff);
  const std::uint32_t mask = (1u << bits) - 1u;
  const std::uint32_t d = diff & mask;
  const std::uint32_t sign = 1u << (bits - 1);
  // sign-extend from bit (bits - 1)
  return static_cast<std::int32_t>(d ^ sign) - static_cast<std::int32_t>(sign);
}

class EncoderDriver {
 public:
  EncoderDriver(hal::EncoderCounter& counter, const EncoderConfig& cfg) : counter_(counter), cfg_(cfg) {}

  /// First read: sets the reference. kOk or the counter's error.
  hal::Status start(std::uint64_t now_us) {
    std::uint32_t c = 0;
    const hal::Status s = readCounter(&c);
    if (!hal::ok(s)) return s;
    last_ = c;
    last_us_ = now_us;
    started_ = true;
    return hal::Status::kOk;
  }

  /// Ticks moved since the previous successful sample. kOk: *delta valid.
  /// kOutOfRange: an impossible jump, rejected and counted (*delta = 0, reference reset).
  /// kFailedPrecondition: start() not called. Otherwise the counter's error (counted).
  hal::Status sample(std::uint64_t now_us, std::int32_t* delta) {
    *delta = 0;
    if (!started_) return hal::Status::kFailedPrecondition;
    std::uint32_t c = 0;
    const hal::Status s = readCounter(&c);
    if (!hal::ok(s)) return s;
    const std::int32_t d = wrapDelta(c, last_, counter_.bits());
    const std::uint64_t dt = now_us >= last_us_ ? now_us - last_us_ : 0;
    const std::uint64_t limit = cfg_.max_ticks_per_s * dt / 1000000u + cfg_.margin_ticks;
    const std::uint64_t mag = d < 0 ? std::uint64_t(-std::int64_t(d)) : std::uint64_t(d);
    last_ = c;
    last_us_ = now_us;
    if (mag > limit) {
      ++counters_.jumps_rejected;
      return hal::Status::kOutOfRange;
    }
    *delta = d;
    return hal::Status::kOk;
  }

  const EncoderCounters& counters() const { return counters_; }

 private:
  hal::Status readCounter(std::uint32_t* c) {
    const hal::Status s = counter_.read(c);
    ++counters_.reads;
    if (!hal::ok(s)) ++counters_.read_errors;
    return s;
  }

  hal::EncoderCounter& counter_;
  EncoderConfig cfg_;
  EncoderCounters counters_{};
  std::uint32_t last_ = 0;
  std::uint64_t last_us_ = 0;
  bool started_ = false;
};

}  // namespace odoerr::drivers
