#include "parallel.hpp"

#include <algorithm>
#include <atomic>
#include <thread>

namespace odoerr::sim::diag {

void runParallel(std::vector<std::function<void()>>& tasks, int threads) {
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t i = next++; i < tasks.size(); i = next++) tasks[i]();
  };
  std::vector<std::thread> pool;
  for (int i = 1; i < std::max(1, threads); ++i) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
}

}  // namespace odoerr::sim::diag
