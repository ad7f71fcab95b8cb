// The Cortex-M4's 15 exception vectors after the initial stack pointer (ARMv7-M: Reset, NMI,
// HardFault, MemManage, BusFault, UsageFault, 4 reserved, SVCall, DebugMonitor, 1 reserved,
// PendSV, SysTick), for a board's vector table: Reset to `reset`, every fault and unused
// exception to `fault`, the reserved words null.
#pragma once

#define ODOERR_CORTEX_M_EXCEPTIONS(reset, fault) \
  reset, fault, fault, fault, fault, fault, nullptr, nullptr, nullptr, nullptr, fault, fault, nullptr, fault, fault
