// Cortex-M4F start-up for QEMU mps2-an386: vector table, FPU on, .data/.bss, a painted
// stack (for the high-water mark), static constructors, main, exit via semihosting.
#include <cstdint>

#include "board.hpp"
#include "cortex_m_vectors.hpp"
#include "semihosting.hpp"
#include "stack_paint.hpp"

extern "C" {
extern std::uint32_t _sidata, _sdata, _edata, _sbss, _ebss;
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();
int odoerr_call_main();
void Reset_Handler();
void Fault_Handler();
}

void Fault_Handler() { odoerr::board::shExit(97); }

__attribute__((section(".isr_vector"), used)) void (*const g_vectors[16])() = {
    reinterpret_cast<void (*)()>(&_estack),
    ODOERR_CORTEX_M_EXCEPTIONS(Reset_Handler, Fault_Handler),
};

void Reset_Handler() {
  // Full access to CP10/CP11 (the FPU) before any floating-point instruction.
  volatile std::uint32_t* cpacr = reinterpret_cast<volatile std::uint32_t*>(0xE000ED88u);
  *cpacr |= (0xFu << 20);
  __asm__ volatile("dsb\n isb" ::: "memory");
  for (std::uint32_t *src = &_sidata, *dst = &_sdata; dst < &_edata;) *dst++ = *src++;
  for (std::uint32_t* dst = &_sbss; dst < &_ebss;) *dst++ = 0;
  odoerr::board::paintStack();
  for (auto* f = __init_array_start; f < __init_array_end; ++f) (*f)();
  odoerr::board::shExit(odoerr_call_main());
}
