// odoerr HAL: a non-blocking serial port.
#pragma once

#include <cstddef>
#include <cstdint>

#include "odoerr/hal/status.hpp"

namespace odoerr::hal {

class SerialPort {
 public:
  virtual ~SerialPort() = default;
  SerialPort() = default;
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  /// Copies up to `capacity` bytes that have already arrived into `buf`; never blocks.
  /// *n_read = bytes copied (0 when none). kOk; kDataLoss: the receiver overran and bytes
  /// were lost before the ones returned (they are still returned); kInvalidArgument.
  Status read(std::uint8_t* buf, std::size_t capacity, std::size_t* n_read) {
    if (n_read == nullptr || (buf == nullptr && capacity > 0)) return Status::kInvalidArgument;
    *n_read = 0;
    return DoRead(buf, capacity, n_read);
  }
  /// Queues `n` bytes for sending; never blocks. *n_written = bytes accepted.
  /// kOk (all accepted); kResourceExhausted (fewer accepted); kInvalidArgument.
  Status write(const std::uint8_t* data, std::size_t n, std::size_t* n_written) {
    if (n_written == nullptr || (data == nullptr && n > 0)) return Status::kInvalidArgument;
    *n_written = 0;
    return DoWrite(data, n, n_written);
  }

 private:
  virtual Status DoRead(std::uint8_t* buf, std::size_t capacity, std::size_t* n_read) = 0;
  virtual Status DoWrite(const std::uint8_t* data, std::size_t n, std::size_t* n_written) = 0;
};

}  // namespace odoerr::hal
