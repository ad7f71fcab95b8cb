// odoerr HAL: a monotonic microsecond clock.
#pragma once

#include <cstdint>

namespace odoerr::hal {

class Clock {
 public:
  virtual ~Clock() = default;
  Clock() = default;
  Clock(const Clock&) = delete;
  Clock& operator=(const Clock&) = delete;

  /// Microseconds since an arbitrary epoch; never decreases; 64 bits never wrap in practice.
  std::uint64_t nowUs() const { return DoNowUs(); }

 private:
  virtual std::uint64_t DoNowUs() const = 0;
};

/// Fake for tests: time moves only when told.
class FakeClock final : public Clock {
 public:
  void set(std::uint64_t us) { now_ = us; }
  void advance(std::uint64_t us) { now_ += us; }

 private:
  std::uint64_t DoNowUs() const override { return now_; }
  std::uint64_t now_ = 0;
};

}  // namespace odoerr::hal
