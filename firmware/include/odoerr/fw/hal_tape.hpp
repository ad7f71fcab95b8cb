// The HAL tape: what the devices showed the firmware at each poll of a simulated drive,
// recorded on the host by the HAL simulator and replayed on the target by HAL
// implementations that read it (firmware/apps/fw_replay). Little-endian:
//
//   header | "ODHT" | u32 version=1 | u32 drive (0 sync, 1 diff) | u32 counter_bits |
//          | f32 ticks_per_unit_a | f32 ticks_per_unit_b | f32 x0 | f32 y0 | f32 theta0 |
//          | f32 k0[2] | u32 baud | u32 polls |
//   poll   | u32 t_lo | u32 t_hi | u32 raw_count_a | u32 raw_count_b | u16 n | u8 bytes[n] |
#pragma once

#include <cstdint>
#include <cstring>

#include "odoerr/fw/tape.hpp"

namespace odoerr::fw {

constexpr std::uint32_t kHalTapeVersion = 1;
constexpr std::size_t kHalTapeHeaderBytes = 4 + 4 * 13;
constexpr std::size_t kHalTapePollBytes = 18;  // without the serial bytes

struct HalTapeHeader {
  std::uint32_t drive = 1;
  std::uint32_t counter_bits = 16;
  float ticks_a = 1, ticks_b = 1;
  float x0 = 0, y0 = 0, theta0 = 0;
  float k0[2] = {0, 0};
  std::uint32_t baud = 38400;
  std::uint32_t polls = 0;
};

inline void encodeHalTapeHeader(const HalTapeHeader& h, std::uint8_t* out) {
  std::memcpy(out, "ODHT", 4);
  putU32(out + 4, kHalTapeVersion);
  putU32(out + 8, h.drive);
  putU32(out + 12, h.counter_bits);
  putF32(out + 16, h.ticks_a);
  putF32(out + 20, h.ticks_b);
  putF32(out + 24, h.x0);
  putF32(out + 28, h.y0);
  putF32(out + 32, h.theta0);
  putF32(out + 36, h.k0[0]);
  putF32(out + 40, h.k0[1]);
  putU32(out + 44, h.baud);
  putU32(out + 48, h.polls);
}

inline bool decodeHalTapeHeader(const std::uint8_t* in, HalTapeHeader* h) {
  if (std::memcmp(in, "ODHT", 4) != 0 || getU32(in + 4) != kHalTapeVersion) return false;
  h->drive = getU32(in + 8);
  h->counter_bits = getU32(in + 12);
  h->ticks_a = getF32(in + 16);
  h->ticks_b = getF32(in + 20);
  h->x0 = getF32(in + 24);
  h->y0 = getF32(in + 28);
  h->theta0 = getF32(in + 32);
  h->k0[0] = getF32(in + 36);
  h->k0[1] = getF32(in + 40);
  h->baud = getU32(in + 44);
  h->polls = getU32(in + 48);
  return h->drive <= 1 && (h->counter_bits == 16 || h->counter_bits == 32) && h->ticks_a > 0.0f &&
         h->ticks_b > 0.0f && h->k0[0] > 0.0f && h->baud > 0;
}

}  // namespace odoerr::fw
