// The two C++ runtime hooks a heap-free, exception-free image still references:
// - __cxa_pure_virtual: a pure virtual call (a bug) ends the run with code 98;
// - operator delete: referenced by the deleting destructors of classes with virtual
//   destructors (the HAL interfaces), never called because nothing is allocated. Calling it
//   would be heap use: it ends the run with code 99.
#include <cstddef>

#include "semihosting.hpp"

extern "C" void __cxa_pure_virtual() { odoerr::board::shExit(98); }

void operator delete(void*) noexcept { odoerr::board::shExit(99); }
void operator delete(void*, std::size_t) noexcept { odoerr::board::shExit(99); }
