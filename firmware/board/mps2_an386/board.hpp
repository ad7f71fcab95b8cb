// The mps2-an386 board support visible to applications.
#pragma once

#include "stack_paint.hpp"  // odoerr::board::stackHighWaterBytes()
