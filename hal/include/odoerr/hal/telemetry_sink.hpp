// odoerr HAL: where telemetry frames go (a UART, a radio, a semihosting file...).
#pragma once

#include <cstddef>
#include <cstdint>

#include "odoerr/hal/status.hpp"

namespace odoerr::hal {

class TelemetrySink {
 public:
  virtual ~TelemetrySink() = default;
  TelemetrySink() = default;
  TelemetrySink(const TelemetrySink&) = delete;
  TelemetrySink& operator=(const TelemetrySink&) = delete;

  /// Sends one complete frame; never blocks. kOk; kResourceExhausted: the frame was dropped
  /// (the caller counts it); kInvalidArgument.
  Status send(const std::uint8_t* frame, std::size_t n) {
    if (frame == nullptr && n > 0) return Status::kInvalidArgument;
    return DoSend(frame, n);
  }

 private:
  virtual Status DoSend(const std::uint8_t* frame, std::size_t n) = 0;
};

}  // namespace odoerr::hal
