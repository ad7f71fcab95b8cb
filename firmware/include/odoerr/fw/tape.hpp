// The core-replay tape: a recorded drive (encoder increments and ranges per cycle) that the
// host simulator writes and both the host and the Cortex-M4F images replay through the
// same float estimator. Little-endian binary:
//
//   header  | "ODTP" | u32 version=1 | u32 drive (0 sync, 1 diff; bit 8: dry run) | u32 cycles | u32 beams |
//           | f32 x0 | f32 y0 | f32 theta0 | f32 k0[2] | u32 record_every |
//   cycle   | f32 input_a | f32 input_b | f32 range[beams]            (cycles times)
//
// Output of a replay ("ODOU"): one record every record_every cycles and after the last:
//   | u32 cycle | f32 state[N] | f32 sigma[N] | f32 k[M] | f32 k_sigma[M] |
// then a trailer | u32 0xFFFFFFFF | u32 beams_used | u32 beams_rejected | u32 of_updates |
// u32 stack_high_water_bytes | u32 estimator_bytes (sizeof the AKF + OF + map + laser) |.
#pragma once

#include <cstdint>
#include <cstring>

namespace odoerr::fw {

constexpr std::uint32_t kTapeVersion = 1;

struct TapeHeader {
  std::uint32_t drive = 1;  ///< 0 sync, 1 diff
  std::uint32_t cycles = 0;
  std::uint32_t beams = 36;
  float x0 = 0, y0 = 0, theta0 = 0;
  float k0[2] = {0, 0};
  std::uint32_t record_every = 100;
  /// Dry run (bit 8 of the drive word): decode the tape but skip the filter, so that the
  /// harness's own cost can be subtracted from instruction counts.
  bool dry = false;
};

/// Little-endian (de)serialisation byte by byte: no struct memcpy, no endian assumption.
inline void putU32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
inline std::uint32_t getU32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= std::uint32_t(p[i]) << (8 * i);
  return v;
}
inline void putF32(std::uint8_t* p, float f) {
  std::uint32_t v;
  std::memcpy(&v, &f, 4);
  putU32(p, v);
}
inline float getF32(const std::uint8_t* p) {
  const std::uint32_t v = getU32(p);
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}

constexpr std::size_t kTapeHeaderBytes = 4 + 4 * 4 + 4 * 5 + 4;

inline void encodeHeader(const TapeHeader& h, std::uint8_t* out) {
  std::memcpy(out, "ODTP", 4);
  putU32(out + 4, kTapeVersion);
  putU32(out + 8, h.drive | (h.dry ? 0x100u : 0u));
  putU32(out + 12, h.cycles);
  putU32(out + 16, h.beams);
  putF32(out + 20, h.x0);
  putF32(out + 24, h.y0);
  putF32(out + 28, h.theta0);
  putF32(out + 32, h.k0[0]);
  putF32(out + 36, h.k0[1]);
  putU32(out + 40, h.record_every);
}

/// Returns false for a wrong magic, version or an impossible field.
inline bool decodeHeader(const std::uint8_t* in, TapeHeader* h) {
  if (std::memcmp(in, "ODTP", 4) != 0 || getU32(in + 4) != kTapeVersion) return false;
  const std::uint32_t drive_word = getU32(in + 8);
  h->drive = drive_word & 0xFFu;
  h->dry = (drive_word & 0x100u) != 0;
  h->cycles = getU32(in + 12);
  h->beams = getU32(in + 16);
  h->x0 = getF32(in + 20);
  h->y0 = getF32(in + 24);
  h->theta0 = getF32(in + 28);
  h->k0[0] = getF32(in + 32);
  h->k0[1] = getF32(in + 36);
  h->record_every = getU32(in + 40);
  // K0 must be positive and finite (the OF cannot start from zero noise).
  const bool k_ok = h->k0[0] > 0.0f && h->k0[0] < 1.0f && (h->drive == 1 || (h->k0[1] > 0.0f && h->k0[1] < 1.0f));
  return h->drive <= 1 && h->beams > 0 && h->beams <= 64 && h->record_every > 0 && k_ok;
}

}  // namespace odoerr::fw
