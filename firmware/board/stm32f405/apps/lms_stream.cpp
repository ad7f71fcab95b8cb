// Host side of the board's LMS2xx probe: writes the byte stream QEMU feeds into USART1
// (LMS2xx measured-value telegrams of 181 ranges from the host simulator's encoder, with
// line damage: garbage between telegrams, one telegram with a flipped byte, one cut short),
// then parses the same bytes with the same parser and writes the report the board must
// reproduce. Usage: lms_stream STREAM.bin EXPECTED.txt
#include <cstdio>
#include <vector>

#include "lms_probe_report.hpp"
#include "odoerr/sim/lms2xx_writer.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: lms_stream STREAM.bin EXPECTED.txt\n");
    return 2;
  }
  std::vector<std::uint8_t> bytes;
  std::uint8_t tel[1024];
  double ranges[181];
  for (int k = 0; k < 40; ++k) {
    for (int i = 0; i < 181; ++i) ranges[i] = 0.5 + 0.02 * i + 0.013 * k;
    const std::size_t n = odoerr::sim::encodeLms2xxScan(ranges, 181, true, tel, sizeof tel);
    if (n == 0) return 1;
    if (k == 7) tel[200] ^= 0x10;  // a bit error: the CRC fails
    const std::size_t keep = (k == 23) ? n / 2 : n;  // cut short: the next STX resynchronises
    bytes.insert(bytes.end(), tel, tel + keep);
    if (k % 10 == 5) {
      for (int g = 0; g < 17; ++g) bytes.push_back(static_cast<std::uint8_t>(0x55 + 3 * g));  // line noise
    }
  }
  std::FILE* f = std::fopen(argv[1], "wb");
  if (f == nullptr || std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size() || std::fclose(f) != 0) {
    std::fprintf(stderr, "lms_stream: cannot write %s\n", argv[1]);
    return 1;
  }
  // The reference: the same parser over the same bytes, in chunks of 64 as poll() reads them.
  odoerr::drivers::Lms2xxConfig cfg;
  cfg.baud = 500000;
  odoerr::drivers::Lms2xxParser parser(cfg);
  odoerr::board::probe::Tally tally;
  std::uint64_t t = 0;
  for (std::size_t at = 0; at < bytes.size(); at += 64) {
    const std::size_t n = bytes.size() - at < 64 ? bytes.size() - at : 64;
    t += 1280;
    (void)parser.feed(bytes.data() + at, n, t);
    odoerr::board::probe::takeScans(parser, &tally);
  }
  char text[512];
  const std::size_t len = odoerr::board::probe::report(tally, parser.counters(), text, sizeof text);
  std::FILE* e = std::fopen(argv[2], "wb");
  if (e == nullptr || std::fwrite(text, 1, len, e) != len || std::fclose(e) != 0) {
    std::fprintf(stderr, "lms_stream: cannot write %s\n", argv[2]);
    return 1;
  }
  return 0;
}
