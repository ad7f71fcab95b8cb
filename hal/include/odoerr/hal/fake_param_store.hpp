// odoerr HAL: an in-memory NOR-flash ParamStore for tests, with power-loss injection.
//
// Semantics (fixed-capacity, no heap):
// - A fresh store reads 0xFF everywhere (as erased flash).
// - erase(i) sets sector i to 0xFF. It costs ONE byte-operation.
// - program() can only clear bits: every byte becomes stored & data. It is STRICT: if any
//   byte of the range would need a 0 -> 1 transition ((stored & data) != data) the call
//   returns kFailedPrecondition and writes nothing (this catches a driver that forgets to
//   erase). Re-programming a byte with a value that only clears more bits is allowed, as on
//   real NOR flash. Each programmed byte costs ONE byte-operation.
// - read() is free and has no side effects.
//
// Power loss: powerLossAfter(k) lets exactly k more byte-operations complete; the (k+1)-th
// one is interrupted:
// - a program() keeps its first bytes (those within the budget) fully written; the byte in
//   progress is left PARTIALLY programmed: some, never all, of the bits it had to clear are
//   cleared (stored & (data | garbage), garbage from a deterministic xorshift generator);
//   the later bytes of the call are untouched;
// - an erase() leaves the sector half-erased: every byte becomes stored | garbage (some
//   bits went back to 1, others did not);
// - the call returns kInternal and so does every later erase/program/read until powerOn()
//   (a simulated reboot), which restores service with the content preserved and disarms
//   the injection. k = 0 interrupts the very next operation.
// byteOps() counts the completed byte-operations (the interrupted one is not counted), so a
// test can measure how many a driver call takes and then inject a loss at each of them.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "odoerr/hal/param_store.hpp"
#include "odoerr/hal/power_loss.hpp"
#include "odoerr/hal/status.hpp"

namespace odoerr::hal {

template <std::size_t kSize, std::size_t kSectorSize>
class FakeParamStore final : public ParamStore {
  static_assert(kSectorSize > 0, "sector size must be positive");
  static_assert(kSize >= kSectorSize && kSize % kSectorSize == 0,
                "size must be a positive multiple of the sector size");

 public:
  explicit FakeParamStore(std::uint32_t garbage_seed = 0x9E3779B9u) : power_(garbage_seed) { mem_.fill(0xFF); }

  /// Arms a power loss: `byte_ops` more byte-operations (programmed bytes; an erase counts
  /// as one) complete, the next one is interrupted. Re-arming replaces the budget.
  void powerLossAfter(std::size_t byte_ops) { power_.after(byte_ops); }
  /// Cancels a pending (not yet triggered) power loss.
  void disarm() { power_.disarm(); }
  /// Simulated reboot: the store works again with its content preserved; injection disarmed.
  void powerOn() { power_.powerOn(); }
  bool poweredOn() const { return power_.powered(); }
  /// Number of power losses that have happened so far.
  std::size_t powerLosses() const { return power_.losses(); }

  /// Completed byte-operations (programmed bytes + erases) since construction/resetCounters().
  std::size_t byteOps() const { return programmed_bytes_ + erases_; }
  std::size_t programmedBytes() const { return programmed_bytes_; }
  std::size_t erases() const { return erases_; }
  void resetCounters() {
    programmed_bytes_ = 0;
    erases_ = 0;
  }

  /// Test back door, bypassing flash semantics, power state and counters.
  std::uint8_t raw(std::size_t offset) const { return mem_[offset]; }
  void setRaw(std::size_t offset, std::uint8_t value) { mem_[offset] = value; }
  void flipBit(std::size_t offset, unsigned bit) {
    mem_[offset] = static_cast<std::uint8_t>(mem_[offset] ^ (1u << (bit & 7u)));
  }

 private:
  std::size_t DoSize() const override { return kSize; }
  std::size_t DoSectorSize() const override { return kSectorSize; }

  Status DoErase(std::size_t index) override {
    if (!power_.powered()) return Status::kInternal;
    const std::size_t base = index * kSectorSize;
    if (power_.interruptNow()) {
      for (std::size_t i = 0; i < kSectorSize; ++i) mem_[base + i] = power_.partialErase(mem_[base + i]);
      return Status::kInternal;
    }
    for (std::size_t i = 0; i < kSectorSize; ++i) mem_[base + i] = 0xFF;
    ++erases_;
    return Status::kOk;
  }

  Status DoProgram(std::size_t offset, const std::uint8_t* data, std::size_t n) override {
    if (!power_.powered()) return Status::kInternal;
    for (std::size_t i = 0; i < n; ++i) {
      if (static_cast<std::uint8_t>(mem_[offset + i] & data[i]) != data[i]) {
        return Status::kFailedPrecondition;
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      std::uint8_t& cell = mem_[offset + i];
      if (power_.interruptNow()) {
        cell = power_.partialProgram(cell, data[i]);
        return Status::kInternal;
      }
      cell = static_cast<std::uint8_t>(cell & data[i]);
      ++programmed_bytes_;
    }
    return Status::kOk;
  }

  Status DoRead(std::size_t offset, std::uint8_t* out, std::size_t n) const override {
    if (!power_.powered()) return Status::kInternal;
    for (std::size_t i = 0; i < n; ++i) out[i] = mem_[offset + i];
    return Status::kOk;
  }

  std::array<std::uint8_t, kSize> mem_{};
  PowerLoss power_;
  std::size_t programmed_bytes_ = 0;
  std::size_t erases_ = 0;
};

}  // namespace odoerr::hal
