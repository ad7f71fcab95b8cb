// The reset sequence both Cortex-M4F boards share (mps2-an386, STM32F405): the FPU on, .data
// copied from flash, .bss zeroed, the stack painted for its high-water mark, static
// constructors, main, and main's exit code through semihosting. A board's start-up keeps only
// its vector table and calls this from Reset_Handler.
#pragma once

#include <cstdint>

#include "semihosting.hpp"
#include "stack_paint.hpp"

extern "C" {
extern std::uint32_t _sidata, _sdata, _edata, _sbss, _ebss;
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();
int odoerr_call_main();
}

namespace odoerr::board {

/// Inlined into Reset_Handler: the stack paint starts below the caller's frame.
[[noreturn]] __attribute__((always_inline)) inline void resetSequence() {
  // Full access to CP10/CP11 (the FPU) before any floating-point instruction.
  volatile std::uint32_t* cpacr = reinterpret_cast<volatile std::uint32_t*>(0xE000ED88u);
  *cpacr |= (0xFu << 20);
  __asm__ volatile("dsb\n isb" ::: "memory");
  for (std::uint32_t *src = &_sidata, *dst = &_sdata; dst < &_edata;) *dst++ = *src++;
  for (std::uint32_t* dst = &_sbss; dst < &_ebss;) *dst++ = 0;
  paintStack();
  for (auto* f = __init_array_start; f < __init_array_end; ++f) (*f)();
  shExit(odoerr_call_main());
}

}  // namespace odoerr::board
