// diagnose's thread pool: the filter runs of a ranking or held-out comparison are
// independent, so they run on the cores the options allow.
#pragma once

#include <functional>
#include <vector>

namespace odoerr::sim::diag {

/// Runs tasks on `threads` workers (the calling thread is one of them).
void runParallel(std::vector<std::function<void()>>& tasks, int threads);

}  // namespace odoerr::sim::diag
