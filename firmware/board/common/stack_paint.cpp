// The stack's high-water mark from the start-up paint (stack_paint.hpp).
#include "stack_paint.hpp"

namespace odoerr::board {

std::uint32_t stackHighWaterBytes() {
  const std::uint32_t* p = &_sstack;
  while (p < &_estack && *p == kStackPaint) ++p;
  return static_cast<std::uint32_t>(reinterpret_cast<const char*>(&_estack) - reinterpret_cast<const char*>(p));
}

}  // namespace odoerr::board
