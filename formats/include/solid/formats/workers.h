// The one worker pool of every stage (convert, sample, render, the optimizer): plain
// std::threads over work that each stage splits itself, deterministically (results land
// in slots by index, never in the order threads finish), so output bytes are the same for
// any thread count.
//
// Plain threads, not oneTBB: the loops are few and coarse (one asset, layout or image a
// step, milliseconds each), and `solid sample` of 2,000 layouts at 640x480 on 2 threads
// took as long with tbb::parallel_for (133.7 s, 137.3 s) as with these (132.2 s, 135.8 s;
// a shared 2-core machine, the same report), so the simpler stays.
#pragma once

#include <algorithm>
#include <chrono>
#include <functional>
#include <thread>
#include <utility>
#include <vector>

namespace solid {

// `requested` threads, or one per core when it is 0 or less.
inline int WorkerCount(int requested) {
  return requested > 0 ? requested : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

// `threads` copies of `work` on threads of their own, started at construction and joined
// by Join or the destructor: for loops whose calling thread does something else meanwhile
// (writes results in order, reports progress).
class BackgroundWorkers {
 public:
  BackgroundWorkers(int threads, const std::function<void()>& work) {
    for (int t = 0; t < threads; ++t) threads_.emplace_back(work);
  }
  ~BackgroundWorkers() { Join(); }
  BackgroundWorkers(const BackgroundWorkers&) = delete;
  BackgroundWorkers& operator=(const BackgroundWorkers&) = delete;

  void Join() {
    for (std::thread& t : threads_) {
      if (t.joinable()) t.join();
    }
  }

 private:
  std::vector<std::thread> threads_;
};

// Runs `work` on `threads` threads, on the calling thread alone when that is 1, and
// returns when every copy has.
template <typename Work>
void RunOnThreads(int threads, const Work& work) {
  if (threads <= 1) {
    work();
    return;
  }
  BackgroundWorkers pool(threads, work);
}

inline double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace solid
