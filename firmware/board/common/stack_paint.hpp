// The stack's high-water mark, shared by the boards: the start-up paints the stack below its
// own frame with a pattern before main runs; the deepest word no longer holding it is the
// deepest the stack has been. The linker script defines _sstack (lowest address) and _estack.
#pragma once

#include <cstdint>

extern "C" std::uint32_t _sstack, _estack;

namespace odoerr::board {

constexpr std::uint32_t kStackPaint = 0xC0FFEE5Au;

/// Paints the stack from _sstack to 64 bytes below the caller's frame. Called by the
/// start-up code before any other function that could use the stack below it.
__attribute__((always_inline)) inline void paintStack() {
  std::uint32_t* sp;
  __asm__ volatile("mov %0, sp" : "=r"(sp));
  for (std::uint32_t* p = &_sstack; p < sp - 16; ++p) *p = kStackPaint;
}

/// Deepest stack use so far (bytes), from the paint.
std::uint32_t stackHighWaterBytes();

}  // namespace odoerr::board
