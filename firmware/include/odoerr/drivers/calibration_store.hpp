// odoerr firmware: power-loss-safe calibration store on a hal::ParamStore (NOR flash).
//
// Persists the estimated systematic and non-systematic parameters and their variances
// across resets. Two slots (two sectors of the ParamStore, by default sectors 0 and 1) each
// hold at most one record at offset 0 of the sector:
//
//   offset  size  field                 encoding
//   ------  ----  --------------------  ------------------------------------------------
//        0     4  magic                 u32 LE 0x4C41434F (bytes 'O' 'C' 'A' 'L')
//        4     1  format version        u8 = 1
//        5     4  sequence number       u32 LE, newest + 1 at each save (wraps; compared
//                                        with serial-number arithmetic, RFC 1982 style)
//        9     2  payload length        u16 LE = 66
//       11     1  payload: drive id     u8
//       12     1  payload: count        u8, 0..8 (number of meaningful entries)
//       13    32  payload: value[8]     8 x IEEE-754 binary32, bit pattern as u32 LE
//       45    32  payload: variance[8]  8 x IEEE-754 binary32, bit pattern as u32 LE
//       77     4  CRC-32                u32 LE, IEEE 802.3 (reflected, poly 0xEDB88320,
//                                        init/xorout 0xFFFFFFFF) over bytes 0..76
//   total 81 bytes. Every field is serialised byte by byte (no struct memcpy, no host-endian
//   assumption). All 8 entries are stored bit-exactly, also those beyond `count`.
//
// save(): picks the slot NOT holding the newest valid record, erases it, programs bytes
// 0..76, then programs the CRC LAST, then reads the record back to verify it. The slot with
// the newest valid record is never erased nor programmed during a save, so a power loss at
// any byte of a save leaves the previous calibration intact: at the next boot load()
// returns it (or the new one, only if its record was complete). One save costs
// 1 erase + 81 programmed bytes = 82 byte-operations of the store.
//
// load() (at boot): reads both slots; a slot is valid if magic, version, length and CRC
// match and the payload is plausible (count <= 8, entries < count finite, variances >= 0);
// returns the valid record with the newest sequence number. An all-0xFF slot is blank; a
// slot that is neither blank nor valid (torn save, bit rot) is counted in
// slots_invalid_at_boot.
//
// No heap, no exceptions, no double arithmetic; not thread-safe (one owner).
#pragma once

#include <cstddef>
#include <cstdint>

#include "odoerr/hal/param_store.hpp"
#include "odoerr/hal/status.hpp"

namespace odoerr::drivers {

/// The persisted calibration (a POD).
struct Calibration {
  static constexpr std::size_t kMaxParams = 8;
  std::uint8_t drive;              ///< drive id
  std::uint8_t count;              ///< meaningful entries in value/variance, 0..kMaxParams
  float value[kMaxParams];         ///< systematic + non-systematic parameter estimates
  float variance[kMaxParams];      ///< their variances
};

/// Outcome of CalibrationStore::load().
enum class [[nodiscard]] LoadResult : std::uint8_t {
  kRestored = 0,     ///< a valid record was found and copied out
  kNoneFound,        ///< no valid record in either slot (first boot, or both corrupted)
  kInvalidArgument,  ///< null output, or a store geometry that cannot hold the two slots
  kStoreError,       ///< the store failed a read; *out is left untouched
};

class CalibrationStore {
 public:
  static constexpr std::uint32_t kMagic = 0x4C41434Fu;  // 'O' 'C' 'A' 'L' in LE byte order
  static constexpr std::uint8_t kVersion = 1;
  static constexpr std::size_t kHeaderSize = 11;
  static constexpr std::size_t kPayloadSize = 2 + 4 * 2 * Calibration::kMaxParams;  // 66
  static constexpr std::size_t kCrcOffset = kHeaderSize + kPayloadSize;             // 77
  static constexpr std::size_t kRecordSize = kCrcOffset + 4;                        // 81

  struct Counters {
    std::uint32_t saves_ok = 0;
    std::uint32_t saves_failed = 0;           ///< every save() that did not return kOk
    std::uint32_t slots_invalid_at_boot = 0;  ///< summed over load() calls
  };

  /// Uses sectors `sector_a` (slot 0) and `sector_b` (slot 1) of `store`. The geometry is
  /// checked lazily: load()/save() fail if the sectors are equal, out of range, or smaller
  /// than kRecordSize.
  explicit CalibrationStore(hal::ParamStore& store, std::size_t sector_a = 0,
                            std::size_t sector_b = 1);
  CalibrationStore(const CalibrationStore&) = delete;
  CalibrationStore& operator=(const CalibrationStore&) = delete;

  /// Boot-time restore: copies the newest valid record into *out.
  LoadResult load(Calibration* out);

  /// Persists `cal` with sequence = newest + 1 (1 on an empty store) into the other slot.
  /// kOk; kInvalidArgument (count > 8, non-finite entry < count, negative variance);
  /// kFailedPrecondition (bad geometry); the store's error (e.g. kInternal on power loss:
  /// the previous calibration stays intact); kInternal when the read-back differs.
  /// Scans the slots first if load() has not (successfully) done so.
  hal::Status save(const Calibration& cal);

  const Counters& counters() const { return counters_; }
  /// True when the newest valid record is known (after a load/save that found or wrote one).
  bool hasNewest() const { return scanned_ && has_newest_; }
  /// Slot (0 or 1) and sequence number of the newest valid record; meaningful if hasNewest().
  std::size_t newestSlot() const { return newest_slot_; }
  std::uint32_t newestSequence() const { return newest_seq_; }

  /// True when `cal` may be saved (see save()).
  static bool plausible(const Calibration& cal);
  /// CRC-32/IEEE 802.3 (the zlib/Ethernet CRC); crc32("123456789") == 0xCBF43926.
  static std::uint32_t crc32(const std::uint8_t* data, std::size_t n);
  /// Serialises a full record (CRC included) into `out`.
  static void encode(const Calibration& cal, std::uint32_t sequence,
                     std::uint8_t (&out)[kRecordSize]);
  /// Validates a record; on success fills *cal and *sequence (either may be null).
  static bool decode(const std::uint8_t (&rec)[kRecordSize], Calibration* cal,
                     std::uint32_t* sequence);
  /// Serial-number order: true when `a` is newer than `b` (a - b in [1, 2^31 - 1] mod 2^32).
  static constexpr bool newer(std::uint32_t a, std::uint32_t b) {
    return a != b && ((a - b) & 0x80000000u) == 0u;
  }

 private:
  bool geometryOk() const;
  std::size_t slotOffset(std::size_t slot) const;
  /// Reads and classifies both slots; sets scanned_/has_newest_/newest_*.
  hal::Status scan(std::uint32_t* invalid_slots, Calibration* newest);

  hal::ParamStore& store_;
  std::size_t sector_[2];
  Counters counters_;
  bool scanned_ = false;
  bool has_newest_ = false;
  std::size_t newest_slot_ = 0;
  std::uint32_t newest_seq_ = 0;
};

}  // namespace odoerr::drivers
