// odoerr HAL: a small non-volatile parameter store with flash semantics.
#pragma once

#include <cstddef>
#include <cstdint>

#include "odoerr/hal/status.hpp"

namespace odoerr::hal {

/// Flash-like region of size() bytes in sectors of sectorSize() bytes. Erased bytes read
/// 0xFF; program() can only clear bits (1 -> 0) of erased bytes, as NOR flash does.
class ParamStore {
 public:
  virtual ~ParamStore() = default;
  ParamStore() = default;
  ParamStore(const ParamStore&) = delete;
  ParamStore& operator=(const ParamStore&) = delete;

  std::size_t size() const { return DoSize(); }
  std::size_t sectorSize() const { return DoSectorSize(); }

  /// Erases sector `index` to 0xFF. kOk; kOutOfRange; kInternal (power lost / fault: the
  /// sector content is then undefined).
  Status erase(std::size_t index) {
    if (sectorSize() == 0 || index >= size() / sectorSize()) return Status::kOutOfRange;
    return DoErase(index);
  }
  /// Programs `n` bytes at `offset`. kOk; kOutOfRange; kInvalidArgument;
  /// kInternal (power lost / fault: a prefix of the bytes may have been written).
  Status program(std::size_t offset, const std::uint8_t* data, std::size_t n) {
    if (data == nullptr && n > 0) return Status::kInvalidArgument;
    if (offset > size() || n > size() - offset) return Status::kOutOfRange;
    return DoProgram(offset, data, n);
  }
  /// Reads `n` bytes at `offset`. kOk; kOutOfRange; kInvalidArgument; kInternal.
  Status read(std::size_t offset, std::uint8_t* out, std::size_t n) const {
    if (out == nullptr && n > 0) return Status::kInvalidArgument;
    if (offset > size() || n > size() - offset) return Status::kOutOfRange;
    return DoRead(offset, out, n);
  }

 private:
  virtual std::size_t DoSize() const = 0;
  virtual std::size_t DoSectorSize() const = 0;
  virtual Status DoErase(std::size_t index) = 0;
  virtual Status DoProgram(std::size_t offset, const std::uint8_t* data, std::size_t n) = 0;
  virtual Status DoRead(std::size_t offset, std::uint8_t* out, std::size_t n) const = 0;
};

}  // namespace odoerr::hal
