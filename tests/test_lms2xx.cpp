// SICK LMS2xx telegram parser (firmware) against the host writer and published telegrams:
// CRC, round trips, value words, time stamps, the API, and no heap while parsing. Format,
// CRC and resync rules: odoerr/drivers/lms2xx.hpp. Line damage: test_lms2xx_damage.cpp.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <limits>
#include <new>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "lms2xx_support.hpp"
#include "odoerr/drivers/lms2xx.hpp"
#include "odoerr/sim/lms2xx_writer.hpp"

#include "heap_counter.hpp"  // the counting operator new, armed around the code under test

using odoerr::test::g_heap_allocs;
using odoerr::test::g_heap_armed;

using namespace odoerr::lms2xx_test;

// --- CRC ----------------------------------------------------------------------------------

// Telegrams published byte for byte by several independent LMS2xx projects (host requests,
// address 0x00) and one scanner reply (address 0x80, ACK of a mode change, status 0x10).
TEST(Lms2xxCrc, PublishedTelegramsGoldenVectors) {
  const std::vector<Bytes> host = {
      {0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08},  // start continuous output
      {0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08},  // stop continuous output
      {0x02, 0x00, 0x02, 0x00, 0x30, 0x01, 0x31, 0x18},  // send measured values once
      {0x02, 0x00, 0x02, 0x00, 0x20, 0x42, 0x52, 0x08},  // 9600 baud
      {0x02, 0x00, 0x02, 0x00, 0x20, 0x48, 0x58, 0x08},  // 500 kbaud
      {0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12},        // status request (LEN 1: CMD only)
      {0x02, 0x00, 0x05, 0x00, 0x3B, 0xB4, 0x00, 0x32, 0x00, 0x3B, 0x1F},  // 180 deg, 0.5 deg
  };
  const Bytes reply = {0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A};
  std::vector<Bytes> all = host;
  all.push_back(reply);
  for (const Bytes& t : all) {
    const std::uint16_t want = le16(&t[t.size() - 2]);
    EXPECT_EQ(Lms2xxParser::crc16(t.data(), t.size() - 2), want);
    EXPECT_EQ(odoerr::sim::lms2xxCrc16(t.data(), t.size() - 2), want);
    // LEN counts CMD .. last byte before the CRC.
    EXPECT_EQ(static_cast<std::size_t>(le16(&t[2])) + 6, t.size());
  }
  // The writer reproduces a published telegram exactly.
  EXPECT_EQ(telegram(0x00, 0x20, {0x24}), host[0]);
  EXPECT_EQ(telegram(0x80, 0xA0, {0x00, 0x10}), reply);

  // The parser accepts them as (non-scan) telegrams at the matching address.
  Lms2xxConfig host_cfg;
  host_cfg.expected_address = 0x00;
  Lms2xxParser ph(host_cfg);
  for (const Bytes& t : host) EXPECT_FALSE(feedAll(ph, t));
  EXPECT_EQ(ph.counters().other_telegrams, host.size());
  EXPECT_EQ(ph.counters().bad_crc, 0u);
  EXPECT_EQ(ph.counters().bytes_discarded, 0u);

  Lms2xxParser pr;
  Bytes with_ack = {0x06};  // the scanner's ACK byte precedes its reply on the line
  with_ack.insert(with_ack.end(), reply.begin(), reply.end());
  EXPECT_FALSE(feedAll(pr, with_ack));
  EXPECT_EQ(pr.counters().other_telegrams, 1u);
  EXPECT_EQ(pr.counters().bytes_discarded, 1u);
  EXPECT_FALSE(pr.scanAvailable());
}

TEST(Lms2xxCrc, ParserAndWriterImplementationsAgree) {
  std::mt19937 rng(7);
  for (int k = 0; k < 200; ++k) {
    Bytes b(static_cast<std::size_t>(rng() % 900));
    for (auto& x : b) x = static_cast<std::uint8_t>(rng());
    ASSERT_EQ(Lms2xxParser::crc16(b.data(), b.size()), odoerr::sim::lms2xxCrc16(b.data(), b.size()));
  }
}

// A real 361-value reply starts 02 80 D6 02 B0 69 01 (published): LEN 726, cm.
TEST(Lms2xxWriter, MatchesARealScannerHeader) {
  const Bytes cm = scanFrame(ranges(361, 1), false);
  ASSERT_EQ(cm.size(), 732u);
  EXPECT_EQ(Bytes(cm.begin(), cm.begin() + 7), (Bytes{0x02, 0x80, 0xD6, 0x02, 0xB0, 0x69, 0x01}));
  const Bytes mm = scanFrame(ranges(361, 1), true);
  EXPECT_EQ(Bytes(mm.begin(), mm.begin() + 7), (Bytes{0x02, 0x80, 0xD6, 0x02, 0xB0, 0x69, 0x41}));
  EXPECT_EQ(mm[mm.size() - 3], 0x10);  // status
  std::uint8_t small[10];
  EXPECT_EQ(odoerr::sim::encodeLms2xxScan(nullptr, 0, true, small, sizeof small), 10u);
  EXPECT_EQ(odoerr::sim::encodeLms2xxScan(nullptr, 1, true, small, sizeof small), 0u);
}

// --- round trip -----------------------------------------------------------------------------

TEST(Lms2xxParser, RoundTripMillimetres) {
  std::vector<double> r = ranges(361, 2);
  r[0] = 0.0;
  r[1] = 8.182;                                      // largest distance
  r[2] = 8.1826;                                     // rounds to 8183 = no-return code
  r[3] = std::numeric_limits<double>::quiet_NaN();   // no return
  r[4] = 30.0;                                       // out of range
  r[5] = -0.5;                                       // invalid
  r[6] = std::numeric_limits<double>::infinity();
  r[7] = 1.0004;
  r[8] = 1.0006;
  Lms2xxParser p;
  EXPECT_TRUE(feedAll(p, scanFrame(r, true)));
  Taken t;
  ASSERT_TRUE(take(p, &t));
  expectRanges(r, t.r, true);
  EXPECT_EQ(t.r[7], 1.000f);
  EXPECT_EQ(t.r[8], 1.001f);
  EXPECT_EQ(t.info.count, 361);
  EXPECT_TRUE(t.info.unit_mm);
  EXPECT_EQ(t.info.status, 0x10);
  EXPECT_FALSE(t.info.partial);
  EXPECT_FALSE(t.info.has_realtime_index);
  EXPECT_EQ(t.info.sequence, 1u);
  EXPECT_EQ(p.counters().frames_ok, 1u);
  EXPECT_EQ(p.counters().bytes_discarded, 0u);
  EXPECT_EQ(p.pendingBytes(), 0u);
  expectBalance(p);
}

TEST(Lms2xxParser, RoundTripCentimetresAndSizes) {
  for (int n : {0, 1, 21, 181, 361, 401}) {
    std::vector<double> r = ranges(n, n);
    for (auto& v : r) v *= 10.0;  // up to 80 m
    if (n > 2) r[1] = 81.82;
    if (n > 3) r[2] = 81.83;
    Lms2xxParser p;
    EXPECT_TRUE(feedAll(p, scanFrame(r, false)));
    Taken t;
    ASSERT_TRUE(take(p, &t)) << n;
    EXPECT_FALSE(t.info.unit_mm);
    expectRanges(r, t.r, false);
  }
}

// --- value words ----------------------------------------------------------------------------

TEST(Lms2xxParser, FlagBitsAndNoReturnCodesBecomeNaN) {
  const std::vector<std::uint16_t> w = {
      1000,           // 1.000 m
      1000 | 0x2000,  // field A: distance kept
      1000 | 0x4000,  // field B: distance kept
      1000 | 0x8000,  // dazzle (mode 0x00) -> NaN
      0x1FF6,         // 8.182 m, the largest distance
      0x1FF7, 0x1FF8, 0x1FFA, 0x1FFB, 0x1FFD, 0x1FFE, 0x1FFF,  // codes -> NaN
      0,              // 0 m
      0x3FF6, 0x3FF7, 0x7FF6, 0x7FF7};
  {
    Lms2xxParser p;  // default mode 0x00: 13-bit distance
    ASSERT_TRUE(feedAll(p, rawB0(0x4000 | static_cast<std::uint16_t>(w.size()), w)));
    Taken t;
    ASSERT_TRUE(take(p, &t));
    EXPECT_EQ(t.r[0], 1.0f);
    EXPECT_EQ(t.r[1], 1.0f);
    EXPECT_EQ(t.r[2], 1.0f);
    EXPECT_TRUE(std::isnan(t.r[3]));
    EXPECT_EQ(t.r[4], 8.182f);
    for (int i = 5; i <= 11; ++i) EXPECT_TRUE(std::isnan(t.r[static_cast<std::size_t>(i)])) << i;
    EXPECT_EQ(t.r[12], 0.0f);
    // 0x3FF6 = field A + 0x1FF6; 0x3FF7 = field A + no-return code.
    EXPECT_EQ(t.r[13], 8.182f);
    EXPECT_TRUE(std::isnan(t.r[14]));
    EXPECT_EQ(t.r[15], 8.182f);        // 0x7FF6: fields A and B set, no dazzle
    EXPECT_TRUE(std::isnan(t.r[16]));  // 0x7FF7: fields A, B + no-return code
  }
  {
    Lms2xxConfig cfg;
    cfg.mode = Lms2xxMeasuringMode::kRange16mFieldsAB;  // 14-bit distance, bits 14/15 fields
    Lms2xxParser p(cfg);
    ASSERT_TRUE(feedAll(p, rawB0(0x4000 | static_cast<std::uint16_t>(w.size()), w)));
    Taken t;
    ASSERT_TRUE(take(p, &t));
    EXPECT_EQ(t.r[1], 9.192f);  // bit 13 is a distance bit here
    EXPECT_EQ(t.r[3], 1.0f);    // bit 15 is field B, not dazzle
    EXPECT_EQ(t.r[5], 8.183f);  // 0x1FF7 is a distance in the 16 m modes
    EXPECT_EQ(t.r[11], 8.191f);
    EXPECT_EQ(t.r[13], 16.374f);
    EXPECT_TRUE(std::isnan(t.r[14]));
    EXPECT_EQ(t.r[15], 16.374f);  // 0x7FF6 & 0x3FFF, field A
  }
  {
    Lms2xxConfig cfg;
    cfg.mode = Lms2xxMeasuringMode::kRange32mReflector;  // 15-bit distance
    Lms2xxParser p(cfg);
    ASSERT_TRUE(feedAll(p, rawB0(0x4000 | static_cast<std::uint16_t>(w.size()), w)));
    Taken t;
    ASSERT_TRUE(take(p, &t));
    EXPECT_EQ(t.r[14], 16.375f);
    EXPECT_EQ(t.r[15], 32.758f);
    EXPECT_EQ(t.r[3], 1.0f);  // reflector bit
  }
  {
    Lms2xxParser p;  // cm: 0x1FF6 = 81.82 m
    ASSERT_TRUE(feedAll(p, rawB0(3, {0x1FF6, 0x1FF7, 150})));
    Taken t;
    ASSERT_TRUE(take(p, &t));
    EXPECT_EQ(t.r[0], 81.82f);
    EXPECT_TRUE(std::isnan(t.r[1]));
    EXPECT_EQ(t.r[2], 1.5f);
  }
}

TEST(Lms2xxParser, CountWordBitsUnitsAndRealTimeIndex) {
  const std::vector<std::uint16_t> w(21, 500);
  {
    Lms2xxParser p;  // partial scan 2 (0.5 deg offset), mm
    ASSERT_TRUE(feedAll(p, rawB0(0x4000 | 0x2000 | (2u << 11) | 21, w)));
    Taken t;
    ASSERT_TRUE(take(p, &t));
    EXPECT_TRUE(t.info.partial);
    EXPECT_EQ(t.info.partial_index, 2);
    EXPECT_TRUE(t.info.unit_mm);
    EXPECT_EQ(t.r[0], 0.5f);
  }
  {
    Lms2xxParser p;  // with a real-time index: LEN = 5 + 2n
    ASSERT_TRUE(feedAll(p, rawB0(21, w, 0xA7)));
    Taken t;
    ASSERT_TRUE(take(p, &t));
    EXPECT_TRUE(t.info.has_realtime_index);
    EXPECT_EQ(t.info.realtime_index, 0xA7);
    EXPECT_EQ(t.info.count, 21);
    EXPECT_EQ(t.r[20], 5.0f);  // cm
  }
  for (std::uint16_t unit : {0x8000, 0xC000}) {  // undefined unit codes
    Lms2xxParser p;
    EXPECT_FALSE(feedAll(p, rawB0(unit | 21, w)));
    EXPECT_EQ(p.counters().bad_unit, 1u);
    EXPECT_EQ(p.counters().frames_ok, 0u);
  }
}

// --- time stamps ----------------------------------------------------------------------------

TEST(Lms2xxParser, TimestampIsArrivalMinusTransmissionTime) {
  const Bytes f = scanFrame(ranges(361, 9), true);  // 732 bytes
  ASSERT_EQ(f.size(), 732u);
  Taken t;
  {
    Lms2xxParser p;  // 38400 baud: 732 * 10 / 38400 s = 190625 us exactly
    feedAll(p, f, 5000000);
    ASSERT_TRUE(take(p, &t));
    EXPECT_EQ(t.info.stamp_us, 5000000u - 190625u);
  }
  {
    Lms2xxConfig cfg;
    cfg.latency_us = 2000;
    Lms2xxParser p(cfg);
    feedAll(p, f, 5000000);
    ASSERT_TRUE(take(p, &t));
    EXPECT_EQ(t.info.stamp_us, 5000000u - 190625u - 2000u);
  }
  {
    Lms2xxParser p;  // 20 more bytes after the telegram in the same chunk: 752 bytes of line
    feedAll(p, cat({f, Bytes(20, 0x00)}), 5000000);
    ASSERT_TRUE(take(p, &t));
    EXPECT_EQ(t.info.stamp_us, 5000000u - 195833u);  // 7520000000 / 38400 = 195833.3
  }
  {
    Lms2xxParser p;  // split: the stamp depends on the chunk holding the last byte
    EXPECT_FALSE(p.feed(f.data(), 500, 123));
    EXPECT_TRUE(p.feed(f.data() + 500, f.size() - 500, 7000000));
    ASSERT_TRUE(take(p, &t));
    EXPECT_EQ(t.info.stamp_us, 7000000u - 190625u);
  }
  {
    Lms2xxConfig cfg;
    cfg.baud = 500000;  // 732 * 10 / 500000 s = 14640 us
    Lms2xxParser p(cfg);
    feedAll(p, f, 1000000);
    ASSERT_TRUE(take(p, &t));
    EXPECT_EQ(t.info.stamp_us, 1000000u - 14640u);
  }
  {
    Lms2xxParser p;  // earlier than the transmission time: clamped
    feedAll(p, f, 1000);
    ASSERT_TRUE(take(p, &t));
    EXPECT_EQ(t.info.stamp_us, 0u);
  }
}

// --- API --------------------------------------------------------------------------------

TEST(Lms2xxParser, OverwriteTakeAndOtherTelegrams) {
  const std::vector<double> r1 = ranges(11, 1), r2 = ranges(11, 2);
  Lms2xxParser p;
  Taken t;
  EXPECT_FALSE(take(p, &t));
  float tiny[4];
  EXPECT_EQ(p.takeScan(tiny, 4, nullptr), Status::kUnavailable);
  EXPECT_FALSE(feedAll(p, telegram(0x80, 0xB1, Bytes(40, 0x33))));  // status reply: skipped
  EXPECT_EQ(p.counters().other_telegrams, 1u);
  EXPECT_TRUE(feedAll(p, scanFrame(r1, true)));
  EXPECT_EQ(p.takeScan(tiny, 4, nullptr), Status::kInvalidArgument);  // too small: kept
  EXPECT_EQ(p.takeScan(nullptr, 11, nullptr), Status::kInvalidArgument);
  EXPECT_TRUE(p.scanAvailable());
  EXPECT_TRUE(feedAll(p, scanFrame(r2, true)));
  EXPECT_EQ(p.counters().scans_overwritten, 1u);
  ASSERT_TRUE(take(p, &t));
  EXPECT_EQ(t.info.sequence, 2u);
  expectRanges(r2, t.r, true);
  EXPECT_FALSE(p.scanAvailable());
  EXPECT_FALSE(take(p, &t));
  // A telegram for another address is garbage.
  const Bytes own = scanFrame(r1, true);
  const Bytes other = telegram(0x81, 0xB0, Bytes(own.begin() + 5, own.end() - 2));
  EXPECT_FALSE(feedAll(p, other));
  EXPECT_EQ(p.counters().bytes_discarded, other.size());
  // reset() drops a telegram in progress and keeps the balance.
  const Bytes f = scanFrame(r1, true);
  p.feed(f.data(), 20, 1);
  EXPECT_EQ(p.pendingBytes(), 20u);
  p.reset();
  EXPECT_EQ(p.pendingBytes(), 0u);
  EXPECT_FALSE(p.feed(f.data() + 20, f.size() - 20, 2));
  EXPECT_TRUE(feedAll(p, f));
  expectBalance(p);
}

namespace {
class FakePort : public odoerr::hal::SerialPort {
 public:
  struct Read {
    Bytes bytes;
    Status status;
  };
  std::deque<Read> reads;

 private:
  Status DoRead(std::uint8_t* buf, std::size_t capacity, std::size_t* n_read) override {
    if (reads.empty()) return Status::kOk;
    Read& r = reads.front();
    const std::size_t n = std::min(capacity, r.bytes.size());
    std::copy(r.bytes.begin(), r.bytes.begin() + static_cast<long>(n), buf);
    *n_read = n;
    const Status s = r.status;
    r.bytes.erase(r.bytes.begin(), r.bytes.begin() + static_cast<long>(n));
    r.status = Status::kOk;
    if (r.bytes.empty()) reads.pop_front();
    return s;
  }
  Status DoWrite(const std::uint8_t*, std::size_t n, std::size_t* n_written) override {
    *n_written = n;
    return Status::kOk;
  }
};
}  // namespace

TEST(Lms2xxParser, PollReadsTheSerialPort) {
  const std::vector<double> r = ranges(361, 3);
  const Bytes f = scanFrame(r, true);
  FakePort port;
  port.reads.push_back({Bytes(f.begin(), f.begin() + 300), Status::kOk});
  port.reads.push_back({Bytes(f.begin() + 300, f.end()), Status::kDataLoss});
  Lms2xxParser p;
  EXPECT_EQ(p.poll(port, 9000000), Status::kDataLoss);
  EXPECT_EQ(p.counters().uart_overruns, 1u);
  Taken t;
  ASSERT_TRUE(take(p, &t));
  expectRanges(r, t.r, true);
  EXPECT_EQ(t.info.stamp_us, 9000000u - 190625u);
  EXPECT_EQ(p.poll(port, 9000001), Status::kOk);  // nothing waiting
}

TEST(Lms2xxParser, NoHeapWhileParsing) {
  g_heap_allocs = 0;
  g_heap_armed = true;
  // The hook works. A call of the allocation function, not a new-expression: a compiler may
  // elide a new/delete pair of a new-expression (clang does).
  void* probe = ::operator new(sizeof(int));
  g_heap_armed = false;
  ::operator delete(probe);
  ASSERT_EQ(g_heap_allocs.load(), 1);

  const Bytes f = cat({Bytes{0x02, 0x80, 0x00, 0x03, 0x55}, scanFrame(ranges(361, 4), true),
                       Bytes{0x02, 0x80, 0xFF, 0xFF}});
  static Lms2xxParser p;  // built outside the armed region
  static float out[Lms2xxParser::kMaxValues];
  Lms2xxScanInfo info;
  g_heap_allocs = 0;
  g_heap_armed = true;
  const bool got = p.feed(f.data(), f.size(), 1000000);
  const Status s = p.takeScan(out, Lms2xxParser::kMaxValues, &info);
  g_heap_armed = false;
  EXPECT_EQ(g_heap_allocs.load(), 0);
  EXPECT_TRUE(got);
  EXPECT_EQ(s, Status::kOk);
  EXPECT_EQ(info.count, 361);
}
