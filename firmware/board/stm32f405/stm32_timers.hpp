// Timers behind the HAL (RM0090 18): a 32-bit general-purpose timer (TIM2 or TIM5) counting a
// wheel's quadrature edges in encoder mode behind hal::EncoderCounter, and a 32-bit timer at
// 1 MHz behind hal::Clock.
//
// Encoder mode 3 counts every edge of both channels (4 counts a line) up or down by the
// direction; the counter wraps at 2^32, and the firmware's encoder driver takes wrap-safe
// differences of what read() returns (odoerr/drivers/encoder.hpp), so the 32-bit count needs no
// extension. The F405 has two 32-bit timers (TIM2, TIM5), both taken by the wheels, so the
// clock runs on a 16-bit one (TIM3 or TIM4) and extends it to 64 bits on read: it must be
// read at least once per wrap (65.5 ms at 1 MHz), which the main loop's 1 ms poll does.
#pragma once

#include <cstdint>

#include "odoerr/hal/clock.hpp"
#include "odoerr/hal/encoder_counter.hpp"
#include "stm32f405_regs.hpp"

namespace odoerr::board::stm32f405 {

class Stm32EncoderTimer final : public hal::EncoderCounter {
 public:
  explicit Stm32EncoderTimer(GpTimerRegs& regs) : regs_(regs) {}

  /// Encoder mode 3 on TI1 and TI2, the input filter `filter` (0..15, IC1F/IC2F: 0 none, 3 is
  /// 8 samples at f_CK_INT), `invert` reverses the counting direction (CC1P), the full 32-bit
  /// range, the counter started at 0. kInvalidArgument for a filter above 15.
  [[nodiscard]] hal::Status configure(std::uint32_t filter, bool invert) {
    if (filter > 15) return hal::Status::kInvalidArgument;
    regs_.cr1 = 0;  // stopped while it is set up
    regs_.smcr = (regs_.smcr & ~tim::kSmcrSmsMask) | tim::kSmcrSmsEncoder3;
    regs_.ccmr1 = tim::kCcmr1Cc1sTi1 | tim::kCcmr1Cc2sTi2 | (filter << tim::kCcmr1Ic1fShift) |
                  (filter << tim::kCcmr1Ic2fShift);
    regs_.ccer = invert ? tim::kCcerCc1p : 0u;
    regs_.psc = 0;
    regs_.arr = 0xFFFFFFFFu;
    regs_.egr = tim::kEgrUg;
    regs_.cnt = 0;
    regs_.cr1 = tim::kCr1Cen;
    configured_ = true;
    return hal::Status::kOk;
  }

 private:
  hal::Status DoRead(std::uint32_t* count) override {
    if (!configured_) return hal::Status::kUnavailable;
    // A set-up the hardware lost (a reset of the peripheral, a stray write) is a fault, not a
    // count: the counter would not be counting edges any more.
    if ((regs_.cr1 & tim::kCr1Cen) == 0 || (regs_.smcr & tim::kSmcrSmsMask) != tim::kSmcrSmsEncoder3) {
      return hal::Status::kInternal;
    }
    *count = regs_.cnt;
    return hal::Status::kOk;
  }
  std::uint8_t DoBits() const override { return 32; }

  GpTimerRegs& regs_;
  bool configured_ = false;
};

class Stm32MicrosecondClock final : public hal::Clock {
 public:
  /// `bits`: the timer's width, 16 (TIM3, TIM4) or 32 (TIM2, TIM5).
  Stm32MicrosecondClock(GpTimerRegs& regs, std::uint8_t bits)
      : regs_(regs), mask_(bits >= 32 ? 0xFFFFFFFFu : (1u << bits) - 1u) {}

  /// Counts up at 1 MHz from a timer clock of `f_timer_hz` (a whole number of MHz),
  /// free-running over the timer's width. kInvalidArgument otherwise.
  [[nodiscard]] hal::Status configure(std::uint32_t f_timer_hz) {
    if (f_timer_hz < 1000000u || f_timer_hz % 1000000u != 0) return hal::Status::kInvalidArgument;
    regs_.cr1 = 0;
    regs_.smcr = regs_.smcr & ~tim::kSmcrSmsMask;  // internal clock
    regs_.psc = f_timer_hz / 1000000u - 1u;
    regs_.arr = mask_;
    regs_.egr = tim::kEgrUg;  // loads PSC now (it is buffered until an update)
    regs_.cnt = 0;
    last_ = 0;  // the count goes on from where it was: never backwards
    regs_.cr1 = tim::kCr1Cen;
    return hal::Status::kOk;
  }

 private:
  std::uint64_t DoNowUs() const override {
    const std::uint32_t now = regs_.cnt & mask_;
    // Wrap-safe: the difference since the last read, modulo the timer's width, added to the
    // 64-bit count.
    total_ += (now - last_) & mask_;
    last_ = now;
    return total_;
  }

  GpTimerRegs& regs_;
  std::uint32_t mask_;
  mutable std::uint32_t last_ = 0;
  mutable std::uint64_t total_ = 0;
};

}  // namespace odoerr::board::stm32f405
