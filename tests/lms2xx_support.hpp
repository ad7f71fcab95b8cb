// The LMS2xx parser tests' shared pieces (test_lms2xx.cpp, test_lms2xx_damage.cpp):
// telegrams built with the host writer or by hand, feeding and taking scans, and the
// checks of decoded ranges and of the byte balance.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <vector>

#include <gtest/gtest.h>

#include "odoerr/drivers/lms2xx.hpp"
#include "odoerr/sim/lms2xx_writer.hpp"

namespace odoerr::lms2xx_test {

using odoerr::drivers::Lms2xxConfig;
using odoerr::drivers::Lms2xxCounters;
using odoerr::drivers::Lms2xxMeasuringMode;
using odoerr::drivers::Lms2xxParser;
using odoerr::drivers::Lms2xxScanInfo;
using odoerr::hal::Status;
using Bytes = std::vector<std::uint8_t>;

inline Bytes scanFrame(const std::vector<double>& r, bool mm, std::uint8_t status = 0x10) {
  Bytes out(r.size() * 2 + 16);
  const std::size_t n = odoerr::sim::encodeLms2xxScan(r.data(), static_cast<int>(r.size()), mm,
                                                      out.data(), out.size(), status);
  out.resize(n);
  return out;
}

inline Bytes telegram(std::uint8_t addr, std::uint8_t cmd, const Bytes& payload) {
  Bytes out(payload.size() + 8);
  const std::size_t n = odoerr::sim::encodeLms2xxTelegram(addr, cmd, payload.data(),
                                                          payload.size(), out.data(), out.size());
  out.resize(n);
  return out;
}

/// A CRC-valid 0xB0 reply with a hand-made count word and value words (and optional
/// real-time index), status 0x10.
inline Bytes rawB0(std::uint16_t count_word, const std::vector<std::uint16_t>& words, int rt = -1) {
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

inline Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& b : parts) out.insert(out.end(), b.begin(), b.end());
  return out;
}

/// Deterministic ranges in [0.3, 8.0] m, none NaN.
inline std::vector<double> ranges(int n, int seed) {
  std::vector<double> r(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) r[static_cast<std::size_t>(i)] = 0.3 + std::fmod(0.7919 * (i + 1) * (seed + 3), 7.7);
  return r;
}

struct Taken {
  std::vector<float> r;
  Lms2xxScanInfo info;
};

inline bool take(Lms2xxParser& p, Taken* t) {
  t->r.assign(Lms2xxParser::kMaxValues, -1.0f);
  Lms2xxScanInfo info;
  if (p.takeScan(t->r.data(), Lms2xxParser::kMaxValues, &info) != Status::kOk) return false;
  t->r.resize(static_cast<std::size_t>(info.count));
  t->info = info;
  return true;
}

inline bool feedAll(Lms2xxParser& p, const Bytes& b, std::uint64_t t = 1000000) {
  return p.feed(b.data(), b.size(), t);
}

/// Expected decoding of a writer-encoded range (mm or cm).
inline void expectRanges(const std::vector<double>& want, const std::vector<float>& got, bool mm) {
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

inline bool sameFloats(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

inline void expectBalance(const Lms2xxParser& p) {
  const Lms2xxCounters& c = p.counters();
  EXPECT_EQ(c.bytes_fed, c.bytes_in_telegrams + c.bytes_discarded + p.pendingBytes());
}

/// True if one bit flip in b[1..] could create STX + 0x80 somewhere other than offset 0.
inline bool flipCanMakeHeader(const Bytes& b) {
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
inline bool headerInside(const Bytes& b) {
  for (std::size_t i = 1; i + 1 < b.size(); ++i) {
    if (b[i] == 0x02 && b[i + 1] == 0x80) return true;
  }
  return false;
}

inline std::uint16_t le16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }

}  // namespace odoerr::lms2xx_test
