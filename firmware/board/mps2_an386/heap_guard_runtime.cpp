// Runtime heap guard, for comparison images only (batch_replay): Eigen's dynamic-size
// GEMM keeps a malloc fallback for blocks too large for alloca, referenced but not taken
// at these sizes. Any allocation that does happen ends the run with code 96, so the
// instruction counts can never include heap work. Firmware images use heap_trap.cpp
// (a link-time error) instead.
#include <cstddef>

#include "semihosting.hpp"

extern "C" {
void* __wrap_malloc(std::size_t) { odoerr::board::shExit(96); }
void* __wrap_calloc(std::size_t, std::size_t) { odoerr::board::shExit(96); }
void* __wrap_realloc(void*, std::size_t) { odoerr::board::shExit(96); }
void __wrap_free(void*) { odoerr::board::shExit(96); }
void* __wrap__malloc_r(void*, std::size_t) { odoerr::board::shExit(96); }
}
