// sim_host: encodes SICK LMS2xx telegrams exactly as a scanner sends them, so the host
// simulator can drive the firmware's parser (odoerr/drivers/lms2xx.hpp, which documents
// the format) with real wire bytes. Host-only (doubles allowed), header-only, no heap.
//
//   STX 0x02 | ADR | LEN (LE) = CMD + data + STATUS bytes | CMD | data | STATUS | CRC16 (LE)
//   CRC16: the vendor routine over STX .. STATUS (implemented here independently of the
//   parser's copy, so the round-trip tests compare two implementations).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace odoerr::sim {

inline constexpr std::uint8_t kLms2xxStx = 0x02;
inline constexpr std::uint8_t kLms2xxReplyAddress = 0x80;
inline constexpr std::uint8_t kLms2xxCmdMeasuredValues = 0xB0;
/// Status byte of normal replies, as in real scanner replies (e.g. 02 80 03 00 A0 00 10 16 0A).
inline constexpr std::uint8_t kLms2xxStatusOk = 0x10;
/// Default measuring mode (8/80 m, 13-bit distance): largest distance and special codes.
inline constexpr std::uint16_t kLms2xxMaxDistance = 0x1FF6;
inline constexpr std::uint16_t kLms2xxNoReturn = 0x1FF7;  ///< measured value > maximum
inline constexpr std::uint16_t kLms2xxInvalid = 0x1FFF;   ///< measured value not valid
inline constexpr std::size_t kLms2xxOverhead = 6;         ///< STX, ADR, LEN(2), CRC(2)

/// The vendor CRC16 (generator 0x8005, current and previous byte XORed in each step).
inline std::uint16_t lms2xxCrc16(const std::uint8_t* p, std::size_t n) {
  std::uint16_t crc = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const bool carry = (crc & 0x8000u) != 0;
    crc = static_cast<std::uint16_t>(crc << 1);
    if (carry) crc = static_cast<std::uint16_t>(crc ^ 0x8005u);
    const unsigned prev = i > 0 ? p[i - 1] : 0u;
    crc = static_cast<std::uint16_t>(crc ^ ((prev << 8) | p[i]));
  }
  return crc;
}

/// Size of a telegram whose LEN is `len`.
constexpr std::size_t lms2xxTelegramSize(std::size_t len) { return len + kLms2xxOverhead; }

/// Any telegram: STX, `address`, LEN = 1 + payload_len, `command`, `payload` (for replies
/// the payload ends with the status byte), CRC. Returns the bytes written, 0 if `out` is too
/// small or LEN would exceed 0xFFFF.
inline std::size_t encodeLms2xxTelegram(std::uint8_t address, std::uint8_t command,
                                        const std::uint8_t* payload, std::size_t payload_len,
                                        std::uint8_t* out, std::size_t capacity) {
  const std::size_t len = 1 + payload_len;
  const std::size_t total = lms2xxTelegramSize(len);
  if (out == nullptr || len > 0xFFFFu || capacity < total ||
      (payload == nullptr && payload_len > 0)) {
    return 0;
  }
  out[0] = kLms2xxStx;
  out[1] = address;
  out[2] = static_cast<std::uint8_t>(len & 0xFFu);
  out[3] = static_cast<std::uint8_t>(len >> 8);
  out[4] = command;
  for (std::size_t i = 0; i < payload_len; ++i) out[5 + i] = payload[i];
  const std::uint16_t crc = lms2xxCrc16(out, total - 2);
  out[total - 2] = static_cast<std::uint8_t>(crc & 0xFFu);
  out[total - 1] = static_cast<std::uint8_t>(crc >> 8);
  return total;
}

/// The value word for a range in metres (default measuring mode, no field/dazzle bits):
/// round(range / unit); NaN, +-inf and ranges above the largest distance -> kLms2xxNoReturn
/// (what the scanner sends when nothing is in range); negative ranges -> kLms2xxInvalid.
inline std::uint16_t lms2xxRangeCode(double range_m, bool unit_mm) {
  if (std::isnan(range_m) || std::isinf(range_m)) return kLms2xxNoReturn;
  if (range_m < 0.0) return kLms2xxInvalid;
  const double q = std::round(range_m * (unit_mm ? 1000.0 : 100.0));
  if (q > static_cast<double>(kLms2xxMaxDistance)) return kLms2xxNoReturn;
  return static_cast<std::uint16_t>(q);
}

/// A measured-values reply (CMD 0xB0, ADR 0x80) with n ranges in metres, unit mm (8.182 m
/// maximum, 1 mm steps) or cm (81.82 m, 1 cm steps): count word n | unit << 14, then one
/// word per range, then `status`. Returns the bytes written (n * 2 + 10), 0 if n is outside
/// [0, 1023], ranges is null with n > 0, or `out` is too small.
inline std::size_t encodeLms2xxScan(const double* ranges_m, int n, bool unit_mm,
                                    std::uint8_t* out, std::size_t capacity,
                                    std::uint8_t status = kLms2xxStatusOk) {
  if (n < 0 || n > 0x3FF || (ranges_m == nullptr && n > 0) || out == nullptr) return 0;
  const std::size_t len = 1 + 2 + 2 * static_cast<std::size_t>(n) + 1;
  const std::size_t total = lms2xxTelegramSize(len);
  if (capacity < total) return 0;
  out[0] = kLms2xxStx;
  out[1] = kLms2xxReplyAddress;
  out[2] = static_cast<std::uint8_t>(len & 0xFFu);
  out[3] = static_cast<std::uint8_t>(len >> 8);
  out[4] = kLms2xxCmdMeasuredValues;
  const unsigned count_word = static_cast<unsigned>(n) | (unit_mm ? 0x4000u : 0u);
  out[5] = static_cast<std::uint8_t>(count_word & 0xFFu);
  out[6] = static_cast<std::uint8_t>(count_word >> 8);
  for (int i = 0; i < n; ++i) {
    const std::uint16_t w = lms2xxRangeCode(ranges_m[i], unit_mm);
    out[7 + 2 * i] = static_cast<std::uint8_t>(w & 0xFFu);
    out[8 + 2 * i] = static_cast<std::uint8_t>(w >> 8);
  }
  out[total - 3] = status;
  const std::uint16_t crc = lms2xxCrc16(out, total - 2);
  out[total - 2] = static_cast<std::uint8_t>(crc & 0xFFu);
  out[total - 1] = static_cast<std::uint8_t>(crc >> 8);
  return total;
}

}  // namespace odoerr::sim
