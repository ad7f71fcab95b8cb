// odoerr HAL: a free-running hardware encoder counter (one per wheel or axis).
#pragma once

#include "odoerr/hal/status.hpp"

namespace odoerr::hal {

/// The raw count of a quadrature counter that wraps at 2^bits(). Drivers turn successive
/// counts into wrap-safe deltas (see firmware/drivers/encoder.hpp).
class EncoderCounter {
 public:
  virtual ~EncoderCounter() = default;
  EncoderCounter() = default;
  EncoderCounter(const EncoderCounter&) = delete;
  EncoderCounter& operator=(const EncoderCounter&) = delete;

  /// Reads the current count (only the low bits() bits are meaningful).
  /// kOk: *count is valid. kUnavailable: the counter is not ready (count untouched).
  /// kInternal: hardware fault. kInvalidArgument: count is null.
  Status read(std::uint32_t* count) {
    if (count == nullptr) return Status::kInvalidArgument;
    return DoRead(count);
  }
  /// Counter width in bits: 16 or 32.
  std::uint8_t bits() const { return DoBits(); }

 private:
  virtual Status DoRead(std::uint32_t* count) = 0;
  virtual std::uint8_t DoBits() const = 0;
};

/// Fake for tests: returns the count it is given, wrapped to its width.
class FakeEncoderCounter final : public EncoderCounter {
 public:
  explicit FakeEncoderCounter(std::uint8_t bits) : bits_(bits) {}
  void set(std::uint64_t raw) { count_ = static_cast<std::uint32_t>(raw & mask()); }
  void fail(Status s) { next_ = s; }

 private:
  std::uint32_t mask() const { return bits_ >= 32 ? 0xFFFFFFFFu : ((1u << bits_) - 1u); }
  Status DoRead(std::uint32_t* count) override {
    if (next_ != Status::kOk) {
      const Status s = next_;
      next_ = Status::kOk;
      return s;
    }
    *count = count_;
    return Status::kOk;
  }
  std::uint8_t DoBits() const override { return bits_; }
  std::uint8_t bits_;
  std::uint32_t count_ = 0;
  Status next_ = Status::kOk;
};

}  // namespace odoerr::hal
