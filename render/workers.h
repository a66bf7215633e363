// Threads and timing shared by the render stages (internal to solid::render): plain
// std::threads over work that each stage splits itself, deterministically.
#pragma once

#include <algorithm>
#include <chrono>
#include <thread>
#include <vector>

namespace solid::render {

// `requested` threads, or one per core when it is 0 or less.
inline int WorkerCount(int requested) {
  return requested > 0 ? requested : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

// Runs `work` on `threads` threads, on the calling thread alone when that is 1, and
// returns when every copy has.
template <typename Work>
void RunOnThreads(int threads, const Work& work) {
  if (threads <= 1) {
    work();
    return;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work);
  for (std::thread& t : pool) t.join();
}

inline double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace solid::render
