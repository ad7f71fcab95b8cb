// STM32F405 start-up: the vector table (16 core exceptions and the 82 interrupts of RM0090
// 12.2, table 61), FPU on, .data and .bss, a painted stack (stack_paint.hpp), static
// constructors, main, and the exit code through semihosting (the only console under QEMU; on
// a board without a debugger the application reports over its telemetry instead).
#include <array>
#include <cstddef>
#include <cstdint>

#include "cortex_m_vectors.hpp"
#include "semihosting.hpp"
#include "stack_paint.hpp"

extern "C" {
extern std::uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();
int odoerr_call_main();
void Reset_Handler();
void Fault_Handler();
void Unused_Handler();
// The interrupts the board's drivers serve; an application defines the handler it uses
// (weak: an interrupt enabled without a handler ends in Unused_Handler, exit code 96).
void USART1_IRQHandler() __attribute__((weak, alias("Unused_Handler")));
void USART2_IRQHandler() __attribute__((weak, alias("Unused_Handler")));
}

void Fault_Handler() { odoerr::board::shExit(97); }
void Unused_Handler() { odoerr::board::shExit(96); }

namespace {
constexpr int kInterrupts = 82;
constexpr int kUsart1Irq = 37;  // RM0090 table 61: USART1 global interrupt
constexpr int kUsart2Irq = 38;  // USART2 global interrupt

using Handler = void (*)();
constexpr std::array<Handler, kInterrupts> interruptTable() {
  std::array<Handler, kInterrupts> t{};
  for (auto& h : t) h = Unused_Handler;
  t[kUsart1Irq] = USART1_IRQHandler;
  t[kUsart2Irq] = USART2_IRQHandler;
  return t;
}

struct Vectors {
  std::uint32_t* initial_sp;
  Handler core[15];  // Reset .. SysTick
  std::array<Handler, kInterrupts> irq;
};
static_assert(offsetof(Vectors, irq) == 16 * sizeof(Handler) && sizeof(Vectors) == (16 + kInterrupts) * sizeof(Handler),
              "the table is 98 words: the stack pointer, 15 exceptions, 82 interrupts");
}  // namespace

__attribute__((section(".isr_vector"), used)) const Vectors g_vectors = {
    &_estack,
    {ODOERR_CORTEX_M_EXCEPTIONS(Reset_Handler, Fault_Handler)},
    interruptTable(),
};

__attribute__((section(".text.Reset_Handler"))) void Reset_Handler() {
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
