// The board's LMS2xx probe, run under QEMU netduinoplus2: sets up the clock tree, USART1 (the
// laser's line, 500 kbaud 8N1, receive interrupt into the driver's ring), TIM2 and TIM5 in
// encoder mode and TIM3 as the microsecond clock, reads their registers back, then parses
// what arrives on USART1 until the line has been quiet for a while, and writes its report
// (lms_probe_report.hpp) to probe.txt through semihosting. QEMU feeds USART1 from a file the
// host wrote (lms_stream.cpp) once the image has sent its ready byte: as on the chip, bytes
// that arrive before the receiver is enabled are lost. ctest compares the report with the
// host's.
//
// Exit codes: 0 report written; 2 the USART, a timer or the clock refused its set-up; 3 a
// register read back is not what the driver wrote (the peripheral is not where RM0090 puts
// it); 4 probe.txt cannot be written.
#include <cstdint>

#include "lms_probe_report.hpp"
#include "robot_io.hpp"
#include "semihosting.hpp"

namespace st = odoerr::board::stm32f405;

namespace {
st::Stm32UsartPort<2048>* g_laser = nullptr;
// Main-loop passes to wait for the line's first byte, and passes with no new byte after
// which the line is taken as finished.
constexpr std::uint32_t kFirstBytePolls = 400000000u;
constexpr std::uint32_t kQuietPolls = 2000000u;
}  // namespace

extern "C" void USART1_IRQHandler() {
  if (g_laser != nullptr) g_laser->onInterrupt();
}

int main() {
  const st::ClockTree clk = st::configureClocks(st::kHseHz);
  st::enableRobotPeripherals();

  st::UsartRegs& u1 = st::at<st::UsartRegs>(st::kUsart1Base);
  // Objects of main (a static with a destructor would need __cxa_atexit, which the board
  // leaves out): the interrupt reaches the port through g_laser while main runs.
  st::Stm32UsartPort<2048> laser(u1);
  st::GpTimerRegs& t2 = st::at<st::GpTimerRegs>(st::kTim2Base);
  st::GpTimerRegs& t5 = st::at<st::GpTimerRegs>(st::kTim5Base);
  st::Stm32EncoderTimer left(t2);
  st::Stm32EncoderTimer right(t5);
  st::Stm32MicrosecondClock clock(st::at<st::GpTimerRegs>(st::kTim3Base), 16);
  if (laser.configure(clk.pclk2_hz, st::kLaserBaud) != odoerr::hal::Status::kOk ||
      left.configure(3, false) != odoerr::hal::Status::kOk || right.configure(3, true) != odoerr::hal::Status::kOk ||
      clock.configure(clk.tim_apb1_hz) != odoerr::hal::Status::kOk) {
    return 2;
  }
  // Read back: the registers hold what the drivers wrote.
  const bool usart_ok = st::usartReadsBack(u1, clk.pclk2_hz, st::kLaserBaud);
  const bool tim_ok = st::encodersReadBack(t2, t5);
  if (!usart_ok || !tim_ok) return 3;
  std::uint32_t count = 0;
  if (left.read(&count) != odoerr::hal::Status::kOk || right.read(&count) != odoerr::hal::Status::kOk) return 3;

  g_laser = &laser;
  st::enableInterrupt(st::kUsart1Irq);
  // Ready: one byte out on USART1's transmit line, which the test's feeder waits for before
  // it sends the stream (what arrives before the receiver is on is lost, as on the chip).
  const std::uint8_t ready = 'R';
  std::size_t sent = 0;
  if (laser.write(&ready, 1, &sent) != odoerr::hal::Status::kOk) return 2;

  odoerr::drivers::Lms2xxConfig cfg;
  cfg.baud = st::kLaserBaud;
  odoerr::drivers::Lms2xxParser parser(cfg);
  odoerr::board::probe::Tally tally;
  std::uint8_t chunk[64];
  std::uint32_t quiet = 0;
  std::uint32_t lost = 0;
  bool started = false;
  while (quiet < (started ? kQuietPolls : kFirstBytePolls)) {
    std::size_t n = 0;
    if (laser.read(chunk, sizeof chunk, &n) == odoerr::hal::Status::kDataLoss) ++lost;
    if (n == 0) {
      ++quiet;
      continue;
    }
    quiet = 0;
    started = true;
    (void)parser.feed(chunk, n, clock.nowUs());
    odoerr::board::probe::takeScans(parser, &tally);
  }
  u1.cr1 = u1.cr1 & ~st::usart::kCr1RxneIe;  // no interrupt into a port about to go
  g_laser = nullptr;

  char text[512];
  std::size_t len = odoerr::board::probe::report(tally, parser.counters(), text, sizeof text);
  const int h = odoerr::board::shOpen("probe.txt", odoerr::board::FileMode::kWriteBinary);
  if (h < 0) return 4;
  const bool written = odoerr::board::shWrite(h, text, len) == len;
  odoerr::board::shClose(h);
  // Beside the report, for the log: the clock tree reached and the line's losses.
  odoerr::board::shPuts(clk.from_pll ? "lms_probe: 168 MHz from the PLL\n" : "lms_probe: on the 16 MHz HSI (no HSE/PLL ready)\n");
  if (lost != 0 || laser.counters().overruns != 0) odoerr::board::shPuts("lms_probe: bytes were lost on USART1\n");
  return written ? 0 : 4;
}
