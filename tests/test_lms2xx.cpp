// SICK LMS2xx telegram parser (firmware) against the host writer, published telegrams and
// every kind of line damage. Format, CRC and resync rules: odoerr/drivers/lms2xx.hpp.
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

#include "odoerr/drivers/lms2xx.hpp"
#include "odoerr/sim/lms2xx_writer.hpp"

// --- a heap hook for the no-allocation test (shown to work first) -------------------------
namespace {
std::atomic<bool> g_armed{false};
std::atomic<long> g_news{0};
}  // namespace

// The replacements pair malloc/free on purpose (GCC cannot see they match).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t n) {
  if (g_armed.load(std::memory_order_relaxed)) g_news.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

using odoerr::drivers::Lms2xxConfig;
using odoerr::drivers::Lms2xxCounters;
using odoerr::drivers::Lms2xxMeasuringMode;
using odoerr::drivers::Lms2xxParser;
using odoerr::drivers::Lms2xxScanInfo;
using odoerr::hal::Status;
using Bytes = std::vector<std::uint8_t>;

namespace {

Bytes scanFrame(const std::vector<double>& r, bool mm, std::uint8_t status = 0x10) {
  Bytes out(r.size() * 2 + 16);
  const std::size_t n = odoerr::sim::encodeLms2xxScan(r.data(), static_cast<int>(r.size()), mm,
                                                      out.data(), out.size(), status);
  out.resize(n);
  return out;
}

Bytes telegram(std::uint8_t addr, std::uint8_t cmd, const Bytes& payload) {
  Bytes out(payload.size() + 8);
  const std::size_t n = odoerr::sim::encodeLms2xxTelegram(addr, cmd, payload.data(),
                                                          payload.size(), out.data(), out.size());
  out.resize(n);
  return out;
}

/// A CRC-valid 0xB0 reply with a hand-made count word and value words (and optional
/// real-time index), status 0x10.
Bytes rawB0(std::uint16_t count_word, const std::vector<std::uint16_t>& words, int rt = -1) {
  Bytes p;
  p.push_back(static_cast<std::uint8_t>(count_word & 0xFF));
  p.push_back(static_cast<std::uint8_t>(count_word >> 8));
  for (std::uint16_t w : words) {
    p.push_back(static_cast<std::uint8_t>(w & 0xFF));
    p.push_back(static_cast<std::uint8_t>(w >> 8));
  }
  if (rt >= 0) p.push_back(static_cast<std::uint8_t>(rt));
  p.push_back(0x10);
  return telegram(0x80, 0xB0, p);
}

Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& b : parts) out.insert(out.end(), b.begin(), b.end());
  return out;
}

/// Deterministic ranges in [0.3, 8.0] m, none NaN.
std::vector<double> ranges(int n, int seed) {
  std::vector<double> r(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) r[static_cast<std::size_t>(i)] = 0.3 + std::fmod(0.7919 * (i + 1) * (seed + 3), 7.7);
  return r;
}

struct Taken {
  std::vector<float> r;
  Lms2xxScanInfo info;
};

bool take(Lms2xxParser& p, Taken* t) {
  t->r.assign(Lms2xxParser::kMaxValues, -1.0f);
  Lms2xxScanInfo info;
  if (p.takeScan(t->r.data(), Lms2xxParser::kMaxValues, &info) != Status::kOk) return false;
  t->r.resize(static_cast<std::size_t>(info.count));
  t->info = info;
  return true;
}

bool feedAll(Lms2xxParser& p, const Bytes& b, std::uint64_t t = 1000000) {
  return p.feed(b.data(), b.size(), t);
}

/// Expected decoding of a writer-encoded range (mm or cm).
void expectRanges(const std::vector<double>& want, const std::vector<float>& got, bool mm) {
  ASSERT_EQ(want.size(), got.size());
  const double q = mm ? 0.001 : 0.01;
  const double max = mm ? 8.182 : 81.82;
  for (std::size_t i = 0; i < want.size(); ++i) {
    const double w = want[i];
    if (std::isfinite(w) && w >= 0.0 && std::round(w / q) * q <= max + 1e-9) {
      EXPECT_NEAR(static_cast<double>(got[i]), w, q / 2 + 1e-6) << "value " << i;
    } else {
      EXPECT_TRUE(std::isnan(got[i])) << "value " << i << " want " << w;
    }
  }
}

bool sameFloats(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

void expectBalance(const Lms2xxParser& p) {
  const Lms2xxCounters& c = p.counters();
  EXPECT_EQ(c.bytes_fed, c.bytes_in_telegrams + c.bytes_discarded + p.pendingBytes());
}

/// True if one bit flip in b[1..] could create STX + 0x80 somewhere other than offset 0.
bool flipCanMakeHeader(const Bytes& b) {
  auto near = [](std::uint8_t x, std::uint8_t target) {
    const unsigned d = static_cast<unsigned>(x ^ target);
    return d == 0 || (d & (d - 1)) == 0;
  };
  for (std::size_t i = 1; i + 1 < b.size(); ++i) {
    if ((near(b[i], 0x02) && b[i + 1] == 0x80) || (b[i] == 0x02 && near(b[i + 1], 0x80))) {
      return true;
    }
  }
  return false;
}

/// True if STX + 0x80 occurs in b other than at offset 0.
bool headerInside(const Bytes& b) {
  for (std::size_t i = 1; i + 1 < b.size(); ++i) {
    if (b[i] == 0x02 && b[i + 1] == 0x80) return true;
  }
  return false;
}

std::uint16_t le16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }

}  // namespace

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

// --- damage ---------------------------------------------------------------------------------

// Every single-bit error in a telegram: no scan from it, the good telegram behind it is
// still parsed, and the damage is counted in the right counter.
TEST(Lms2xxParser, EverySingleBitFlipIsRejectedAndClassified) {
  const Bytes a = scanFrame(ranges(21, 4), true);
  const std::vector<double> rb = ranges(15, 5);
  const Bytes b = scanFrame(rb, true);
  ASSERT_FALSE(flipCanMakeHeader(a)) << "test data must not allow a flip to forge a header";
  int flips = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    for (int bit = 0; bit < 8; ++bit) {
      Bytes bad = a;
      bad[k] = static_cast<std::uint8_t>(bad[k] ^ (1u << bit));
      Lms2xxParser p;
      feedAll(p, cat({bad, b}));
      const Lms2xxCounters& c = p.counters();
      Taken t;
      ASSERT_TRUE(take(p, &t)) << "byte " << k << " bit " << bit;
      EXPECT_EQ(t.info.count, 15) << "byte " << k << " bit " << bit;  // B's scan, not A's
      expectRanges(rb, t.r, true);
      EXPECT_EQ(c.frames_ok, 1u);
      EXPECT_EQ(c.scans_overwritten, 0u) << "a damaged telegram produced a scan";
      EXPECT_EQ(c.bytes_discarded, a.size());
      EXPECT_EQ(c.bytes_in_telegrams, b.size());
      if (k < 2) {  // STX or ADR: no candidate at all, plain resync garbage
        EXPECT_EQ(c.bad_crc + c.truncated + c.wrong_length, 0u) << "byte " << k;
      } else if (k < 4) {  // LEN: out of range, too short (CRC) or too long (truncated)
        EXPECT_EQ(c.bad_crc + c.truncated + c.wrong_length, 1u) << "byte " << k << " bit " << bit;
      } else {  // CMD, data, status, CRC
        EXPECT_EQ(c.bad_crc, 1u) << "byte " << k << " bit " << bit;
        EXPECT_EQ(c.truncated + c.wrong_length, 0u) << "byte " << k << " bit " << bit;
      }
      expectBalance(p);
      ++flips;
    }
  }
  EXPECT_EQ(flips, static_cast<int>(a.size()) * 8);
}

// A telegram cut after k bytes, then a good one: the cut one is counted truncated and the
// good one is parsed whether the cut one's declared end falls inside the good one (CRC fails,
// rescan) or after it (the good one completes first and wins).
TEST(Lms2xxParser, TruncatedTelegramThenGoodTelegram) {
  const Bytes a = scanFrame(ranges(361, 6), true);
  ASSERT_FALSE(headerInside(a));
  const std::vector<double> rb = ranges(21, 7);
  const Bytes b = scanFrame(rb, true);
  for (std::size_t k : {3u, 4u, 5u, 7u, 100u, 690u, 700u, 731u}) {
    Lms2xxParser p;
    const Bytes s = cat({Bytes(a.begin(), a.begin() + static_cast<long>(k)), b});
    EXPECT_TRUE(feedAll(p, s)) << k;
    Taken t;
    ASSERT_TRUE(take(p, &t)) << k;
    EXPECT_EQ(t.info.count, 21);
    expectRanges(rb, t.r, true);
    const Lms2xxCounters& c = p.counters();
    EXPECT_EQ(c.truncated, 1u) << k;
    EXPECT_EQ(c.bad_crc, 0u) << k;
    EXPECT_EQ(c.wrong_length, 0u) << k;
    EXPECT_EQ(c.frames_ok, 1u) << k;
    EXPECT_EQ(c.bytes_discarded, k) << k;
    expectBalance(p);
  }
  // Cut after STX ADR: the next telegram's 02 80 reads as LEN 0x8002, out of range.
  Lms2xxParser p2;
  feedAll(p2, cat({Bytes(a.begin(), a.begin() + 2), b}));
  EXPECT_EQ(p2.counters().wrong_length, 1u);
  EXPECT_EQ(p2.counters().frames_ok, 1u);
  // Cut with no telegram behind it (idle filler): counted bad_crc once its span has passed.
  Lms2xxParser p3;
  feedAll(p3, cat({Bytes(a.begin(), a.begin() + 100), Bytes(700, 0x00)}));
  EXPECT_EQ(p3.counters().bad_crc, 1u);
  EXPECT_EQ(p3.counters().truncated, 0u);
  EXPECT_FALSE(p3.scanAvailable());
  expectBalance(p3);
}

TEST(Lms2xxParser, WrongLengthField) {
  const std::vector<double> rg = ranges(21, 8);
  const Bytes good = scanFrame(rg, true);
  std::vector<std::uint16_t> w21(21, 1234);
  struct Case {
    const char* what;
    Bytes bytes;
    bool consumed_as_telegram;  // CRC-valid: consumed whole, not rescanned
  };
  const std::vector<Case> cases = {
      {"LEN 813 > max", {0x02, 0x80, 0x2D, 0x03, 0xB0, 0x15, 0x40, 0x11, 0x22}, false},
      {"LEN 0", {0x02, 0x80, 0x00, 0x00, 0xB0, 0x15, 0x40}, false},
      {"LEN 0xFFFF", {0x02, 0x80, 0xFF, 0xFF}, false},
      {"count 21, 20 values", rawB0(0x4000 | 21, std::vector<std::uint16_t>(20, 1234)), true},
      {"count 21, 23 values", rawB0(0x4000 | 21, std::vector<std::uint16_t>(23, 1234)), true},
      {"count 0x3FF, 21 values", rawB0(0x4000 | 0x3FF, w21), true},
      {"B0 without count word", telegram(0x80, 0xB0, {0x10}), true},
      {"B0 count word split", telegram(0x80, 0xB0, {0x00, 0x10}), true},
  };
  for (const Case& cs : cases) {
    Lms2xxParser p;
    feedAll(p, cat({cs.bytes, good}));
    const Lms2xxCounters& c = p.counters();
    EXPECT_EQ(c.wrong_length, 1u) << cs.what;
    EXPECT_EQ(c.frames_ok, 1u) << cs.what;
    EXPECT_EQ(c.bad_crc + c.truncated + c.bad_unit + c.other_telegrams, 0u) << cs.what;
    EXPECT_EQ(c.bytes_in_telegrams, good.size() + (cs.consumed_as_telegram ? cs.bytes.size() : 0))
        << cs.what;
    Taken t;
    ASSERT_TRUE(take(p, &t)) << cs.what;
    expectRanges(rg, t.r, true);
    EXPECT_EQ(c.scans_overwritten, 0u) << cs.what;
    expectBalance(p);
  }
  // More values than configured.
  Lms2xxConfig cfg;
  cfg.max_values = 20;
  Lms2xxParser p(cfg);
  EXPECT_FALSE(feedAll(p, good));
  EXPECT_EQ(p.counters().wrong_length, 1u);
  EXPECT_FALSE(p.scanAvailable());
  cfg.max_values = 21;
  Lms2xxParser p21(cfg);
  EXPECT_TRUE(feedAll(p21, good));
}

// Random garbage before, between and after telegrams, with fake headers (02 80 alone, with an
// out-of-range LEN, with a small LEN, and with a large LEN that swallows the next telegram).
TEST(Lms2xxParser, GarbageAroundTelegramsAllTelegramsFound) {
  std::mt19937 rng(12345);
  const std::vector<int> sizes = {361, 21, 181, 5, 401, 0, 361};
  std::vector<std::vector<double>> want;
  Bytes stream;
  std::uint64_t garbage = 0, telegram_bytes = 0;
  auto addGarbage = [&](bool swallow) {
    const std::size_t n = rng() % 300;
    Bytes g(n);
    for (auto& x : g) x = static_cast<std::uint8_t>(rng());
    const Bytes fakes[] = {{0x02, 0x80}, {0x02, 0x80, 0xFF, 0x7F}, {0x02, 0x80, 0x10, 0x00},
                           {0x02, 0x80, 0x02}};
    for (int f = 0; f < 3 && n > 8; ++f) {
      const Bytes& fk = fakes[rng() % 4];
      const std::size_t at = rng() % (n - fk.size());
      std::copy(fk.begin(), fk.end(), g.begin() + static_cast<long>(at));
    }
    if (swallow) {  // a fake header whose LEN 0x0300 covers the next telegram
      const Bytes h = {0x02, 0x80, 0x00, 0x03};
      g.insert(g.end(), h.begin(), h.end());
    }
    garbage += g.size();
    stream.insert(stream.end(), g.begin(), g.end());
  };
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    addGarbage(i % 2 == 1);
    want.push_back(ranges(sizes[i], static_cast<int>(i) + 20));
    const Bytes f = scanFrame(want.back(), i % 3 != 0);
    telegram_bytes += f.size();
    stream.insert(stream.end(), f.begin(), f.end());
  }
  addGarbage(false);
  stream.push_back(0x02);  // a header that never completes
  stream.push_back(0x80);
  ++garbage;
  ++garbage;

  Lms2xxParser p;
  std::vector<Taken> got;
  std::size_t pos = 0;
  while (pos < stream.size()) {  // chunks shorter than the shortest telegram (10 bytes)
    const std::size_t n = std::min<std::size_t>(1 + rng() % 9, stream.size() - pos);
    if (p.feed(stream.data() + pos, n, 1000 + pos)) {
      Taken t;
      ASSERT_TRUE(take(p, &t));
      got.push_back(t);
    }
    pos += n;
  }
  const Lms2xxCounters& c = p.counters();
  ASSERT_EQ(got.size(), sizes.size());
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    EXPECT_EQ(got[i].info.count, sizes[i]);
    expectRanges(want[i], got[i].r, i % 3 != 0);
  }
  EXPECT_EQ(c.frames_ok, sizes.size());
  EXPECT_EQ(c.other_telegrams, 0u);
  EXPECT_EQ(c.scans_overwritten, 0u);
  EXPECT_EQ(c.bytes_in_telegrams, telegram_bytes);
  EXPECT_EQ(c.bytes_discarded + p.pendingBytes(), garbage);
  EXPECT_GT(c.bytes_discarded, 0u);
  EXPECT_GE(c.truncated, 3u);  // the swallowing fake headers
  EXPECT_GE(c.wrong_length, 1u);
  EXPECT_GE(p.pendingBytes(), 2u);
  expectBalance(p);
}

// False headers nested inside each other in front of a telegram: after the first fails its
// CRC, the rescan meets a second one with a large LEN; the telegram behind it must still be
// delivered as soon as it is complete, whether it was still arriving when the rescan
// happened or had just been completed by the same byte that failed the first header.
TEST(Lms2xxParser, NestedFalseHeadersDoNotHoldBackATelegram) {
  const std::vector<double> rf = ranges(21, 11);
  const Bytes f = scanFrame(rf, true);  // 52 bytes
  ASSERT_EQ(f.size(), 52u);
  const Bytes big = {0x02, 0x80, 0x00, 0x03};  // LEN 768
  const std::vector<Bytes> streams = {
      // A: LEN 20 (ends inside F), 1 filler byte, B (LEN 768), F.
      cat({{0x02, 0x80, 0x14, 0x00, 0x55}, big, f}),
      // A: LEN 54 (ends with F's last byte), B, F.
      cat({{0x02, 0x80, 0x36, 0x00}, big, f}),
  };
  for (std::size_t i = 0; i < streams.size(); ++i) {
    Lms2xxParser p;
    EXPECT_TRUE(feedAll(p, streams[i])) << i;
    Taken t;
    ASSERT_TRUE(take(p, &t)) << i;
    expectRanges(rf, t.r, true);
    const Lms2xxCounters& c = p.counters();
    EXPECT_EQ(c.truncated, 1u) << i;  // one rejected region, with F inside it
    EXPECT_EQ(c.bad_crc + c.wrong_length, 0u) << i;
    EXPECT_EQ(c.bytes_discarded, streams[i].size() - f.size()) << i;
    EXPECT_EQ(p.pendingBytes(), 0u);
  }
}

// A header-like 02 80 FF FF inside the bytes of a rejected telegram is part of the damage,
// not a second error.
TEST(Lms2xxParser, HeadersInsideARejectedSpanAreNotCountedAgain) {
  Bytes a = rawB0(0x4000 | 4, {1000, 0x8002, 0xFFFF, 2000});  // data bytes ... 02 80 FF FF ...
  Lms2xxParser ok;
  EXPECT_TRUE(feedAll(ok, a));  // intact: the inner pattern is never hunted
  EXPECT_EQ(ok.counters().wrong_length, 0u);
  a[a.size() - 3] ^= 0x01;  // status byte damaged
  Lms2xxParser p;
  EXPECT_FALSE(feedAll(p, cat({a, Bytes(4, 0x00)})));
  EXPECT_EQ(p.counters().bad_crc, 1u);
  EXPECT_EQ(p.counters().wrong_length, 0u);
  EXPECT_EQ(p.counters().bytes_discarded, a.size() + 4);
}

// Byte by byte, one chunk, and random chunks give the same telegrams, counters and scan.
TEST(Lms2xxParser, ChunkingDoesNotChangeResults) {
  std::mt19937 rng(99);
  Bytes s;
  for (int i = 0; i < 12; ++i) {
    Bytes g(rng() % 200);
    for (auto& x : g) x = static_cast<std::uint8_t>(rng());
    if (i % 3 == 0) g.insert(g.end(), {0x02, 0x80, 0x40, 0x01});  // swallowing fake header
    s.insert(s.end(), g.begin(), g.end());
    Bytes f = scanFrame(ranges(i % 2 ? 361 : 31, i), i % 2 == 0);
    if (i == 4) f[40] ^= 0x10;                           // corrupted
    if (i == 7) f.resize(300);                       // truncated
    if (i == 9) f = telegram(0x80, 0xA0, {0x00, 0x10});  // another telegram
    s.insert(s.end(), f.begin(), f.end());
  }
  const std::uint32_t baud = 38400;
  const std::uint64_t t_end = 50000000;
  auto at = [&](std::size_t last_index) {  // arrival of byte `last_index`, back-to-back
    return t_end - Lms2xxParser::transmissionTimeUs(s.size() - 1 - last_index, baud);
  };
  Lms2xxConfig cfg;
  cfg.baud = baud;
  Lms2xxParser one(cfg), bytewise(cfg), chunks(cfg);
  one.feed(s.data(), s.size(), t_end);
  for (std::size_t i = 0; i < s.size(); ++i) bytewise.feed(&s[i], 1, at(i));
  for (std::size_t pos = 0; pos < s.size();) {
    const std::size_t n = std::min<std::size_t>(1 + rng() % 300, s.size() - pos);
    chunks.feed(s.data() + pos, n, at(pos + n - 1));
    pos += n;
  }
  Lms2xxParser* others[] = {&bytewise, &chunks};
  Taken t1;
  ASSERT_TRUE(take(one, &t1));
  const Lms2xxCounters& c1 = one.counters();
  EXPECT_EQ(c1.frames_ok, 9u);
  EXPECT_EQ(c1.other_telegrams, 1u);
  EXPECT_GE(c1.bad_crc + c1.truncated, 2u);
  for (Lms2xxParser* pp : others) {
    Lms2xxParser& p = *pp;
    const Lms2xxCounters& c = p.counters();
    EXPECT_EQ(c.frames_ok, c1.frames_ok);
    EXPECT_EQ(c.bad_crc, c1.bad_crc);
    EXPECT_EQ(c.truncated, c1.truncated);
    EXPECT_EQ(c.wrong_length, c1.wrong_length);
    EXPECT_EQ(c.bad_unit, c1.bad_unit);
    EXPECT_EQ(c.other_telegrams, c1.other_telegrams);
    EXPECT_EQ(c.scans_overwritten, c1.scans_overwritten);
    EXPECT_EQ(c.bytes_fed, c1.bytes_fed);
    EXPECT_EQ(c.bytes_in_telegrams, c1.bytes_in_telegrams);
    EXPECT_EQ(c.bytes_discarded, c1.bytes_discarded);
    EXPECT_EQ(p.pendingBytes(), one.pendingBytes());
    Taken t;
    ASSERT_TRUE(take(p, &t));
    EXPECT_TRUE(sameFloats(t.r, t1.r));
    EXPECT_EQ(t.info.sequence, t1.info.sequence);
    EXPECT_EQ(t.info.count, t1.info.count);
    const std::int64_t dt = static_cast<std::int64_t>(t.info.stamp_us - t1.info.stamp_us);
    EXPECT_LE(std::llabs(dt), 1) << "stamps differ by rounding only";
    expectBalance(p);
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
  g_news = 0;
  g_armed = true;
  int* probe = new int(3);  // the hook works
  g_armed = false;
  delete probe;
  ASSERT_EQ(g_news.load(), 1);

  const Bytes f = cat({Bytes{0x02, 0x80, 0x00, 0x03, 0x55}, scanFrame(ranges(361, 4), true),
                       Bytes{0x02, 0x80, 0xFF, 0xFF}});
  static Lms2xxParser p;  // built outside the armed region
  static float out[Lms2xxParser::kMaxValues];
  Lms2xxScanInfo info;
  g_news = 0;
  g_armed = true;
  const bool got = p.feed(f.data(), f.size(), 1000000);
  const Status s = p.takeScan(out, Lms2xxParser::kMaxValues, &info);
  g_armed = false;
  EXPECT_EQ(g_news.load(), 0);
  EXPECT_TRUE(got);
  EXPECT_EQ(s, Status::kOk);
  EXPECT_EQ(info.count, 361);
}
