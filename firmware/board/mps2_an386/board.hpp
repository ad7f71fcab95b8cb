// The mps2-an386 board support visible to applications.
#pragma once

#include <cstdint>

namespace odoerr::board {
/// Deepest stack use so far, from the start-up stack paint (bytes).
std::uint32_t stackHighWaterBytes();
}  // namespace odoerr::board
