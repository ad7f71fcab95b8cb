// A counting global allocator for the no-heap checks of the firmware suites
// (test_calibration_store.cpp, test_lms2xx.cpp): one replacement of operator new per
// program (heap_counter.cpp), armed around the code under test only. test_no_heap.cpp
// has its own, stricter hook (malloc wrapped at link time) in an executable of its own.
#pragma once

#include <atomic>

namespace odoerr::test {
extern std::atomic<bool> g_heap_armed;  // count operator new calls while set
extern std::atomic<long> g_heap_allocs;
}  // namespace odoerr::test
