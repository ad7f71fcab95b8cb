// The LMS2xx probe's report, the same on the host (the reference) and on the board: the
// parser's counters and a checksum of every range it decoded, one "key value" line each.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "odoerr/drivers/lms2xx.hpp"

namespace odoerr::board::probe {

struct Tally {
  std::uint32_t scans = 0;
  std::uint32_t values = 0;
  std::uint32_t range_sum_mm = 0;  // modulo 2^32
};

/// Takes every scan the parser holds into the tally.
inline void takeScans(drivers::Lms2xxParser& parser, Tally* t) {
  float ranges[drivers::Lms2xxParser::kMaxValues];
  drivers::Lms2xxParser::ScanInfo info;
  while (parser.takeScan(ranges, drivers::Lms2xxParser::kMaxValues, &info) == hal::Status::kOk) {
    ++t->scans;
    for (int i = 0; i < info.count; ++i) {
      ++t->values;
      if (!std::isnan(ranges[i])) t->range_sum_mm += static_cast<std::uint32_t>(std::lround(ranges[i] * 1000.0f));
    }
  }
}

/// Appends "key value\n" to buf at *at (no stdio on the target).
inline void line(char* buf, std::size_t cap, std::size_t* at, const char* key, std::uint64_t v) {
  for (const char* k = key; *k != '\0' && *at + 1 < cap; ++k) buf[(*at)++] = *k;
  if (*at + 1 < cap) buf[(*at)++] = ' ';
  char digits[24];
  int n = 0;
  do {
    digits[n++] = static_cast<char>('0' + v % 10);
    v /= 10;
  } while (v != 0);
  while (n > 0 && *at + 1 < cap) buf[(*at)++] = digits[--n];
  if (*at + 1 < cap) buf[(*at)++] = '\n';
  buf[*at] = '\0';
}

/// The report's text for a tally and the parser's counters.
inline std::size_t report(const Tally& t, const drivers::Lms2xxCounters& c, char* buf, std::size_t cap) {
  std::size_t at = 0;
  line(buf, cap, &at, "scans", t.scans);
  line(buf, cap, &at, "values", t.values);
  line(buf, cap, &at, "range_sum_mm", t.range_sum_mm);
  line(buf, cap, &at, "frames_ok", c.frames_ok);
  line(buf, cap, &at, "bad_crc", c.bad_crc);
  line(buf, cap, &at, "truncated", c.truncated);
  line(buf, cap, &at, "wrong_length", c.wrong_length);
  line(buf, cap, &at, "bytes_fed", c.bytes_fed);
  line(buf, cap, &at, "bytes_discarded", c.bytes_discarded);
  return at;
}

}  // namespace odoerr::board::probe
