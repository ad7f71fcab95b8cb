// Cortex-M4F start-up for QEMU mps2-an386: the vector table; the reset sequence (FPU on,
// .data/.bss, a painted stack, static constructors, main, exit via semihosting) is the
// boards' common one (common/cortex_m_reset.hpp).
#include <cstdint>

#include "board.hpp"
#include "cortex_m_reset.hpp"
#include "cortex_m_vectors.hpp"
#include "semihosting.hpp"

extern "C" {
void Reset_Handler();
void Fault_Handler();
}

void Fault_Handler() { odoerr::board::shExit(97); }

__attribute__((section(".isr_vector"), used)) void (*const g_vectors[16])() = {
    reinterpret_cast<void (*)()>(&_estack),
    ODOERR_CORTEX_M_EXCEPTIONS(Reset_Handler, Fault_Handler),
};

void Reset_Handler() {
  odoerr::board::resetSequence();
}
