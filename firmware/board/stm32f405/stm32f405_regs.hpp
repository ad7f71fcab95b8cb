// STM32F405 peripheral registers: the few this board port uses, written from the reference
// manual RM0090 (rev 19; section numbers below) and the STM32F405xx datasheet's memory map.
// Each block's layout is asserted at compile time against the manual's offsets, each base
// address against the memory map, and each bit position the drivers use against the
// manual's register description; no vendor header is used.
//
// The structs are plain layouts of `volatile std::uint32_t`: on the target a driver gets a
// reference to the block at its base address (`at<T>(base)`); on the host the tests give it a
// block in RAM and play the hardware's side (tests/test_stm32_drivers.cpp).
#pragma once

#include <cstddef>
#include <cstdint>

namespace odoerr::board::stm32f405 {

using Reg = volatile std::uint32_t;

// --- Memory map (datasheet, "Memory mapping"; RM0090 2.3, table 1) -------------------------
inline constexpr std::uintptr_t kTim2Base = 0x40000000u;    // APB1
inline constexpr std::uintptr_t kTim3Base = 0x40000400u;
inline constexpr std::uintptr_t kTim5Base = 0x40000C00u;
inline constexpr std::uintptr_t kUsart2Base = 0x40004400u;
inline constexpr std::uintptr_t kUsart1Base = 0x40011000u;  // APB2
inline constexpr std::uintptr_t kGpioABase = 0x40020000u;   // AHB1; port n at + n * 0x400
inline constexpr std::uintptr_t kGpioPortStride = 0x400u;
inline constexpr std::uintptr_t kRccBase = 0x40023800u;
inline constexpr std::uintptr_t kFlashIfBase = 0x40023C00u;  // the flash interface's registers
inline constexpr std::uintptr_t kFlashBase = 0x08000000u;    // main memory, 1 MB on the F405RG
inline constexpr std::uintptr_t kSram1Base = 0x20000000u;    // 112 KB SRAM1 + 16 KB SRAM2
inline constexpr std::uintptr_t kCcmBase = 0x10000000u;      // 64 KB core-coupled RAM

static_assert(kTim3Base - kTim2Base == 0x400 && kTim5Base - kTim2Base == 0xC00, "RM0090 2.3: TIM2..TIM5 0x400 apart");
static_assert(kUsart1Base == 0x40011000u && kUsart2Base == 0x40004400u, "RM0090 2.3: USART1 on APB2, USART2 on APB1");
static_assert(kRccBase == 0x40023800u && kFlashIfBase == 0x40023C00u, "RM0090 2.3: RCC and flash interface");

// --- USART (RM0090 30.6) -------------------------------------------------------------------
struct UsartRegs {
  Reg sr;    // 0x00 status
  Reg dr;    // 0x04 data
  Reg brr;   // 0x08 baud rate
  Reg cr1;   // 0x0C control 1
  Reg cr2;   // 0x10 control 2
  Reg cr3;   // 0x14 control 3
  Reg gtpr;  // 0x18 guard time and prescaler
};
static_assert(offsetof(UsartRegs, sr) == 0x00 && offsetof(UsartRegs, dr) == 0x04, "RM0090 30.6.1-2");
static_assert(offsetof(UsartRegs, brr) == 0x08 && offsetof(UsartRegs, cr1) == 0x0C, "RM0090 30.6.3-4");
static_assert(offsetof(UsartRegs, cr3) == 0x14 && sizeof(UsartRegs) == 0x1C, "RM0090 30.6.6-7");

namespace usart {
// SR (30.6.1)
inline constexpr std::uint32_t kSrPe = 1u << 0;    // parity error
inline constexpr std::uint32_t kSrFe = 1u << 1;    // framing error
inline constexpr std::uint32_t kSrNf = 1u << 2;    // noise detected
inline constexpr std::uint32_t kSrOre = 1u << 3;   // overrun
inline constexpr std::uint32_t kSrRxne = 1u << 5;  // read data register not empty
inline constexpr std::uint32_t kSrTc = 1u << 6;    // transmission complete
inline constexpr std::uint32_t kSrTxe = 1u << 7;   // transmit data register empty
// CR1 (30.6.4)
inline constexpr std::uint32_t kCr1Re = 1u << 2;
inline constexpr std::uint32_t kCr1Te = 1u << 3;
inline constexpr std::uint32_t kCr1RxneIe = 1u << 5;
inline constexpr std::uint32_t kCr1TxeIe = 1u << 7;
inline constexpr std::uint32_t kCr1M = 1u << 12;     // 9 data bits when set
inline constexpr std::uint32_t kCr1Ue = 1u << 13;    // USART enable
inline constexpr std::uint32_t kCr1Over8 = 1u << 15;  // 8x oversampling when set
// CR3 (30.6.6)
inline constexpr std::uint32_t kCr3Eie = 1u << 0;  // error interrupt (ORE, NF, FE with DMA)
static_assert(kSrRxne == 0x20 && kSrTxe == 0x80 && kSrOre == 0x08, "RM0090 30.6.1: SR bits");
static_assert(kCr1Ue == 0x2000 && kCr1RxneIe == 0x20 && kCr1Re == 0x04 && kCr1Te == 0x08, "RM0090 30.6.4: CR1 bits");

/// BRR for 16x oversampling (OVER8 = 0): USARTDIV = f_ck / (16 baud), held as a 12.4 fixed
/// point number (30.3.4), i.e. f_ck / baud rounded to the nearest integer. 0 if it does not
/// fit (USARTDIV below 1 or above 4095.9375).
constexpr std::uint32_t brrFor(std::uint32_t f_ck_hz, std::uint32_t baud) {
  if (baud == 0) return 0;
  const std::uint64_t v = (static_cast<std::uint64_t>(f_ck_hz) + baud / 2) / baud;
  return (v < 16 || v > 0xFFFF) ? 0u : static_cast<std::uint32_t>(v);
}
// 30.3.4, table 136's kind of example: 84 MHz (APB2 at the 168 MHz set-up) and 500 kbaud
// give USARTDIV 10.5: mantissa 10, fraction 8.
static_assert(brrFor(84000000u, 500000u) == ((10u << 4) | 8u), "RM0090 30.3.4: USARTDIV 10.5");
static_assert(brrFor(84000000u, 38400u) == 2188u, "84 MHz / 38400 = 2187.5 rounds to 2188");
}  // namespace usart

// --- General-purpose timers TIM2..TIM5 (RM0090 18.4) ---------------------------------------
struct GpTimerRegs {
  Reg cr1;         // 0x00
  Reg cr2;         // 0x04
  Reg smcr;        // 0x08 slave mode control
  Reg dier;        // 0x0C
  Reg sr;          // 0x10
  Reg egr;         // 0x14 event generation
  Reg ccmr1;       // 0x18 capture/compare mode 1
  Reg ccmr2;       // 0x1C
  Reg ccer;        // 0x20 capture/compare enable
  Reg cnt;         // 0x24 counter (32 bits on TIM2 and TIM5)
  Reg psc;         // 0x28 prescaler
  Reg arr;         // 0x2C auto-reload
  Reg reserved30;  // 0x30
  Reg ccr[4];      // 0x34..0x40
  Reg reserved44;  // 0x44
  Reg dcr;         // 0x48
  Reg dmar;        // 0x4C
  Reg option;      // 0x50 TIM2_OR / TIM5_OR
};
static_assert(offsetof(GpTimerRegs, smcr) == 0x08 && offsetof(GpTimerRegs, egr) == 0x14, "RM0090 18.4.3, 18.4.6");
static_assert(offsetof(GpTimerRegs, ccmr1) == 0x18 && offsetof(GpTimerRegs, ccer) == 0x20, "RM0090 18.4.7, 18.4.9");
static_assert(offsetof(GpTimerRegs, cnt) == 0x24 && offsetof(GpTimerRegs, psc) == 0x28, "RM0090 18.4.10-11");
static_assert(offsetof(GpTimerRegs, arr) == 0x2C && offsetof(GpTimerRegs, ccr) == 0x34, "RM0090 18.4.12-13");
static_assert(offsetof(GpTimerRegs, option) == 0x50, "RM0090 18.4.21: TIM2_OR / TIM5_OR");

namespace tim {
inline constexpr std::uint32_t kCr1Cen = 1u << 0;  // counter enable
inline constexpr std::uint32_t kEgrUg = 1u << 0;   // update generation (loads PSC)
// SMCR.SMS[2:0] (18.4.3): 011 = encoder mode 3, counts on both edges of TI1 and TI2.
inline constexpr std::uint32_t kSmcrSmsMask = 0x7u;
inline constexpr std::uint32_t kSmcrSmsEncoder3 = 0x3u;
// CCMR1 (18.4.7, input capture): CC1S[1:0] = 01 maps IC1 on TI1; CC2S[9:8] = 01 maps IC2 on
// TI2; IC1F[7:4] and IC2F[15:12] the input filters.
inline constexpr std::uint32_t kCcmr1Cc1sTi1 = 0x1u << 0;
inline constexpr std::uint32_t kCcmr1Cc2sTi2 = 0x1u << 8;
inline constexpr int kCcmr1Ic1fShift = 4;
inline constexpr int kCcmr1Ic2fShift = 12;
// CCER (18.4.9): CC1E bit 0, CC1P bit 1, CC2E bit 4, CC2P bit 5 (in encoder mode CCxP inverts
// the input's polarity; CCxE is not needed for counting).
inline constexpr std::uint32_t kCcerCc1p = 1u << 1;
inline constexpr std::uint32_t kCcerCc2p = 1u << 5;
static_assert(kCcmr1Cc2sTi2 == 0x100 && kCcerCc2p == 0x20, "RM0090 18.4.7, 18.4.9");
}  // namespace tim

// --- RCC (RM0090 7.3) ------------------------------------------------------------------------
struct RccRegs {
  Reg cr;           // 0x00
  Reg pllcfgr;      // 0x04
  Reg cfgr;         // 0x08
  Reg cir;          // 0x0C
  Reg ahb1rstr;     // 0x10
  Reg ahb2rstr;     // 0x14
  Reg ahb3rstr;     // 0x18
  Reg reserved1c;   // 0x1C
  Reg apb1rstr;     // 0x20
  Reg apb2rstr;     // 0x24
  Reg reserved28;   // 0x28
  Reg reserved2c;   // 0x2C
  Reg ahb1enr;      // 0x30
  Reg ahb2enr;      // 0x34
  Reg ahb3enr;      // 0x38
  Reg reserved3c;   // 0x3C
  Reg apb1enr;      // 0x40
  Reg apb2enr;      // 0x44
};
static_assert(offsetof(RccRegs, cfgr) == 0x08 && offsetof(RccRegs, ahb1enr) == 0x30, "RM0090 7.3.3, 7.3.10");
static_assert(offsetof(RccRegs, apb1enr) == 0x40 && offsetof(RccRegs, apb2enr) == 0x44, "RM0090 7.3.13-14");

namespace rcc {
inline constexpr std::uint32_t kApb1Tim2En = 1u << 0;
inline constexpr std::uint32_t kApb1Tim3En = 1u << 1;
inline constexpr std::uint32_t kApb1Tim5En = 1u << 3;
inline constexpr std::uint32_t kApb1Usart2En = 1u << 17;
inline constexpr std::uint32_t kApb2Usart1En = 1u << 4;
inline constexpr std::uint32_t kAhb1GpioAEn = 1u << 0;
inline constexpr std::uint32_t kAhb1GpioBEn = 1u << 1;
static_assert(kApb1Usart2En == 0x20000 && kApb2Usart1En == 0x10, "RM0090 7.3.13-14");
}  // namespace rcc

// --- GPIO (RM0090 8.4) -----------------------------------------------------------------------
struct GpioRegs {
  Reg moder;    // 0x00
  Reg otyper;   // 0x04
  Reg ospeedr;  // 0x08
  Reg pupdr;    // 0x0C
  Reg idr;      // 0x10
  Reg odr;      // 0x14
  Reg bsrr;     // 0x18
  Reg lckr;     // 0x1C
  Reg afr[2];   // 0x20 AFRL (pins 0-7), 0x24 AFRH (pins 8-15)
};
static_assert(offsetof(GpioRegs, pupdr) == 0x0C && offsetof(GpioRegs, afr) == 0x20, "RM0090 8.4.4, 8.4.9");
static_assert(sizeof(GpioRegs) == 0x28, "RM0090 8.4.10: AFRH at 0x24");

// --- Flash interface (RM0090 3.9) ------------------------------------------------------------
struct FlashRegs {
  Reg acr;      // 0x00 access control
  Reg keyr;     // 0x04
  Reg optkeyr;  // 0x08
  Reg sr;       // 0x0C
  Reg cr;       // 0x10
  Reg optcr;    // 0x14
};
static_assert(offsetof(FlashRegs, keyr) == 0x04 && offsetof(FlashRegs, sr) == 0x0C, "RM0090 3.9.2, 3.9.4");
static_assert(offsetof(FlashRegs, cr) == 0x10 && offsetof(FlashRegs, optcr) == 0x14, "RM0090 3.9.5-6");

namespace flash {
inline constexpr std::uint32_t kKey1 = 0x45670123u;  // 3.5.1: the unlock sequence
inline constexpr std::uint32_t kKey2 = 0xCDEF89ABu;
inline constexpr std::uint32_t kSrEop = 1u << 0;
inline constexpr std::uint32_t kSrOperr = 1u << 1;
inline constexpr std::uint32_t kSrWrperr = 1u << 4;
inline constexpr std::uint32_t kSrPgaerr = 1u << 5;
inline constexpr std::uint32_t kSrPgperr = 1u << 6;
inline constexpr std::uint32_t kSrPgserr = 1u << 7;
inline constexpr std::uint32_t kSrBsy = 1u << 16;
inline constexpr std::uint32_t kSrErrors = kSrOperr | kSrWrperr | kSrPgaerr | kSrPgperr | kSrPgserr;
inline constexpr std::uint32_t kCrPg = 1u << 0;
inline constexpr std::uint32_t kCrSer = 1u << 1;
inline constexpr int kCrSnbShift = 3;                   // SNB[6:3]: the sector to erase
inline constexpr std::uint32_t kCrPsizeX32 = 2u << 8;   // PSIZE[9:8] = 10: 32-bit program (2.7-3.6 V)
inline constexpr std::uint32_t kCrStrt = 1u << 16;
inline constexpr std::uint32_t kCrLock = 1u << 31;
static_assert(kSrBsy == 0x10000 && kCrStrt == 0x10000 && kCrLock == 0x80000000u, "RM0090 3.9.4-5");

/// The F405's sectors (RM0090 3.3, table 5): 4 x 16 KB, 1 x 64 KB, 7 x 128 KB.
constexpr std::uint32_t sectorSize(int sector) {
  return sector < 4 ? 16u * 1024u : (sector == 4 ? 64u * 1024u : 128u * 1024u);
}
constexpr std::uintptr_t sectorAddress(int sector) {
  std::uintptr_t a = kFlashBase;
  for (int s = 0; s < sector; ++s) a += sectorSize(s);
  return a;
}
static_assert(sectorAddress(4) == 0x08010000u && sectorAddress(5) == 0x08020000u, "RM0090 3.3, table 5");
static_assert(sectorAddress(11) + sectorSize(11) == 0x08100000u, "1 MB in 12 sectors");
}  // namespace flash

/// The register block of type T at a peripheral's base address (target only).
template <typename T>
T& at(std::uintptr_t base) {
  return *reinterpret_cast<T*>(base);  // NOLINT(performance-no-int-to-ptr): a peripheral's address
}

}  // namespace odoerr::board::stm32f405
