// The robot's peripherals on the STM32F405 board, shared by its images: USART1 for the laser
// (PA9/PA10), USART2 for telemetry (PA2/PA3), TIM2 and TIM5 in encoder mode (PA15/PB3,
// PA0/PA1), TIM3 as the microsecond clock. Their clocks and pins, and the check that each
// peripheral's registers hold what its driver wrote (under QEMU this shows the peripheral is
// where RM0090 puts it; QEMU models neither the RCC nor the GPIO, whose writes are ignored).
#pragma once

#include <cstdint>

#include "board.hpp"
#include "stm32_timers.hpp"
#include "stm32_usart.hpp"

namespace odoerr::board::stm32f405 {

inline constexpr std::uint32_t kHseHz = 8000000u;  // the board's crystal (configureClocks)
inline constexpr int kUsart1Irq = 37;  // RM0090 table 61
inline constexpr std::uint32_t kLaserBaud = 500000u;
inline constexpr std::uint32_t kTelemetryBaud = 115200u;

/// The peripherals' clocks on and their pins to their alternate functions.
inline void enableRobotPeripherals() {
  RccRegs& rcc = at<RccRegs>(kRccBase);
  rcc.ahb1enr = rcc.ahb1enr | rcc::kAhb1GpioAEn | rcc::kAhb1GpioBEn;
  rcc.apb2enr = rcc.apb2enr | rcc::kApb2Usart1En;
  rcc.apb1enr = rcc.apb1enr | rcc::kApb1Usart2En | rcc::kApb1Tim2En | rcc::kApb1Tim3En | rcc::kApb1Tim5En;
  pinAlternate(0, 9, 7);   // PA9  USART1_TX, AF7
  pinAlternate(0, 10, 7);  // PA10 USART1_RX, AF7
  pinAlternate(0, 2, 7);   // PA2  USART2_TX, AF7
  pinAlternate(0, 3, 7);   // PA3  USART2_RX, AF7
  pinAlternate(0, 15, 1);  // PA15 TIM2_CH1, AF1
  pinAlternate(1, 3, 1);   // PB3  TIM2_CH2, AF1
  pinAlternate(0, 0, 2);   // PA0  TIM5_CH1, AF2
  pinAlternate(0, 1, 2);   // PA1  TIM5_CH2, AF2
}

/// USART at `baud` from `f_ck_hz`, enabled with its receive interrupt (Stm32UsartPort::configure).
inline bool usartReadsBack(const UsartRegs& u, std::uint32_t f_ck_hz, std::uint32_t baud) {
  constexpr std::uint32_t on = usart::kCr1Ue | usart::kCr1Re | usart::kCr1RxneIe;
  return u.brr == usart::brrFor(f_ck_hz, baud) && (u.cr1 & on) == on;
}

/// TIM2 (left, not inverted) and TIM5 (right, inverted) in encoder mode 3 (Stm32EncoderTimer).
inline bool encodersReadBack(const GpTimerRegs& left, const GpTimerRegs& right) {
  return (left.smcr & 7u) == 3u && (right.smcr & 7u) == 3u && left.ccmr1 == 0x3131u && right.ccmr1 == 0x3131u &&
         right.ccer == tim::kCcerCc1p && left.arr == 0xFFFFFFFFu && right.arr == 0xFFFFFFFFu;
}

}  // namespace odoerr::board::stm32f405
