// odoerr HAL: power-loss injection for flash fakes and models (FakeParamStore, the tests'
// STM32F405 flash controller model). A budget of byte-operations completes, the next one is
// interrupted and the power is off until powerOn(); what the interrupted operation leaves:
// - a byte being programmed keeps some, never all, of the bits it had to clear cleared
//   (stored & (data | garbage), with one bit kept set if the garbage would complete it);
// - a sector being erased: every byte stored | garbage (some bits back to 1, others not).
// The garbage is a deterministic xorshift32 of the seed, so a failing case replays.
#pragma once

#include <cstddef>
#include <cstdint>

namespace odoerr::hal {

class PowerLoss {
 public:
  explicit PowerLoss(std::uint32_t seed = 0x9E3779B9u) : rng_(seed == 0 ? 1u : seed) {}

  /// `byte_ops` more byte-operations complete, the next one is interrupted. Re-arming
  /// replaces the budget.
  void after(std::size_t byte_ops) {
    armed_ = true;
    budget_ = byte_ops;
  }
  /// Cancels a pending (not yet triggered) loss.
  void disarm() { armed_ = false; }
  /// The power back (a reboot); the injection disarmed.
  void powerOn() {
    powered_ = true;
    armed_ = false;
  }
  bool powered() const { return powered_; }
  /// Losses that have happened so far.
  std::size_t losses() const { return losses_; }

  /// Consumes one unit of budget; true when the current operation is the interrupted one
  /// (the power is then off).
  bool interruptNow() {
    if (!armed_) return false;
    if (budget_ > 0) {
      --budget_;
      return false;
    }
    armed_ = false;
    powered_ = false;
    ++losses_;
    return true;
  }

  /// What a byte being programmed from `stored` towards `data` holds when the power goes.
  std::uint8_t partialProgram(std::uint8_t stored, std::uint8_t data) {
    const auto target = static_cast<std::uint8_t>(stored & data);
    auto partial = static_cast<std::uint8_t>(stored & (data | garbage()));
    const auto to_clear = static_cast<std::uint8_t>(stored & ~target);
    if (partial == target && to_clear != 0) {
      // Never complete the byte in progress: keep its lowest bit-to-clear set.
      partial = static_cast<std::uint8_t>(partial | (to_clear & (~to_clear + 1u)));
    }
    return partial;
  }
  /// What a byte of a sector being erased holds when the power goes.
  std::uint8_t partialErase(std::uint8_t stored) { return static_cast<std::uint8_t>(stored | garbage()); }

 private:
  std::uint8_t garbage() {  // xorshift32
    rng_ ^= rng_ << 13;
    rng_ ^= rng_ >> 17;
    rng_ ^= rng_ << 5;
    return static_cast<std::uint8_t>(rng_ >> 24);
  }

  std::uint32_t rng_;
  std::size_t budget_ = 0;
  std::size_t losses_ = 0;
  bool armed_ = false;
  bool powered_ = true;
};

}  // namespace odoerr::hal
