// The STM32F405 board set-up: the clock tree (RM0090 6.2, 7.3), the pins' alternate
// functions (8.3.7) and the interrupt controller's enable bits (Cortex-M4 NVIC_ISER).
#pragma once

#include <cstdint>

#include "stm32f405_regs.hpp"

namespace odoerr::board::stm32f405 {

struct ClockTree {
  std::uint32_t sysclk_hz = 16000000u;  // HSI after reset
  std::uint32_t pclk1_hz = 16000000u;   // APB1: USART2, TIM2-5 (their clock is 2 x pclk1 when APB1 is divided)
  std::uint32_t pclk2_hz = 16000000u;   // APB2: USART1
  std::uint32_t tim_apb1_hz = 16000000u;
  bool from_pll = false;                // false: HSE or the PLL never became ready; on HSI
};

/// 168 MHz from an `hse_hz` crystal (a whole number of 2 MHz steps, 4-26 MHz) through the PLL:
/// VCO input 2 MHz, N 168, P 2 (168 MHz), Q 7 (48 MHz); AHB /1, APB1 /4 (42 MHz), APB2 /2
/// (84 MHz); flash 5 wait states with the caches. Every wait for a ready bit is bounded: a
/// crystal that does not start (or an emulator without the RCC) leaves the chip on its 16 MHz
/// HSI, and the tree says so.
ClockTree configureClocks(std::uint32_t hse_hz);

/// Pin `pin` of GPIO port `port` (0 = A) to alternate function `af` (RM0090 8.3.7).
void pinAlternate(int port, int pin, std::uint32_t af);

/// Enables interrupt `irq` (its position in RM0090 table 61) in the NVIC.
void enableInterrupt(int irq);

}  // namespace odoerr::board::stm32f405
