#include "board.hpp"

namespace odoerr::board::stm32f405 {
namespace {
// RCC_CR (7.3.1), RCC_PLLCFGR (7.3.2), RCC_CFGR (7.3.3), FLASH_ACR (3.9.1).
constexpr std::uint32_t kCrHseOn = 1u << 16;
constexpr std::uint32_t kCrHseRdy = 1u << 17;
constexpr std::uint32_t kCrPllOn = 1u << 24;
constexpr std::uint32_t kCrPllRdy = 1u << 25;
constexpr std::uint32_t kPllSrcHse = 1u << 22;
constexpr std::uint32_t kCfgrSwPll = 0x2u;
constexpr std::uint32_t kCfgrSwsMask = 0x3u << 2;
constexpr std::uint32_t kCfgrSwsPll = 0x2u << 2;
constexpr std::uint32_t kCfgrPpre1Div4 = 0x5u << 10;
constexpr std::uint32_t kCfgrPpre2Div2 = 0x4u << 13;
constexpr std::uint32_t kAcrLatency5 = 5u;
constexpr std::uint32_t kAcrPrften = 1u << 8;
constexpr std::uint32_t kAcrIcen = 1u << 9;
constexpr std::uint32_t kAcrDcen = 1u << 10;
static_assert(kCrPllRdy == 0x02000000u && kPllSrcHse == 0x00400000u, "RM0090 7.3.1-2");
constexpr std::uint32_t kReadyPolls = 100000u;

bool waitSet(const Reg& reg, std::uint32_t mask, std::uint32_t value) {
  for (std::uint32_t i = 0; i < kReadyPolls; ++i) {
    if ((reg & mask) == value) return true;
  }
  return false;
}
}  // namespace

ClockTree configureClocks(std::uint32_t hse_hz) {
  ClockTree tree;
  if (hse_hz < 4000000u || hse_hz > 26000000u || hse_hz % 2000000u != 0) return tree;
  RccRegs& rcc = at<RccRegs>(kRccBase);
  FlashRegs& fl = at<FlashRegs>(kFlashIfBase);
  rcc.cr = rcc.cr | kCrHseOn;
  if (!waitSet(rcc.cr, kCrHseRdy, kCrHseRdy)) return tree;
  const std::uint32_t m = hse_hz / 2000000u;  // VCO input 2 MHz
  const std::uint32_t n = 168u;               // VCO 336 MHz
  const std::uint32_t p_bits = 0u;            // P = 2: 168 MHz
  const std::uint32_t q = 7u;                 // 48 MHz
  rcc.pllcfgr = m | (n << 6) | (p_bits << 16) | kPllSrcHse | (q << 24);
  rcc.cr = rcc.cr | kCrPllOn;
  if (!waitSet(rcc.cr, kCrPllRdy, kCrPllRdy)) return tree;
  fl.acr = kAcrLatency5 | kAcrPrften | kAcrIcen | kAcrDcen;  // before the clock rises (3.5.1)
  rcc.cfgr = kCfgrPpre1Div4 | kCfgrPpre2Div2 | kCfgrSwPll;
  if (!waitSet(rcc.cfgr, kCfgrSwsMask, kCfgrSwsPll)) return tree;
  tree.sysclk_hz = 168000000u;
  tree.pclk1_hz = 42000000u;
  tree.pclk2_hz = 84000000u;
  tree.tim_apb1_hz = 84000000u;  // APB1 divided: the timers run at twice its clock (7.2)
  tree.from_pll = true;
  return tree;
}

void pinAlternate(int port, int pin, std::uint32_t af) {
  GpioRegs& g = at<GpioRegs>(kGpioABase + static_cast<std::uintptr_t>(port) * kGpioPortStride);
  const auto p = static_cast<std::uint32_t>(pin);
  g.moder = (g.moder & ~(0x3u << (2 * p))) | (0x2u << (2 * p));  // 10: alternate function
  Reg& afr = g.afr[p / 8];
  afr = (afr & ~(0xFu << (4 * (p % 8)))) | ((af & 0xFu) << (4 * (p % 8)));
}

void enableInterrupt(int irq) {
  auto* iser = reinterpret_cast<volatile std::uint32_t*>(0xE000E100u);  // NVIC_ISER0..
  iser[irq / 32] = 1u << (irq % 32);
}

}  // namespace odoerr::board::stm32f405
