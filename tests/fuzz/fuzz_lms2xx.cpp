// libFuzzer target: the LMS2xx telegram parser fed a byte stream, in chunks as poll() does.
// Input: byte 0 picks the configuration (measuring mode, max_values, real baud), byte 1 the
// chunking; the rest is the line. Checks the parser's documented invariants.
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "odoerr/drivers/lms2xx.hpp"

using odoerr::drivers::Lms2xxParser;

namespace {
void check(bool ok) {
  if (!ok) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  Lms2xxParser::Config cfg;
  cfg.mode = static_cast<Lms2xxParser::MeasuringMode>(data[0] % 7);
  cfg.max_values = (data[0] & 0x80) ? 401 : 361;
  cfg.baud = (data[0] & 0x40) ? 500000 : 38400;
  cfg.latency_us = (data[0] & 0x20) ? 1000 : 0;
  // Chunk sizes: 1 (byte by byte, as an ISR), or 1..64 (as poll() reads), from byte 1.
  const std::size_t chunk_max = (data[1] & 1) ? 1 : 1 + (data[1] >> 2);
  data += 2;
  size -= 2;
  Lms2xxParser p(cfg);
  float ranges[Lms2xxParser::kMaxValues];
  std::uint64_t t = 1000;
  std::size_t i = 0;
  std::uint32_t taken = 0;
  while (i < size) {
    std::size_t n = 1 + (i * 7 + size) % chunk_max;
    if (n > size - i) n = size - i;
    t += 1 + n * 260;  // about the line time at 38400 baud
    p.feed(data + i, n, t);
    i += n;
    if (p.scanAvailable()) {
      Lms2xxParser::ScanInfo info;
      check(p.takeScan(ranges, Lms2xxParser::kMaxValues, &info) == odoerr::hal::Status::kOk);
      check(info.count >= 0 && info.count <= cfg.max_values);
      for (int k = 0; k < info.count; ++k) check(std::isnan(ranges[k]) || (ranges[k] >= 0.0f && ranges[k] < 400.0f));
      ++taken;
    }
    const auto& c = p.counters();
    check(c.bytes_fed == c.bytes_in_telegrams + c.bytes_discarded + p.pendingBytes());
    check(p.pendingBytes() <= Lms2xxParser::kMaxTelegram);
  }
  check(taken <= p.counters().frames_ok);
  check(p.takeScan(ranges, Lms2xxParser::kMaxValues, nullptr) == odoerr::hal::Status::kUnavailable);
  return 0;
}
