// fw_board: the firmware application (fw/app.hpp) on the STM32F405 board, run under QEMU
// netduinoplus2 over a HAL tape (the same drive fw_replay replays on the host and on
// mps2-an386), with the board's own drivers where QEMU models the hardware:
//   - the laser's bytes arrive on USART1 (500 kbaud 8N1) and the receive interrupt puts them
//     in Stm32UsartPort's ring, which the LMS2xx parser reads;
//   - the telemetry frames leave on USART2 (115,200 baud, polled), QEMU's second serial port;
//   - TIM2 and TIM5 are set up in encoder mode and read back; QEMU does not count quadrature
//     edges, so the counts, and the time, come from the tape (the seam, docs/porting.md).
// Pacing (the only test seam on the laser's path): before each poll whose tape record holds
// laser bytes, the board sends one byte, 'N', on USART1's transmit line; the host's feeder
// (firmware/tools/board_feed.py) answers with that poll's bytes, and the board waits until
// the interrupt has put them all in the ring. The application then reads them through the
// driver, as the host's replay reads them from the tape.
//
// Exit codes: fw_replay.hpp's (0 success; 3, 5, 6), 10 no tape, 2 not a HAL tape; 12 a
// peripheral refused its set-up; 13 a register read back is not what the driver wrote; 14 the
// laser's bytes did not arrive through USART1 as sent (an overrun, a full ring or a line error
// counted, a request not sent, or a poll's bytes left unread).
#include <cstddef>
#include <cstdint>

#include "fw_replay/fw_replay.hpp"
#include "robot_io.hpp"
#include "semihosting.hpp"

namespace st = odoerr::board::stm32f405;
namespace fr = odoerr::fw_replay;
using odoerr::hal::Status;

namespace {

using LaserPort = st::Stm32UsartPort<1024>;
LaserPort* g_laser = nullptr;

/// The laser's bytes of each poll through USART1 (see the file's comment).
class UsartFeed {
 public:
  explicit UsartFeed(LaserPort& port) : port_(port) {}
  odoerr::hal::SerialPort& port() { return port_; }
  /// The tape's copy of a poll's bytes is not used: they come through the USART.
  std::uint8_t* receive(std::size_t n) { return n <= sizeof discard_ ? discard_ : nullptr; }
  bool deliver(std::size_t n) {
    if (port_.pending() != 0) {
      unread_ = true;  // the application left bytes of an earlier poll in the ring
      return false;
    }
    if (n == 0) return true;
    const std::uint8_t request = 'N';
    std::size_t sent = 0;
    if (port_.write(&request, 1, &sent) != Status::kOk || sent != 1) return false;
    waitFor(n);
    return port_.pending() == n;
  }
  bool unread() const { return unread_; }

 private:
  /// Spins until the ring holds n bytes. A function of its own, so that the footprint's
  /// instruction count can leave the wait out (firmware/tools/board_footprint.py).
  __attribute__((noinline)) void waitFor(std::size_t n) {
    while (port_.pending() < n) {
    }
  }

  LaserPort& port_;
  inline static std::uint8_t discard_[1024];  // in .bss, not on the stack
  bool unread_ = false;
};

/// Telemetry frames out on USART2's transmit line (polled).
class UsartTelemetry final : public odoerr::hal::TelemetrySink {
 public:
  explicit UsartTelemetry(st::Stm32UsartPort<2>& port) : port_(port) {}

 private:
  Status DoSend(const std::uint8_t* frame, std::size_t n) override {
    std::size_t sent = 0;
    const Status s = port_.write(frame, n, &sent);
    return s == Status::kOk && sent == n ? Status::kOk : Status::kResourceExhausted;
  }
  st::Stm32UsartPort<2>& port_;
};

bool lossCounted(const st::UsartCounters& c) {
  return c.overruns != 0 || c.ring_full != 0 || c.framing_errors != 0 || c.noise_errors != 0 || c.parity_errors != 0;
}

}  // namespace

extern "C" void USART1_IRQHandler() {
  if (g_laser != nullptr) g_laser->onInterrupt();
}

int main() {
  const st::ClockTree clk = st::configureClocks(st::kHseHz);
  st::enableRobotPeripherals();
  st::UsartRegs& u1 = st::at<st::UsartRegs>(st::kUsart1Base);
  st::UsartRegs& u2 = st::at<st::UsartRegs>(st::kUsart2Base);
  st::GpTimerRegs& t2 = st::at<st::GpTimerRegs>(st::kTim2Base);
  st::GpTimerRegs& t5 = st::at<st::GpTimerRegs>(st::kTim5Base);
  // Objects of main (a static with a destructor would need __cxa_atexit, which the board
  // leaves out): the interrupt reaches the port through g_laser while main runs.
  LaserPort laser(u1);
  st::Stm32UsartPort<2> telemetry_port(u2);  // transmit only: its interrupt stays off in the NVIC
  st::Stm32EncoderTimer left(t2);
  st::Stm32EncoderTimer right(t5);
  if (laser.configure(clk.pclk2_hz, st::kLaserBaud) != Status::kOk ||
      telemetry_port.configure(clk.pclk1_hz, st::kTelemetryBaud) != Status::kOk ||
      left.configure(3, false) != Status::kOk || right.configure(3, true) != Status::kOk) {
    return 12;
  }
  if (!st::usartReadsBack(u1, clk.pclk2_hz, st::kLaserBaud) ||
      !st::usartReadsBack(u2, clk.pclk1_hz, st::kTelemetryBaud) || !st::encodersReadBack(t2, t5)) {
    return 13;
  }

  const int in = odoerr::replay_io::openRead("haltape.bin");
  if (in < 0) return 10;
  odoerr::fw::HalTapeHeader h;
  if (!fr::readHeader(in, &h)) return 2;

  g_laser = &laser;
  st::enableInterrupt(st::kUsart1Irq);
  UsartFeed feed(laser);
  UsartTelemetry tm(telemetry_port);
  const int rc = h.drive == 0 ? fr::run<odoerr::SyncDrive>(in, h, feed, tm) : fr::run<odoerr::DiffDrive>(in, h, feed, tm);
  u1.cr1 = u1.cr1 & ~st::usart::kCr1RxneIe;  // no interrupt into a port about to go
  g_laser = nullptr;
  if (rc == fr::kFeedFailed || lossCounted(laser.counters())) {
    odoerr::board::shPuts(feed.unread() ? "fw_board: a poll's laser bytes were left unread\n"
                                        : "fw_board: USART1 lost bytes, or a request could not be sent\n");
    return 14;
  }
  if (rc != fr::kOk) return rc;
  odoerr::board::shPuts(clk.from_pll ? "fw_board: 168 MHz from the PLL\n" : "fw_board: on the 16 MHz HSI (no HSE/PLL ready)\n");
  return rc;
}
