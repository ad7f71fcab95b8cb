// The STM32F405 board's drivers (firmware/board/stm32f405/) on the host: each is given a
// register block in RAM, and the test plays the hardware's side (sets SR, DR, CNT) and reads
// back what the driver wrote. The values checked are the reference manual's (RM0090).
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "calibration_test_util.hpp"
#include "odoerr/drivers/calibration_store.hpp"
#include "odoerr/drivers/lms2xx.hpp"
#include "odoerr/sim/lms2xx_writer.hpp"
#include "stm32_flash.hpp"
#include "stm32_flash_model.hpp"
#include "stm32_timers.hpp"
#include "stm32_usart.hpp"

namespace {

namespace st = odoerr::board::stm32f405;
using odoerr::hal::Status;

// The hardware's side of a received byte: DR holds it and SR.RXNE is set, then the interrupt.
template <typename Port>
void receive(st::UsartRegs& regs, Port& port, std::uint8_t byte, std::uint32_t extra_sr = 0) {
  regs.dr = byte;
  regs.sr = st::usart::kSrRxne | st::usart::kSrTxe | extra_sr;
  port.onInterrupt();
  regs.sr = st::usart::kSrTxe;  // the read of DR cleared RXNE and the error flags
}

TEST(Stm32Usart, ConfiguresEightN1At500KbaudFrom84MHz) {
  st::UsartRegs regs{};
  st::Stm32UsartPort<64> port(regs);
  ASSERT_EQ(port.configure(84000000u, 500000u), Status::kOk);
  EXPECT_EQ(regs.brr, 0xA8u);  // USARTDIV 10.5: mantissa 10, fraction 8
  EXPECT_EQ(regs.cr1, 0x202Cu);  // UE | RXNEIE | TE | RE; M = 0 (8 bits), no parity, OVER8 = 0
  EXPECT_EQ(regs.cr2, 0u);       // one stop bit
  EXPECT_EQ(regs.cr3, 0x1u);     // EIE
  // A rate the divider cannot reach is refused, and nothing is enabled.
  st::UsartRegs other{};
  st::Stm32UsartPort<64> slow(other);
  EXPECT_EQ(slow.configure(84000000u, 10000000u), Status::kInvalidArgument);
  EXPECT_EQ(other.cr1, 0u);
}

TEST(Stm32Usart, BytesArriveInOrderAcrossTheRingsWrap) {
  st::UsartRegs regs{};
  st::Stm32UsartPort<16> port(regs);
  ASSERT_EQ(port.configure(84000000u, 500000u), Status::kOk);
  std::vector<std::uint8_t> sent, got;
  std::uint8_t buf[8];
  for (int round = 0; round < 10; ++round) {
    for (int i = 0; i < 11; ++i) {
      const auto b = static_cast<std::uint8_t>(round * 11 + i);
      sent.push_back(b);
      receive(regs, port, b);
    }
    std::size_t n = 0;
    do {
      ASSERT_EQ(port.read(buf, sizeof buf, &n), Status::kOk);
      got.insert(got.end(), buf, buf + n);
    } while (n > 0);
  }
  EXPECT_EQ(got, sent);
  EXPECT_EQ(port.counters().bytes_received, 110u);
  EXPECT_EQ(port.pending(), 0u);
}

TEST(Stm32Usart, AnOverrunIsReportedOnceWithTheBytesThatCame) {
  st::UsartRegs regs{};
  st::Stm32UsartPort<16> port(regs);
  ASSERT_EQ(port.configure(84000000u, 500000u), Status::kOk);
  receive(regs, port, 1);
  receive(regs, port, 2, st::usart::kSrOre);  // a byte was lost before this one
  std::uint8_t buf[4];
  std::size_t n = 0;
  EXPECT_EQ(port.read(buf, sizeof buf, &n), Status::kDataLoss);
  ASSERT_EQ(n, 2u);
  EXPECT_EQ(buf[0], 1);
  EXPECT_EQ(buf[1], 2);
  EXPECT_EQ(port.read(buf, sizeof buf, &n), Status::kOk);  // said once
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(port.counters().overruns, 1u);
  // ORE without RXNE: DR is read to clear it, nothing is queued, the loss is still said.
  regs.dr = 0x55;
  regs.sr = st::usart::kSrOre;
  port.onInterrupt();
  EXPECT_EQ(port.read(buf, sizeof buf, &n), Status::kDataLoss);
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(port.counters().overruns, 2u);
}

TEST(Stm32Usart, AFullRingDropsAndCountsNeverOverwrites) {
  st::UsartRegs regs{};
  st::Stm32UsartPort<8> port(regs);
  ASSERT_EQ(port.configure(84000000u, 500000u), Status::kOk);
  for (int i = 0; i < 12; ++i) receive(regs, port, static_cast<std::uint8_t>(i));
  EXPECT_EQ(port.counters().ring_full, 4u);
  std::uint8_t buf[16];
  std::size_t n = 0;
  EXPECT_EQ(port.read(buf, sizeof buf, &n), Status::kDataLoss);
  ASSERT_EQ(n, 8u);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(buf[i], i);  // the first eight, untouched
}

TEST(Stm32Usart, LineErrorsAreCountedAndTheBytesKept) {
  st::UsartRegs regs{};
  st::Stm32UsartPort<8> port(regs);
  ASSERT_EQ(port.configure(84000000u, 500000u), Status::kOk);
  receive(regs, port, 7, st::usart::kSrFe);
  receive(regs, port, 8, st::usart::kSrNf);
  receive(regs, port, 9, st::usart::kSrPe);
  EXPECT_EQ(port.counters().framing_errors, 1u);
  EXPECT_EQ(port.counters().noise_errors, 1u);
  EXPECT_EQ(port.counters().parity_errors, 1u);
  std::uint8_t buf[8];
  std::size_t n = 0;
  EXPECT_EQ(port.read(buf, sizeof buf, &n), Status::kOk);
  EXPECT_EQ(n, 3u);
  // An interrupt with nothing received (TXE only) queues nothing.
  regs.sr = st::usart::kSrTxe;
  port.onInterrupt();
  EXPECT_EQ(port.pending(), 0u);
}

TEST(Stm32Usart, WritesWaitForTxeAndGiveUpOnAStuckTransmitter) {
  st::UsartRegs regs{};
  st::Stm32UsartPort<8> port(regs);
  ASSERT_EQ(port.configure(84000000u, 500000u), Status::kOk);
  const std::uint8_t msg[3] = {0x02, 0x00, 0x20};
  std::size_t n = 0;
  regs.sr = st::usart::kSrTxe;
  EXPECT_EQ(port.write(msg, 3, &n), Status::kOk);
  EXPECT_EQ(n, 3u);
  EXPECT_EQ(regs.dr, 0x20u);  // the last byte written
  regs.sr = 0;  // TXE never comes
  EXPECT_EQ(port.write(msg, 3, &n), Status::kResourceExhausted);
  EXPECT_EQ(n, 0u);
}

// LMS2xx telegrams (the host simulator's encoder) byte by byte through the USART's receive
// interrupt, the parser polling the port between bytes as the main loop would: every scan
// arrives with its ranges; a byte lost to an overrun costs that telegram only, and is said.
TEST(Stm32Usart, Lms2xxTelegramsThroughTheReceiverReachTheParser) {
  st::UsartRegs regs{};
  st::Stm32UsartPort<1024> port(regs);
  ASSERT_EQ(port.configure(84000000u, 500000u), Status::kOk);
  odoerr::drivers::Lms2xxParser parser;
  double ranges[181];
  float got[odoerr::drivers::Lms2xxParser::kMaxValues];
  std::uint8_t tel[1024];
  int scans = 0;
  std::uint64_t now_us = 0;
  for (int k = 0; k < 6; ++k) {
    for (int i = 0; i < 181; ++i) ranges[i] = 1.0 + 0.01 * i + 0.1 * k;
    const std::size_t n = odoerr::sim::encodeLms2xxScan(ranges, 181, true, tel, sizeof tel);
    ASSERT_GT(n, 0u);
    for (std::size_t b = 0; b < n; ++b) {
      // Telegram 3 loses its 100th byte in the hardware: the next byte comes with ORE.
      if (k == 3 && b == 100) continue;
      receive(regs, port, tel[b], (k == 3 && b == 101) ? st::usart::kSrOre : 0u);
      now_us += 20;  // 10 bits at 500 kbaud
      if (b % 64 == 63 || b + 1 == n) {
        const Status ps = parser.poll(port, now_us);
        EXPECT_TRUE(ps == Status::kOk || (k == 3 && ps == Status::kDataLoss)) << int(ps);
      }
    }
    odoerr::drivers::Lms2xxParser::ScanInfo info;
    if (parser.takeScan(got, odoerr::drivers::Lms2xxParser::kMaxValues, &info) == Status::kOk) {
      ++scans;
      ASSERT_EQ(info.count, 181);
      for (int i = 0; i < 181; ++i) EXPECT_NEAR(got[i], ranges[i], 0.0006) << "scan " << k << " beam " << i;
    } else {
      EXPECT_EQ(k, 3) << "only the damaged telegram may be missing";
    }
  }
  EXPECT_EQ(scans, 5);
  EXPECT_EQ(port.counters().overruns, 1u);
  EXPECT_EQ(parser.counters().uart_overruns, 1u);
}

TEST(Stm32EncoderTimer, SetsEncoderMode3AndReadsTheCounter) {
  st::GpTimerRegs regs{};
  st::Stm32EncoderTimer enc(regs);
  std::uint32_t count = 0;
  EXPECT_EQ(enc.read(&count), Status::kUnavailable);  // not configured yet
  ASSERT_EQ(enc.configure(3, false), Status::kOk);
  EXPECT_EQ(regs.smcr & 0x7u, 0x3u);  // SMS = 011
  EXPECT_EQ(regs.ccmr1, 0x3131u);     // CC1S = 01, IC1F = 3, CC2S = 01, IC2F = 3
  EXPECT_EQ(regs.ccer, 0u);
  EXPECT_EQ(regs.arr, 0xFFFFFFFFu);
  EXPECT_EQ(regs.cr1 & 0x1u, 0x1u);  // CEN
  EXPECT_EQ(enc.bits(), 32);
  regs.cnt = 0xFFFFFFF0u;  // the hardware counted backwards through zero
  ASSERT_EQ(enc.read(&count), Status::kOk);
  EXPECT_EQ(count, 0xFFFFFFF0u);
  // Inverted direction: CC1P.
  st::GpTimerRegs r2{};
  st::Stm32EncoderTimer inv(r2);
  ASSERT_EQ(inv.configure(0, true), Status::kOk);
  EXPECT_EQ(r2.ccer, 0x2u);
  EXPECT_EQ(inv.configure(16, false), Status::kInvalidArgument);
}

TEST(Stm32EncoderTimer, ALostSetUpIsAFaultNotACount) {
  st::GpTimerRegs regs{};
  st::Stm32EncoderTimer enc(regs);
  ASSERT_EQ(enc.configure(0, false), Status::kOk);
  std::uint32_t count = 7;
  regs.cr1 = 0;  // a peripheral reset stopped the counter
  EXPECT_EQ(enc.read(&count), Status::kInternal);
  EXPECT_EQ(count, 7u);
  regs.cr1 = 1;
  regs.smcr = 0;  // the slave mode was lost
  EXPECT_EQ(enc.read(&count), Status::kInternal);
}

TEST(Stm32MicrosecondClock, SixteenBitTimerExtendedThroughItsWraps) {
  st::GpTimerRegs regs{};
  st::Stm32MicrosecondClock clock(regs, 16);
  ASSERT_EQ(clock.configure(84000000u), Status::kOk);
  EXPECT_EQ(regs.arr, 0xFFFFu);
  std::uint64_t expected = 0;
  std::uint32_t cnt = 0;
  for (int i = 0; i < 1000; ++i) {  // steps below one wrap, about 33 s in all
    const std::uint32_t step = 1000u + static_cast<std::uint32_t>(i) * 61u;
    cnt = (cnt + step) & 0xFFFFu;
    expected += step;
    regs.cnt = cnt;
    ASSERT_EQ(clock.nowUs(), expected) << "read " << i;
  }
}

TEST(Stm32MicrosecondClock, OneMegahertzAndNeverBackwardsThroughTheWrap) {
  st::GpTimerRegs regs{};
  st::Stm32MicrosecondClock clock(regs, 32);
  ASSERT_EQ(clock.configure(84000000u), Status::kOk);
  EXPECT_EQ(regs.psc, 83u);  // 84 MHz / 84 = 1 MHz
  EXPECT_EQ(regs.arr, 0xFFFFFFFFu);
  EXPECT_EQ(clock.configure(84500000u), Status::kInvalidArgument);
  regs.cnt = 1000;
  EXPECT_EQ(clock.nowUs(), 1000u);
  regs.cnt = 0xFFFFFF00u;
  EXPECT_EQ(clock.nowUs(), 0xFFFFFF00u);
  regs.cnt = 0x100u;  // wrapped
  EXPECT_EQ(clock.nowUs(), 0x100000100ull);
  regs.cnt = 0x200u;
  EXPECT_EQ(clock.nowUs(), 0x100000200ull);
}

// --- the parameter store on the chip's flash, against the model of its controller ---------

using FlashModel = st::test::Stm32FlashModel;
using FlashStore = st::Stm32FlashParamStore<FlashModel>;
using odoerr::drivers::Calibration;
using odoerr::drivers::CalibrationStore;
using odoerr::drivers::LoadResult;
using odoerr::test::makeCal;
using odoerr::test::same;

TEST(Stm32Flash, EraseProgramAndReadUnderTheControllersRules) {
  FlashModel m;
  FlashStore fs(m);
  EXPECT_EQ(fs.size(), 32768u);
  EXPECT_EQ(fs.sectorSize(), 16384u);
  const std::uint8_t data[4] = {0x12, 0x34, 0x00, 0xFF};
  ASSERT_EQ(fs.program(100, data, 4), Status::kOk);
  EXPECT_NE(m.cr() & st::flash::kCrLock, 0u);  // locked again after the operation
  std::uint8_t back[4];
  ASSERT_EQ(fs.read(100, back, 4), Status::kOk);
  EXPECT_EQ(std::vector<std::uint8_t>(back, back + 4), std::vector<std::uint8_t>(data, data + 4));
  // Only bits cleared: a byte that needs a 1 again is refused, and nothing is written.
  const std::uint8_t again[2] = {0x10, 0x35};
  EXPECT_EQ(fs.program(100, again, 2), Status::kFailedPrecondition);
  EXPECT_EQ(m.raw(100), 0x12);
  // Erase sector 1 of the store (the chip's sector 2): 0xFF there, sector 0 of the store untouched.
  ASSERT_EQ(fs.program(16384 + 5, data, 1), Status::kOk);
  ASSERT_EQ(fs.erase(1), Status::kOk);
  EXPECT_EQ(m.raw(16384 + 5), 0xFF);
  EXPECT_EQ(m.raw(100), 0x12);
  EXPECT_EQ(fs.erase(2), Status::kOutOfRange);
  EXPECT_NE(m.cr() & st::flash::kCrLock, 0u);
}

TEST(Stm32Flash, AnErrorFlagOrAControllerLockedUntilResetIsAFault) {
  FlashModel m;
  FlashStore fs(m);
  const std::uint8_t b = 0x00;
  m.failWith(st::flash::kSrPgperr);  // a flag left from before is cleared first, not reported
  EXPECT_EQ(fs.program(0, &b, 1), Status::kOk);
  // A wrong key sequence (a stray write) locks FLASH_CR until reset: every operation fails.
  m.key(0x12345678u);
  EXPECT_EQ(fs.program(1, &b, 1), Status::kInternal);
  EXPECT_EQ(fs.erase(0), Status::kInternal);
  EXPECT_EQ(m.raw(1), 0xFF);
  m.powerOn();
  EXPECT_EQ(fs.program(1, &b, 1), Status::kOk);
  EXPECT_EQ(m.raw(1), 0x00);
}

// The calibration store's guarantee on this board: power lost at any byte-operation of a
// save leaves the previous record or the new one, never nothing and never a mixture.
TEST(Stm32Flash, PowerLostAtEveryStepOfASaveKeepsARecord) {
  const Calibration A = makeCal(1, 1.0f), B = makeCal(1, 2.0f);
  FlashModel with_a;
  {
    FlashStore fs(with_a);
    CalibrationStore cs(fs);
    Calibration out{};
    EXPECT_EQ(cs.load(&out), LoadResult::kNoneFound);
    ASSERT_EQ(cs.save(A), Status::kOk);
  }
  std::size_t full = 0;
  {
    FlashModel m = with_a;
    FlashStore fs(m);
    CalibrationStore cs(fs);
    Calibration out{};
    ASSERT_EQ(cs.load(&out), LoadResult::kRestored);
    const std::size_t before = m.byteOps();
    ASSERT_EQ(cs.save(B), Status::kOk);
    full = m.byteOps() - before;
  }
  ASSERT_GT(full, 10u);
  int old_kept = 0, new_kept = 0;
  for (std::size_t k = 0; k <= full; ++k) {
    FlashModel m = with_a;
    Status saved;
    {
      FlashStore fs(m);
      CalibrationStore cs(fs);
      Calibration out{};
      ASSERT_EQ(cs.load(&out), LoadResult::kRestored);
      m.powerLossAfter(k);
      saved = cs.save(B);
    }
    if (k < full) {
      EXPECT_NE(saved, Status::kOk) << "k " << k;
      EXPECT_FALSE(m.poweredOn());
    } else {
      EXPECT_EQ(saved, Status::kOk);
    }
    m.powerOn();  // the reset after the power comes back
    FlashStore fs(m);
    CalibrationStore cs(fs);
    Calibration out{};
    ASSERT_EQ(cs.load(&out), LoadResult::kRestored) << "calibration lost at k " << k;
    if (same(out, B)) {
      ++new_kept;
    } else {
      ASSERT_TRUE(same(out, A)) << "a mixture at k " << k;
      EXPECT_NE(saved, Status::kOk);
      ++old_kept;
    }
  }
  EXPECT_GT(old_kept, 0);
  EXPECT_GE(new_kept, 1);
}

}  // namespace
