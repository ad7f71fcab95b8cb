// A USART receiver behind hal::SerialPort (RM0090 30): the receive interrupt moves each byte
// from DR into a ring buffer; read() copies out what has arrived and never blocks. The
// LMS2xx parser reads it as it reads any SerialPort.
//
// Loss is never silent: a byte the hardware overran (SR.ORE: a byte came before the last was
// read) or one the ring had no room for is counted, and the next read() returns kDataLoss
// with the bytes that did arrive (the parser then resynchronises on the next telegram).
// Framing, noise and parity flags are counted too; those bytes are kept (the telegram's CRC
// decides).
//
// One producer (the interrupt) and one consumer (the main loop): the ring's indices are
// atomics, written each by one side only. Writing is polled (TXE), for the few bytes the
// firmware sends (the LMS2xx's mode requests).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

#include "odoerr/hal/serial_port.hpp"
#include "stm32f405_regs.hpp"

namespace odoerr::board::stm32f405 {

struct UsartCounters {
  std::uint32_t bytes_received = 0;
  std::uint32_t overruns = 0;      // SR.ORE seen: at least one byte lost in the hardware
  std::uint32_t ring_full = 0;     // bytes dropped because the ring had no room
  std::uint32_t framing_errors = 0;
  std::uint32_t noise_errors = 0;
  std::uint32_t parity_errors = 0;
};

template <std::size_t kRingBytes>
class Stm32UsartPort final : public hal::SerialPort {
  static_assert(kRingBytes >= 2 && (kRingBytes & (kRingBytes - 1)) == 0, "the ring's size is a power of two");

 public:
  explicit Stm32UsartPort(UsartRegs& regs) : regs_(regs) {}

  /// 8N1 at `baud` from a peripheral clock of `f_ck_hz`, 16x oversampling, receiver and
  /// transmitter on, the receive interrupt on (and the error interrupt, for overruns).
  /// kInvalidArgument when the baud rate cannot be reached from this clock.
  [[nodiscard]] hal::Status configure(std::uint32_t f_ck_hz, std::uint32_t baud) {
    const std::uint32_t brr = usart::brrFor(f_ck_hz, baud);
    if (brr == 0) return hal::Status::kInvalidArgument;
    regs_.cr1 = 0;  // UE off while it is set up (30.6.4: M and PCE only while UE is 0)
    regs_.brr = brr;
    regs_.cr2 = 0;  // one stop bit
    regs_.cr3 = usart::kCr3Eie;
    regs_.cr1 = usart::kCr1Ue | usart::kCr1Te | usart::kCr1Re | usart::kCr1RxneIe;
    return hal::Status::kOk;
  }

  /// The interrupt's body (USARTx_IRQHandler calls it). Reads SR, then DR when a byte is
  /// there: that read sequence also clears ORE, NF, FE and PE (30.6.1).
  void onInterrupt() {
    const std::uint32_t sr = regs_.sr;
    if ((sr & (usart::kSrRxne | usart::kSrOre)) == 0) return;
    const auto byte = static_cast<std::uint8_t>(regs_.dr & 0xFFu);
    if ((sr & usart::kSrOre) != 0) {
      ++counters_.overruns;
      lost_.store(true, std::memory_order_release);
    }
    if ((sr & usart::kSrFe) != 0) ++counters_.framing_errors;
    if ((sr & usart::kSrNf) != 0) ++counters_.noise_errors;
    if ((sr & usart::kSrPe) != 0) ++counters_.parity_errors;
    if ((sr & usart::kSrRxne) == 0) return;  // ORE with no byte waiting: DR read only to clear it
    ++counters_.bytes_received;
    const std::uint32_t head = head_.load(std::memory_order_relaxed);
    const std::uint32_t tail = tail_.load(std::memory_order_acquire);
    if (head - tail >= kRingBytes) {
      ++counters_.ring_full;
      lost_.store(true, std::memory_order_release);
      return;
    }
    ring_[head & (kRingBytes - 1)] = byte;
    head_.store(head + 1, std::memory_order_release);
  }

  /// The counts so far (read from the main loop; each is written by the interrupt only).
  const UsartCounters& counters() const { return counters_; }
  /// Bytes waiting in the ring.
  std::size_t pending() const {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_relaxed);
  }

 private:
  hal::Status DoRead(std::uint8_t* buf, std::size_t capacity, std::size_t* n_read) override {
    const std::uint32_t tail = tail_.load(std::memory_order_relaxed);
    const std::uint32_t head = head_.load(std::memory_order_acquire);
    std::size_t n = head - tail;
    if (n > capacity) n = capacity;
    for (std::size_t i = 0; i < n; ++i) buf[i] = ring_[(tail + i) & (kRingBytes - 1)];
    tail_.store(tail + static_cast<std::uint32_t>(n), std::memory_order_release);
    *n_read = n;
    return lost_.exchange(false, std::memory_order_acq_rel) ? hal::Status::kDataLoss : hal::Status::kOk;
  }

  hal::Status DoWrite(const std::uint8_t* data, std::size_t n, std::size_t* n_written) override {
    // Polled: each byte waits for TXE, with a bound so that a stuck transmitter cannot hang
    // the loop (the bytes not sent are reported).
    for (std::size_t i = 0; i < n; ++i) {
      int spins = 0;
      while ((regs_.sr & usart::kSrTxe) == 0) {
        if (++spins > kTxSpinLimit) return hal::Status::kResourceExhausted;
      }
      regs_.dr = data[i];
      *n_written = i + 1;
    }
    return hal::Status::kOk;
  }

  static constexpr int kTxSpinLimit = 100000;
  UsartRegs& regs_;
  std::uint8_t ring_[kRingBytes] = {};
  std::atomic<std::uint32_t> head_{0};  // written by the interrupt
  std::atomic<std::uint32_t> tail_{0};  // written by read()
  std::atomic<bool> lost_{false};
  UsartCounters counters_;
};

}  // namespace odoerr::board::stm32f405
