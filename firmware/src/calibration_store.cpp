// odoerr firmware: power-loss-safe calibration store (see calibration_store.hpp).
#include "odoerr/drivers/calibration_store.hpp"

#include <cstring>
#include <limits>

namespace odoerr::drivers {

static_assert(sizeof(float) == 4 && std::numeric_limits<float>::is_iec559,
              "the record stores IEEE-754 binary32 bit patterns");
static_assert(CalibrationStore::kPayloadSize == 66 && CalibrationStore::kRecordSize == 81,
              "record layout documented in the header");

namespace {

constexpr std::size_t kOffMagic = 0;
constexpr std::size_t kOffVersion = 4;
constexpr std::size_t kOffSequence = 5;
constexpr std::size_t kOffLength = 9;
constexpr std::size_t kOffDrive = 11;
constexpr std::size_t kOffCount = 12;
constexpr std::size_t kOffValue = 13;
constexpr std::size_t kOffVariance = kOffValue + 4 * Calibration::kMaxParams;  // 45

void putU16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v & 0xFFu);
  p[1] = static_cast<std::uint8_t>((v >> 8) & 0xFFu);
}
void putU32(std::uint8_t* p, std::uint32_t v) {
  p[0] = static_cast<std::uint8_t>(v & 0xFFu);
  p[1] = static_cast<std::uint8_t>((v >> 8) & 0xFFu);
  p[2] = static_cast<std::uint8_t>((v >> 16) & 0xFFu);
  p[3] = static_cast<std::uint8_t>((v >> 24) & 0xFFu);
}
std::uint16_t getU16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint32_t getU32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
std::uint32_t floatBits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);  // a scalar bit copy; the byte order is then explicit
  return u;
}
float bitsFloat(std::uint32_t u) {
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}
bool finite(float f) { return ((floatBits(f) >> 23) & 0xFFu) != 0xFFu; }

}  // namespace

CalibrationStore::CalibrationStore(hal::ParamStore& store, std::size_t sector_a,
                                   std::size_t sector_b)
    : store_(store), sector_{sector_a, sector_b} {}

bool CalibrationStore::plausible(const Calibration& cal) {
  if (cal.count > Calibration::kMaxParams) return false;
  for (std::size_t i = 0; i < cal.count; ++i) {
    if (!finite(cal.value[i]) || !finite(cal.variance[i])) return false;
    if (!(cal.variance[i] >= 0.0f)) return false;
  }
  return true;
}

std::uint32_t CalibrationStore::crc32(const std::uint8_t* data, std::size_t n) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= data[i];
    for (int b = 0; b < 8; ++b) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xFFFFFFFFu;
}

void CalibrationStore::encode(const Calibration& cal, std::uint32_t sequence,
                              std::uint8_t (&out)[kRecordSize]) {
  putU32(out + kOffMagic, kMagic);
  out[kOffVersion] = kVersion;
  putU32(out + kOffSequence, sequence);
  putU16(out + kOffLength, static_cast<std::uint16_t>(kPayloadSize));
  out[kOffDrive] = cal.drive;
  out[kOffCount] = cal.count;
  for (std::size_t i = 0; i < Calibration::kMaxParams; ++i) {
    putU32(out + kOffValue + 4 * i, floatBits(cal.value[i]));
    putU32(out + kOffVariance + 4 * i, floatBits(cal.variance[i]));
  }
  putU32(out + kCrcOffset, crc32(out, kCrcOffset));
}

bool CalibrationStore::decode(const std::uint8_t (&rec)[kRecordSize], Calibration* cal,
                              std::uint32_t* sequence) {
  if (getU32(rec + kOffMagic) != kMagic) return false;
  if (rec[kOffVersion] != kVersion) return false;
  if (getU16(rec + kOffLength) != kPayloadSize) return false;
  if (getU32(rec + kCrcOffset) != crc32(rec, kCrcOffset)) return false;
  Calibration c{};
  c.drive = rec[kOffDrive];
  c.count = rec[kOffCount];
  for (std::size_t i = 0; i < Calibration::kMaxParams; ++i) {
    c.value[i] = bitsFloat(getU32(rec + kOffValue + 4 * i));
    c.variance[i] = bitsFloat(getU32(rec + kOffVariance + 4 * i));
  }
  if (!plausible(c)) return false;
  if (cal != nullptr) *cal = c;
  if (sequence != nullptr) *sequence = getU32(rec + kOffSequence);
  return true;
}

bool CalibrationStore::geometryOk() const {
  const std::size_t sector = store_.sectorSize();
  if (sector < kRecordSize) return false;
  const std::size_t sectors = store_.size() / sector;
  return sector_[0] != sector_[1] && sector_[0] < sectors && sector_[1] < sectors;
}

std::size_t CalibrationStore::slotOffset(std::size_t slot) const {
  return sector_[slot] * store_.sectorSize();
}

hal::Status CalibrationStore::scan(std::uint32_t* invalid_slots, Calibration* newest) {
  scanned_ = false;
  has_newest_ = false;
  std::uint32_t invalid = 0;
  bool found = false;
  std::size_t best_slot = 0;
  std::uint32_t best_seq = 0;
  Calibration best{};
  for (std::size_t slot = 0; slot < 2; ++slot) {
    std::uint8_t rec[kRecordSize];
    const hal::Status s = store_.read(slotOffset(slot), rec, kRecordSize);
    if (!hal::ok(s)) return s;
    Calibration c{};
    std::uint32_t seq = 0;
    if (decode(rec, &c, &seq)) {
      if (!found || newer(seq, best_seq)) {
        found = true;
        best_slot = slot;
        best_seq = seq;
        best = c;
      }
    } else {
      bool blank = true;
      for (std::size_t i = 0; i < kRecordSize; ++i) blank = blank && rec[i] == 0xFFu;
      if (!blank) ++invalid;
    }
  }
  scanned_ = true;
  has_newest_ = found;
  newest_slot_ = best_slot;
  newest_seq_ = best_seq;
  if (invalid_slots != nullptr) *invalid_slots = invalid;
  if (found && newest != nullptr) *newest = best;
  return hal::Status::kOk;
}

LoadResult CalibrationStore::load(Calibration* out) {
  if (out == nullptr || !geometryOk()) return LoadResult::kInvalidArgument;
  std::uint32_t invalid = 0;
  Calibration c{};
  if (!hal::ok(scan(&invalid, &c))) return LoadResult::kStoreError;
  counters_.slots_invalid_at_boot += invalid;
  if (!has_newest_) return LoadResult::kNoneFound;
  *out = c;
  return LoadResult::kRestored;
}

hal::Status CalibrationStore::save(const Calibration& cal) {
  hal::Status s = hal::Status::kOk;
  if (!geometryOk()) {
    s = hal::Status::kFailedPrecondition;
  } else if (!plausible(cal)) {
    s = hal::Status::kInvalidArgument;
  } else if (!scanned_) {
    // Never erase a slot before knowing which one holds the newest record.
    s = scan(nullptr, nullptr);
  }
  if (!hal::ok(s)) {
    ++counters_.saves_failed;
    return s;
  }

  const std::size_t target = has_newest_ ? 1 - newest_slot_ : 0;
  const std::uint32_t sequence = has_newest_ ? newest_seq_ + 1u : 1u;
  std::uint8_t rec[kRecordSize];
  encode(cal, sequence, rec);
  const std::size_t base = slotOffset(target);

  // From here on only `target` changes; the cached newest slot stays the other one, so a
  // failed save is simply retried into the same (non-newest) slot.
  s = store_.erase(sector_[target]);
  if (hal::ok(s)) s = store_.program(base, rec, kCrcOffset);
  if (hal::ok(s)) s = store_.program(base + kCrcOffset, rec + kCrcOffset, kRecordSize - kCrcOffset);
  if (hal::ok(s)) {
    std::uint8_t back[kRecordSize];
    s = store_.read(base, back, kRecordSize);
    if (hal::ok(s) && std::memcmp(back, rec, kRecordSize) != 0) s = hal::Status::kInternal;
  }
  if (!hal::ok(s)) {
    ++counters_.saves_failed;
    return s;
  }
  has_newest_ = true;
  newest_slot_ = target;
  newest_seq_ = sequence;
  ++counters_.saves_ok;
  return hal::Status::kOk;
}

}  // namespace odoerr::drivers
