// SICK LMS2xx telegram parser (firmware) under every kind of line damage: bit flips,
// truncation, wrong lengths, garbage and false headers, chunking. Format, CRC and resync
// rules: odoerr/drivers/lms2xx.hpp. The rest of the parser: test_lms2xx.cpp.
#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "lms2xx_support.hpp"

using namespace odoerr::lms2xx_test;

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
