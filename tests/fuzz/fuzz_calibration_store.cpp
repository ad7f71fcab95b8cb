// libFuzzer target: the calibration store's boot-time load() on an arbitrary flash image
// (through the fake NOR param store: two 128-byte sectors, the input written raw, the rest
// erased). Whatever load() restores must be plausible; a save() after it must succeed and
// be what the next load() restores.
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "odoerr/drivers/calibration_store.hpp"
#include "odoerr/hal/fake_param_store.hpp"

using odoerr::drivers::Calibration;
using odoerr::drivers::CalibrationStore;
using odoerr::drivers::LoadResult;

namespace {
constexpr std::size_t kSector = 128;
using Flash = odoerr::hal::FakeParamStore<2 * kSector, kSector>;
void check(bool ok) {
  if (!ok) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Flash flash;
  for (std::size_t i = 0; i < size && i < 2 * kSector; ++i) flash.setRaw(i, data[i]);
  CalibrationStore store(flash);
  Calibration cal{};
  const LoadResult r = store.load(&cal);
  check(r == LoadResult::kRestored || r == LoadResult::kNoneFound);
  if (r == LoadResult::kRestored) check(CalibrationStore::plausible(cal));
  check(store.counters().slots_invalid_at_boot <= 2);

  Calibration next{};
  next.drive = 1;
  next.count = 2;
  next.value[0] = 1.0f;
  next.value[1] = 0.5f;
  next.variance[0] = 1e-4f;
  next.variance[1] = 2e-4f;
  check(store.save(next) == odoerr::hal::Status::kOk);
  CalibrationStore again(flash);
  Calibration back{};
  check(again.load(&back) == LoadResult::kRestored);
  check(back.drive == 1 && back.count == 2 && back.value[1] == 0.5f && back.variance[1] == 2e-4f);
  return 0;
}
