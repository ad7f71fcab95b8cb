// The parameter store on the STM32F405's own flash, behind hal::ParamStore (RM0090 3): two
// 16 KB sectors (1 and 2, at 0x08004000; the image leaves them free) hold the calibration
// store's two slots.
//
// The flash rules it keeps (RM0090 3.5-3.6):
// - FLASH_CR is locked after reset; KEY1 then KEY2 into FLASH_KEYR unlocks it, and a wrong
//   sequence locks it until the next reset. The driver unlocks for each operation and locks
//   again after it.
// - An erase sets a whole sector to 0xFF: SER and SNB, then STRT, then wait for BSY to clear.
// - Programming can only clear bits: PG, then a write to the address (byte parallelism,
//   PSIZE = x8, valid at any supply voltage), then wait for BSY. A byte that would need a bit
//   set again is refused before anything is written (kFailedPrecondition), as the host's
//   FakeParamStore does, so a driver that forgets to erase is caught on both.
// - Any error flag after an operation (PGSERR, PGPERR, PGAERR, WRPERR, OPERR) is kInternal and
//   is cleared; so is a BSY that never clears (a bounded wait).
// While a sector erases, the CPU stalls on any fetch from flash (one bank): about 0.25-0.5 s
// for 16 KB; the firmware saves its calibration while the robot stands still.
//
// The registers and the array are reached through a bus (a template parameter): on the board,
// `MmioFlashBus`, the registers at 0x40023C00 and the array at its address; on the host the
// tests' model of the flash controller, which applies the rules above and loses power where a
// test asks (tests/stm32_flash_model.hpp).
#pragma once

#include <cstddef>
#include <cstdint>

#include "odoerr/hal/param_store.hpp"
#include "stm32f405_regs.hpp"

namespace odoerr::board::stm32f405 {

/// The board's bus: the flash interface's registers and the flash array, memory-mapped.
class MmioFlashBus {
 public:
  std::uint32_t sr() const { return at<FlashRegs>(kFlashIfBase).sr; }
  void clearSr(std::uint32_t bits) { at<FlashRegs>(kFlashIfBase).sr = bits; }  // write 1 to clear
  std::uint32_t cr() const { return at<FlashRegs>(kFlashIfBase).cr; }
  void setCr(std::uint32_t v) { at<FlashRegs>(kFlashIfBase).cr = v; }
  void key(std::uint32_t v) { at<FlashRegs>(kFlashIfBase).keyr = v; }
  std::uint8_t readByte(std::uintptr_t address) const { return *reinterpret_cast<volatile const std::uint8_t*>(address); }
  void writeByte(std::uintptr_t address, std::uint8_t v) { *reinterpret_cast<volatile std::uint8_t*>(address) = v; }
};

template <typename Bus>
class Stm32FlashParamStore final : public hal::ParamStore {
 public:
  static constexpr int kFirstSector = 1;
  static constexpr int kSectors = 2;
  static constexpr std::size_t kSectorBytes = flash::sectorSize(kFirstSector);
  static_assert(flash::sectorSize(kFirstSector) == flash::sectorSize(kFirstSector + kSectors - 1),
                "the store's sectors are the same size");
  static constexpr std::uintptr_t kBase = flash::sectorAddress(kFirstSector);
  /// Polls of BSY before an operation is called stuck (an erase of 16 KB takes up to 0.8 s;
  /// at 168 MHz a poll is a few cycles, so this is several seconds).
  static constexpr std::uint32_t kBusyPolls = 200000000u;

  explicit Stm32FlashParamStore(Bus& bus) : bus_(bus) {}

 private:
  std::size_t DoSize() const override { return kSectorBytes * kSectors; }
  std::size_t DoSectorSize() const override { return kSectorBytes; }

  hal::Status DoErase(std::size_t index) override {
    hal::Status s = begin();
    if (s != hal::Status::kOk) return s;
    const auto snb = static_cast<std::uint32_t>(kFirstSector + static_cast<int>(index));
    bus_.setCr(flash::kCrSer | (snb << flash::kCrSnbShift));
    bus_.setCr(flash::kCrSer | (snb << flash::kCrSnbShift) | flash::kCrStrt);
    s = finish();
    bus_.setCr(0);
    lock();
    return s;
  }

  hal::Status DoProgram(std::size_t offset, const std::uint8_t* data, std::size_t n) override {
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint8_t stored = bus_.readByte(kBase + offset + i);
      if (static_cast<std::uint8_t>(stored & data[i]) != data[i]) return hal::Status::kFailedPrecondition;
    }
    hal::Status s = begin();
    if (s != hal::Status::kOk) return s;
    bus_.setCr(flash::kCrPg);  // PSIZE = 00: byte parallelism
    for (std::size_t i = 0; i < n && s == hal::Status::kOk; ++i) {
      bus_.writeByte(kBase + offset + i, data[i]);
      s = finish();
    }
    bus_.setCr(0);
    lock();
    return s;
  }

  hal::Status DoRead(std::size_t offset, std::uint8_t* out, std::size_t n) const override {
    for (std::size_t i = 0; i < n; ++i) out[i] = bus_.readByte(kBase + offset + i);
    return hal::Status::kOk;
  }

  // No operation in progress, old error flags cleared, the control register unlocked.
  hal::Status begin() {
    if (!waitIdle()) return hal::Status::kInternal;
    bus_.clearSr(flash::kSrErrors | flash::kSrEop);
    if ((bus_.cr() & flash::kCrLock) != 0) {
      bus_.key(flash::kKey1);
      bus_.key(flash::kKey2);
      if ((bus_.cr() & flash::kCrLock) != 0) return hal::Status::kInternal;  // locked until reset
    }
    return hal::Status::kOk;
  }
  // The operation started has ended without an error flag.
  hal::Status finish() {
    if (!waitIdle()) return hal::Status::kInternal;
    const std::uint32_t errors = bus_.sr() & flash::kSrErrors;
    if (errors != 0) {
      bus_.clearSr(errors);
      return hal::Status::kInternal;
    }
    return hal::Status::kOk;
  }
  bool waitIdle() {
    for (std::uint32_t i = 0; i < kBusyPolls; ++i) {
      if ((bus_.sr() & flash::kSrBsy) == 0) return true;
    }
    return false;
  }
  void lock() { bus_.setCr(flash::kCrLock); }

  Bus& bus_;
};

}  // namespace odoerr::board::stm32f405
