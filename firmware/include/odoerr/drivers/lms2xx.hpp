// odoerr firmware: stream parser for SICK LMS2xx (LMS200/211/221/291) binary telegrams.
// Hardware-independent; no heap, no exceptions, no iostream, no double maths; float output.
//
// ---------------------------------------------------------------------------------------
// Telegram (RS-232/RS-422, 8N1, so 10 bits on the line per byte). Multi-byte fields are
// little-endian (low byte first).
//
//   offset   size    field   meaning
//   0        1       STX     0x02
//   1        1       ADR     0x80 in replies scanner -> host (0x80 | scanner address);
//                            0x00 in telegrams host -> scanner
//   2        2       LEN     number of bytes from CMD up to and including the status byte:
//                            LEN = 1 (CMD) + data bytes + 1 (STATUS). STX, ADR, LEN and CRC
//                            are not counted. (Host -> scanner telegrams have no status byte.)
//   4        1       CMD     0xB0 = measured values (reply to 0x20 mode 0x24 "continuous"
//                            and to 0x30 "send measured values once"); others are skipped
//   5        LEN-2   DATA    see below for 0xB0
//   3+LEN    1       STATUS  scanner status byte (e.g. 0x10 in normal replies); not judged
//   4+LEN    2       CRC     vendor CRC16 (below) over bytes 0 .. 3+LEN, i.e. STX through
//                            STATUS; low byte first
//   total telegram = LEN + 6 bytes.  Accepted here: 1 <= LEN <= kMaxLen (812).
//
// 0xB0 data:
//   +0       2       count word: bits 0-9   number of values n
//                                bit  10    unused
//                                bits 11-12 partial-scan index k (values start k*0.25 deg
//                                           late; interlaced 0.25 deg modes)
//                                bit  13    1 = partial scan
//                                bits 14-15 unit: 00 = cm, 01 = mm (10, 11 undefined)
//   +2       2n      one 16-bit word per value (layout per measuring mode, below)
//   [+2+2n   1       real-time scan index: only if the scanner is configured to send it]
//   so LEN = 4 + 2n, or 5 + 2n with the real-time index. Anything else: wrong_length.
//
// Value word, by the measuring mode of the scanner's configuration (default 0x00):
//   0x00  8/80 m, fields A,B,dazzle: bits 0-12 distance; 13 field A; 14 field B; 15 dazzle
//   0x01  8/80 m, reflector:         bits 0-12 distance; 13-15 reflector level
//   0x02  8/80 m, fields A,B,C:      bits 0-12 distance; 13 A; 14 B; 15 C
//   0x03  16 m, reflector:           bits 0-13 distance; 14-15 reflector level
//   0x04  16 m, fields A,B:          bits 0-13 distance; 14 A; 15 B
//   0x05  32 m, reflector:           bits 0-14 distance; 15 reflector
//   0x06  32 m, field A:             bits 0-14 distance; 15 A
// With D the distance mask (0x1FFF, 0x3FFF or 0x7FFF) the codes D-8 .. D are not distances:
//   D-8 (0x1FF7) measured value > maximum (no return within range), D-5 (0x1FFA) error
//   reading channel 1, D-4 (0x1FFB) signal-to-noise ratio too small, D-2 (0x1FFD) operation
//   overflow, D-1 (0x1FFE) dazzling, D (0x1FFF) measured value not valid; the rest of
//   D-8..D is undocumented. Largest distance: D-9 (0x1FF6 = 8.182 m in mm, 81.82 m in cm).
// Output: distance * unit in metres; NaN for every code >= D-8 and, in mode 0x00, for the
// dazzle bit. Field and reflector bits are not errors: the distance is kept.
//
// CRC16 (vendor routine; not a textbook CRC: each step XORs in the current AND the previous
// byte), over STX .. STATUS:
//   crc = 0; prev = 0
//   for each byte b:
//     crc = (crc & 0x8000) ? (((crc & 0x7FFF) << 1) ^ 0x8005) : (crc << 1)   // 16 bits
//     crc ^= (prev << 8) | b
//     prev = b
//   e.g. 02 00 02 00 20 24 -> 0x0834, sent as 34 08 (the "continuous output" request).
//
// Sources (public, read, not copied): SICK "LMS/LMI 400 - Definition of telegrams between
// the user interface and LMS or LMI systems via RS 422/RS 232" (the LMS2xx telegram listing:
// §2.3 telegram structure, §2.4 CRC16, B0h reply; only its table of contents was reachable);
// ros-drivers/sicktoolbox SickLMS2xxMessage.cc (LEN = payload incl. CMD, CRC over
// LEN + 4 bytes from STX, CRC16_GEN_POL 0x8005, max payload 812) and SickLMS2xx.cc (B0
// count bits 0-9, partial index bits 11-12, optional real-time index, value masks per
// measuring mode); roboticslibrary/rl SickLms200.cpp (partial-scan bit 13, unit bits
// 14-15, error codes 0x1FF7..0x1FFF and 0x3FF7.., 0x7FF7.., 8.182 m maximum); telegrams
// published in several projects (CRC golden vectors in tests/test_lms2xx.cpp) and a real
// B0 reply header 02 80 D6 02 B0 69 01 (LEN 726 = 1 + 2 + 361*2 + 1; 361 values in cm).
//
// ---------------------------------------------------------------------------------------
// Resynchronisation. A candidate is a byte STX followed by the expected ADR and a LEN in
// [1, kMaxLen]. A header with a LEN out of range counts wrong_length. A candidate is
// rejected if its CRC fails, or if a CRC-valid telegram is completed inside its declared
// span before the candidate itself is complete (a false or cut-off header must not hold
// back the real telegram behind it). After a rejection the hunt resumes at the byte after
// the rejected STX, so a real telegram inside garbage, or behind a cut-off one, is found.
// A rejected span (merged with overlapping rejected spans) is counted exactly once:
//   truncated  a CRC-valid telegram starts inside it: the telegram was cut short and the
//              next one began before its declared end (a LEN corrupted upwards looks the
//              same);
//   bad_crc    otherwise; counted when the hunt has moved past the span's end.
// Headers lying inside a span that is already counted as rejected are its bytes and are
// not counted again. Every byte ends up exactly once in bytes_in_telegrams (CRC-valid
// telegrams) or bytes_discarded, or is still buffered: bytes_fed == bytes_in_telegrams +
// bytes_discarded + pendingBytes(). Bytes are processed one at a time, so feeding a stream
// byte by byte or in any chunking gives the same telegrams and counters.
//
// Time stamp. The bytes of a chunk are assumed to have arrived back-to-back at line rate,
// the chunk's last byte at arrival_us. The scanner starts sending right after a scan
// completes, so
//   stamp = arrival_us - (bytes from the telegram's STX to the chunk's last byte) * 10 / baud
//           - latency_us
// i.e. the arrival of the telegram's last byte minus its transmission time (LEN + 6 bytes
// x 10 bits / baud), minus the scanner's internal acquisition-to-send latency (a
// configurable constant, default 0). Integer microseconds, rounded to nearest; clamped at 0.
#pragma once

#include <cstddef>
#include <cstdint>

#include "odoerr/hal/serial_port.hpp"
#include "odoerr/hal/status.hpp"

namespace odoerr::drivers {

/// Measuring mode byte of the scanner configuration (see the value-word table above).
enum class Lms2xxMeasuringMode : std::uint8_t {
  kRange8mFieldsABDazzle = 0x00,  ///< default
  kRange8mReflector = 0x01,
  kRange8mFieldsABC = 0x02,
  kRange16mReflector = 0x03,
  kRange16mFieldsAB = 0x04,
  kRange32mReflector = 0x05,
  kRange32mFieldA = 0x06,
};

struct Lms2xxConfig {
  std::uint32_t baud = 38400;            ///< line rate (8N1); 0 is taken as 38400
  std::uint8_t expected_address = 0x80;  ///< ADR of the telegrams to parse (replies: 0x80)
  /// Largest value count accepted (clamped to [1, kMaxValues]). 401 = 100 deg at 0.25 deg,
  /// the largest LMS2xx scan; 361 = 180 deg at 0.5 deg. A 0xB0 telegram announcing more
  /// counts wrong_length.
  int max_values = 401;
  Lms2xxMeasuringMode mode = Lms2xxMeasuringMode::kRange8mFieldsABDazzle;
  std::uint32_t latency_us = 0;  ///< scanner-internal delay from scan end to first byte sent
};

struct Lms2xxCounters {
  std::uint32_t frames_ok = 0;          ///< CRC-valid 0xB0 telegrams decoded into a scan
  std::uint32_t bad_crc = 0;            ///< rejected spans with no valid telegram inside
  std::uint32_t truncated = 0;          ///< rejected spans with a valid telegram inside
  std::uint32_t wrong_length = 0;       ///< LEN out of [1, 812], or 0xB0 LEN inconsistent
                                        ///< with its value count, or count > max_values
  std::uint32_t bad_unit = 0;           ///< CRC-valid 0xB0 with unit code 10 or 11
  std::uint32_t other_telegrams = 0;    ///< CRC-valid telegrams with CMD != 0xB0 (skipped)
  std::uint32_t scans_overwritten = 0;  ///< a new scan replaced one not taken yet
  std::uint32_t uart_overruns = 0;      ///< poll(): the port reported lost bytes
  std::uint64_t bytes_fed = 0;
  std::uint64_t bytes_in_telegrams = 0;  ///< bytes of CRC-valid telegrams (any CMD)
  std::uint64_t bytes_discarded = 0;     ///< resync garbage and rejected candidates' bytes
};

struct Lms2xxScanInfo {
  int count = 0;                  ///< number of values
  std::uint64_t stamp_us = 0;     ///< estimated time of the scan (see the model above)
  std::uint8_t status = 0;        ///< the telegram's status byte
  bool unit_mm = false;           ///< false: cm
  bool partial = false;           ///< count-word bit 13
  std::uint8_t partial_index = 0; ///< count-word bits 11-12
  bool has_realtime_index = false;
  std::uint8_t realtime_index = 0;
  std::uint32_t sequence = 0;     ///< frames_ok when decoded (1, 2, ...)
};

class Lms2xxParser {
 public:
  using Config = Lms2xxConfig;
  using Counters = Lms2xxCounters;
  using ScanInfo = Lms2xxScanInfo;
  using MeasuringMode = Lms2xxMeasuringMode;

  static constexpr std::uint8_t kStx = 0x02;
  static constexpr std::uint8_t kCmdMeasuredValues = 0xB0;
  static constexpr int kMaxValues = 401;
  static constexpr std::size_t kMaxLen = 812;  ///< largest LEN accepted
  static constexpr std::size_t kOverhead = 6;  ///< STX, ADR, LEN (2), CRC (2)
  static constexpr std::size_t kMaxTelegram = kMaxLen + kOverhead;

  explicit Lms2xxParser(const Config& config = Config());

  /// Feeds bytes as they arrive; arrival_us = clock time (us) at which the LAST byte of
  /// this chunk arrived. Returns true when at least one complete scan became available.
  bool feed(const std::uint8_t* data, std::size_t n, std::uint64_t arrival_us);

  /// Reads what the port holds (at most 32 reads of 64 bytes, to bound the time spent) and
  /// feeds it with arrival time now_us. Poll often: every chunk is stamped now_us, so a
  /// telegram ending in an earlier chunk of the same poll is stamped late by the later
  /// chunks' line time. kOk; kDataLoss (bytes were lost; counted in uart_overruns, the
  /// bytes read are still fed); any other status of the port is returned as is.
  hal::Status poll(hal::SerialPort& port, std::uint64_t now_us);

  bool scanAvailable() const { return scan_ready_; }

  /// Copies the newest complete scan: ranges in metres (NaN = invalid), and its info.
  /// kOk (the scan is consumed); kUnavailable (none since the last take); kInvalidArgument
  /// (ranges null or capacity < count; the scan is kept). info may be null.
  hal::Status takeScan(float* ranges, int capacity, ScanInfo* info);

  const Counters& counters() const { return counters_; }
  const Config& config() const { return cfg_; }
  /// Bytes buffered and not yet classified (a telegram in progress or a header being hunted).
  std::size_t pendingBytes() const { return tail_ - head_; }
  /// Drops buffered bytes and any pending scan; keeps the configuration and the counters.
  void reset();

  /// The vendor CRC16 over n bytes (see above).
  static std::uint16_t crc16(const std::uint8_t* data, std::size_t n);
  /// Line time of `bytes` bytes at `baud` (10 bits per byte), in us, rounded to nearest.
  static std::uint64_t transmissionTimeUs(std::uint64_t bytes, std::uint32_t baud);

 private:
  struct Inner {
    std::uint64_t start;  // stream position of the inner header's STX
    std::uint64_t end;    // one past its declared last byte
  };
  static constexpr int kMaxInner = 8;

  void push(std::uint8_t b);
  void process();
  bool headerAt(std::size_t idx, std::size_t* total) const;
  bool crcOkAt(std::size_t idx, std::size_t total) const;
  bool scanBufferedInners();
  void noteInnerHeaderAtTail();
  bool acceptInnerEndingAtTail();
  void abandonOuterFor(std::size_t idx);
  void registerFailure(std::uint64_t end);
  void discard(std::size_t k);
  void acceptAtHead();
  void handleTelegram(const std::uint8_t* t, std::size_t total);
  std::uint64_t absTail() const { return abs_head_ + (tail_ - head_); }
  std::size_t indexOf(std::uint64_t abs) const {
    return head_ + static_cast<std::size_t>(abs - abs_head_);
  }

  Config cfg_;
  Counters counters_{};
  std::uint16_t dist_mask_ = 0x1FFF;
  bool dazzle_bit_ = true;

  std::uint8_t buf_[kMaxTelegram] = {};
  std::size_t head_ = 0;
  std::size_t tail_ = 0;
  std::uint64_t abs_head_ = 0;    // stream position of buf_[head_]
  std::size_t outer_total_ = 0;   // > 0: header at head_ accepted; telegram size
  bool fail_pending_ = false;     // a rejected span not counted yet
  std::uint64_t fail_end_ = 0;    // its end (stream position)
  Inner inner_[kMaxInner] = {};
  int n_inner_ = 0;

  std::uint64_t chunk_arrival_us_ = 0;
  std::uint64_t chunk_end_ = 0;   // stream position one past the chunk's last byte

  float ranges_[kMaxValues] = {};
  ScanInfo info_{};
  bool scan_ready_ = false;
  bool new_scan_ = false;
};

}  // namespace odoerr::drivers
