// The core-replay tape: a recorded drive (encoder increments and ranges per cycle) that the
// host simulator writes and both the host and the Cortex-M4F images replay through the
// same float estimator. Little-endian binary:
//
//   header  | "ODTP" | u32 version=2 | u32 drive word | u32 cycles | u32 beams |
//           | f32 x0 | f32 y0 | f32 theta0 | f32 k0[2] | u32 record_every |
//           | f32 laser angle_min | f32 angle_inc | f32 range_max | f32 sigma |  (laser frame = robot frame)
//   cycle   | f32 input_a | f32 input_b | f32 range[beams]            (cycles times)
//
// The drive word: bits 0-7 the drive (0 sync, 1 diff), bit 8 a dry run, bits 16-27 the
// beams the filter fuses per scan (0: all; see LaserGeometry's beam selection).
//
// Output of a replay ("ODOU"): one record every record_every cycles and after the last:
//   | u32 cycle | f32 state[N] | f32 sigma[N] | f32 k[M] | f32 k_sigma[M] |
// then a trailer | u32 0xFFFFFFFF | u32 beams_used | u32 beams_rejected | u32 of_updates |
// u32 stack_high_water_bytes | u32 estimator_bytes (sizeof the AKF + OF + map + laser) |.
#pragma once

#include <cstdint>
#include <cstring>

namespace odoerr::fw {

constexpr std::uint32_t kTapeVersion = 2;

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
  /// Beams fused per scan (0: all of them).
  std::uint32_t beams_used = 0;
  /// The range finder (beams as above; mounted at the robot's origin, facing forward).
  float angle_min = 0, angle_inc = 0, range_max = 0, sigma = 0;
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

constexpr std::size_t kTapeHeaderBytes = 4 + 4 * 4 + 4 * 5 + 4 + 4 * 4;

inline void encodeHeader(const TapeHeader& h, std::uint8_t* out) {
  std::memcpy(out, "ODTP", 4);
  putU32(out + 4, kTapeVersion);
  putU32(out + 8, h.drive | (h.dry ? 0x100u : 0u) | ((h.beams_used & 0xFFFu) << 16));
  putU32(out + 12, h.cycles);
  putU32(out + 16, h.beams);
  putF32(out + 20, h.x0);
  putF32(out + 24, h.y0);
  putF32(out + 28, h.theta0);
  putF32(out + 32, h.k0[0]);
  putF32(out + 36, h.k0[1]);
  putU32(out + 40, h.record_every);
  putF32(out + 44, h.angle_min);
  putF32(out + 48, h.angle_inc);
  putF32(out + 52, h.range_max);
  putF32(out + 56, h.sigma);
}

/// Returns false for a wrong magic, version or an impossible field (more than max_beams
/// ranges per cycle among them).
inline bool decodeHeader(const std::uint8_t* in, TapeHeader* h, std::uint32_t max_beams = 64) {
  if (std::memcmp(in, "ODTP", 4) != 0 || getU32(in + 4) != kTapeVersion) return false;
  const std::uint32_t drive_word = getU32(in + 8);
  h->drive = drive_word & 0xFFu;
  h->dry = (drive_word & 0x100u) != 0;
  h->beams_used = (drive_word >> 16) & 0xFFFu;
  h->cycles = getU32(in + 12);
  h->beams = getU32(in + 16);
  h->x0 = getF32(in + 20);
  h->y0 = getF32(in + 24);
  h->theta0 = getF32(in + 28);
  h->k0[0] = getF32(in + 32);
  h->k0[1] = getF32(in + 36);
  h->record_every = getU32(in + 40);
  h->angle_min = getF32(in + 44);
  h->angle_inc = getF32(in + 48);
  h->range_max = getF32(in + 52);
  h->sigma = getF32(in + 56);
  // K0 must be positive and finite (the OF cannot start from zero noise).
  const bool k_ok = h->k0[0] > 0.0f && h->k0[0] < 1.0f && (h->drive == 1 || (h->k0[1] > 0.0f && h->k0[1] < 1.0f));
  const bool laser_ok = h->range_max > 0.0f && h->sigma > 0.0f && h->angle_inc == h->angle_inc &&
                        h->angle_min == h->angle_min;  // not NaN
  return h->drive <= 1 && h->beams > 0 && h->beams <= max_beams && h->beams_used <= h->beams &&
         h->record_every > 0 && k_ok && laser_ok;
}

}  // namespace odoerr::fw
