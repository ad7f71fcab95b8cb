// Telemetry frame of the firmware (documented in docs/telemetry.md). Little-endian:
//
//   offset  size  field
//   0       1     sync 0xA5
//   1       1     sync 0x5A
//   2       1     message id (1 = estimator state)
//   3       1     payload length L (bytes)
//   4       L     payload
//   4+L     2     CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) over bytes 2 .. 3+L
//
// State payload (id 1):
//   u64 time_us | u32 cycle | f32 x, y, theta | f32 sigma_x, sigma_y, sigma_theta |
//   u8 P | f32 param[P] | f32 param_sigma[P] | u8 M | f32 k[M] | f32 k_sigma[M] |
//   u8 C | u32 counter[C]  (the order of Health::kNames)
#pragma once

#include <cstddef>
#include <cstdint>

#include "odoerr/fw/tape.hpp"

namespace odoerr::fw {

constexpr std::uint8_t kTelemetrySync0 = 0xA5;
constexpr std::uint8_t kTelemetrySync1 = 0x5A;
constexpr std::uint8_t kTelemetryState = 1;
constexpr std::size_t kTelemetryMaxFrame = 4 + 255 + 2;

inline std::uint16_t crc16Ccitt(const std::uint8_t* p, std::size_t n) {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ (std::uint16_t(p[i]) << 8));
    for (int b = 0; b < 8; ++b) {
      crc = (crc & 0x8000u) ? static_cast<std::uint16_t>((crc << 1) ^ 0x1021u)
                            : static_cast<std::uint16_t>(crc << 1);
    }
  }
  return crc;
}

/// Appends fields to a frame under construction; refuses to overflow.
class FrameWriter {
 public:
  explicit FrameWriter(std::uint8_t id) {
    buf_[0] = kTelemetrySync0;
    buf_[1] = kTelemetrySync1;
    buf_[2] = id;
  }
  void u8(std::uint8_t v) {
    if (ok(1)) buf_[n_++] = v;
  }
  void u32(std::uint32_t v) {
    if (ok(4)) {
      putU32(buf_ + n_, v);
      n_ += 4;
    }
  }
  void u64(std::uint64_t v) {
    u32(static_cast<std::uint32_t>(v));
    u32(static_cast<std::uint32_t>(v >> 32));
  }
  void f32(float v) {
    if (ok(4)) {
      putF32(buf_ + n_, v);
      n_ += 4;
    }
  }
  /// Closes the frame: length and CRC. Returns the frame size, 0 if it overflowed.
  std::size_t finish() {
    if (overflow_) return 0;
    buf_[3] = static_cast<std::uint8_t>(n_ - 4);
    const std::uint16_t crc = crc16Ccitt(buf_ + 2, n_ - 2);
    buf_[n_] = static_cast<std::uint8_t>(crc);
    buf_[n_ + 1] = static_cast<std::uint8_t>(crc >> 8);
    return n_ + 2;
  }
  const std::uint8_t* data() const { return buf_; }

 private:
  bool ok(std::size_t k) {
    if (n_ + k > 4 + 255) overflow_ = true;
    return !overflow_;
  }
  std::uint8_t buf_[kTelemetryMaxFrame]{};
  std::size_t n_ = 4;
  bool overflow_ = false;
};

}  // namespace odoerr::fw
