// odoerr HAL: status codes shared by every device interface.
#pragma once

#include <cstdint>

namespace odoerr::hal {

/// Result of a device call. [[nodiscard]]: a status is never silently dropped.
enum class [[nodiscard]] Status : std::uint8_t {
  kOk = 0,
  kUnavailable,         ///< nothing ready yet / device busy; try again later
  kInvalidArgument,     ///< bad pointer, size or index
  kOutOfRange,          ///< address or size outside the device
  kDataLoss,            ///< data were lost before this call (e.g. UART overrun)
  kResourceExhausted,   ///< partial write: the device took fewer bytes
  kFailedPrecondition,  ///< the device state forbids the call (e.g. programming unerased flash)
  kInternal,            ///< hardware fault (e.g. power lost during a flash operation)
};

constexpr bool ok(Status s) { return s == Status::kOk; }

}  // namespace odoerr::hal
