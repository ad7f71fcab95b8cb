// The counting operator new of heap_counter.hpp.
#include "heap_counter.hpp"

#include <cstdlib>
#include <new>

namespace odoerr::test {
std::atomic<bool> g_heap_armed{false};
std::atomic<long> g_heap_allocs{0};
}  // namespace odoerr::test

void* operator new(std::size_t n) {
  if (odoerr::test::g_heap_armed.load(std::memory_order_relaxed)) {
    odoerr::test::g_heap_allocs.fetch_add(1, std::memory_order_relaxed);
  }
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
// Out of line, so GCC does not pair the inlined free() with operator new
// (-Wmismatched-new-delete false positive).
__attribute__((noinline)) void operator delete(void* p) noexcept { std::free(p); }
__attribute__((noinline)) void operator delete(void* p, std::size_t) noexcept { std::free(p); }
