// STM32F405 start-up: the vector table (16 core exceptions and the 82 interrupts of RM0090
// 12.2, table 61). The reset sequence is the boards' common one (common/cortex_m_reset.hpp):
// FPU on, .data and .bss, a painted stack, static constructors, main, and the exit code
// through semihosting (the only console under QEMU; on a board without a debugger the
// application reports over its telemetry instead).
#include <array>
#include <cstddef>
#include <cstdint>

#include "cortex_m_reset.hpp"
#include "cortex_m_vectors.hpp"
#include "semihosting.hpp"

extern "C" {
extern std::uint32_t _estack;
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
  odoerr::board::resetSequence();
}
