// A host model of the STM32F405 flash controller (RM0090 3.5-3.6) for sectors 1 and 2, the
// bus of Stm32FlashParamStore in tests (firmware/board/stm32f405/stm32_flash.hpp). QEMU's
// netduinoplus2 does not emulate the flash interface, so the driver is checked against this.
//
// The rules it applies: FLASH_CR locked after reset, KEY1 then KEY2 to unlock, any other
// write to KEYR locks it until the next reset; writes to a locked CR ignored, except setting
// LOCK; an erase (SER + SNB, then STRT) sets a sector to 0xFF; a byte write with PG set and
// PSIZE = x8 clears bits only (stored & data); a write without PG is a sequence error
// (PGSERR), one with another PSIZE a parallelism error (PGPERR); each operation keeps BSY set
// for a few polls of SR, then sets EOP.
//
// Power loss as FakeParamStore models it (hal/include/odoerr/hal/fake_param_store.hpp):
// powerLossAfter(k) lets k more byte-operations (bytes programmed; an erase counts one)
// complete, and the next is interrupted: a byte partly programmed (never complete), a sector
// half erased (hal/include/odoerr/hal/power_loss.hpp). The controller then answers every poll
// with OPERR until powerOn(), a reset.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "odoerr/hal/power_loss.hpp"
#include "stm32f405_regs.hpp"

namespace odoerr::board::stm32f405::test {

class Stm32FlashModel {
 public:
  static constexpr std::uintptr_t kBase = flash::sectorAddress(1);
  static constexpr std::size_t kBytes = 2 * flash::sectorSize(1);

  Stm32FlashModel() { mem_.fill(0xFF); }

  // --- the bus (what the driver sees) ---
  std::uint32_t sr() {
    if (!power_.powered()) return flash::kSrOperr;
    if (busy_polls_ > 0) {
      --busy_polls_;
      return sr_ | flash::kSrBsy;
    }
    return sr_;
  }
  void clearSr(std::uint32_t bits) { sr_ &= ~(bits & (flash::kSrErrors | flash::kSrEop)); }
  std::uint32_t cr() const { return cr_; }
  void setCr(std::uint32_t v) {
    if (!power_.powered()) return;
    if ((cr_ & flash::kCrLock) != 0) {
      if ((v & flash::kCrLock) != 0) cr_ |= flash::kCrLock;
      return;
    }
    cr_ = v;
    if ((v & flash::kCrLock) != 0) {
      key_stage_ = 0;
      return;
    }
    if ((v & flash::kCrStrt) != 0) {
      if ((v & flash::kCrSer) == 0) {
        sr_ |= flash::kSrPgserr;
        return;
      }
      const int snb = static_cast<int>((v >> flash::kCrSnbShift) & 0xFu);
      if (snb < 1 || snb > 2) {
        sr_ |= flash::kSrWrperr;  // outside the modelled sectors: refused
        return;
      }
      ++erase_requests_;
      erase(static_cast<std::size_t>(snb - 1) * flash::sectorSize(1));
    }
  }
  void key(std::uint32_t v) {
    if (!power_.powered() || locked_until_reset_) return;
    if (key_stage_ == 0 && v == flash::kKey1) {
      key_stage_ = 1;
    } else if (key_stage_ == 1 && v == flash::kKey2) {
      key_stage_ = 0;
      cr_ &= ~flash::kCrLock;
    } else {
      locked_until_reset_ = true;  // RM0090 3.5.1: a wrong sequence locks until reset
      cr_ |= flash::kCrLock;
    }
  }
  std::uint8_t readByte(std::uintptr_t address) const { return mem_[index(address)]; }
  void writeByte(std::uintptr_t address, std::uint8_t v) {
    if (!power_.powered()) return;
    if ((cr_ & flash::kCrPg) == 0 || (cr_ & flash::kCrLock) != 0) {
      sr_ |= flash::kSrPgserr;
      return;
    }
    if ((cr_ & (3u << 8)) != 0) {  // PSIZE is not x8 for a byte access
      sr_ |= flash::kSrPgperr;
      return;
    }
    const std::size_t i = index(address);
    if (power_.interruptNow()) {
      mem_[i] = power_.partialProgram(mem_[i], v);
      return;
    }
    mem_[i] = static_cast<std::uint8_t>(mem_[i] & v);
    ++programmed_;
    busy_polls_ = 2;
    sr_ |= flash::kSrEop;
  }

  // --- the test's side ---
  void powerLossAfter(std::size_t byte_ops) { power_.after(byte_ops); }
  /// A reset: the power back, FLASH_CR locked again, the flags cleared; the array kept.
  void powerOn() {
    power_.powerOn();
    locked_until_reset_ = false;
    key_stage_ = 0;
    cr_ = flash::kCrLock;
    sr_ = 0;
    busy_polls_ = 0;
  }
  bool poweredOn() const { return power_.powered(); }
  std::size_t byteOps() const { return programmed_ + erases_; }
  std::size_t eraseRequests() const { return erase_requests_; }
  std::uint8_t raw(std::size_t i) const { return mem_[i]; }
  /// The next operation ends with this error flag set (a fault the driver must report).
  void failWith(std::uint32_t flag) { sr_ |= flag; }

 private:
  static std::size_t index(std::uintptr_t address) { return static_cast<std::size_t>(address - kBase) % kBytes; }
  void erase(std::size_t base) {
    if (power_.interruptNow()) {
      for (std::size_t i = 0; i < flash::sectorSize(1); ++i) mem_[base + i] = power_.partialErase(mem_[base + i]);
      return;
    }
    for (std::size_t i = 0; i < flash::sectorSize(1); ++i) mem_[base + i] = 0xFF;
    ++erases_;
    busy_polls_ = 5;
    sr_ |= flash::kSrEop;
  }
  std::array<std::uint8_t, kBytes> mem_{};
  std::uint32_t cr_ = flash::kCrLock;
  std::uint32_t sr_ = 0;
  int key_stage_ = 0;
  bool locked_until_reset_ = false;
  int busy_polls_ = 0;
  hal::PowerLoss power_;
  std::size_t programmed_ = 0;
  std::size_t erases_ = 0;
  std::size_t erase_requests_ = 0;
};

}  // namespace odoerr::board::stm32f405::test
