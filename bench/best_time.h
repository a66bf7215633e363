// Best-of-N wall time of a call, for the comparison benchmarks: the minimum is the figure
// least disturbed by other load on a shared machine.
#pragma once

#include <algorithm>
#include <chrono>

namespace solid::bench {

template <typename F>
double BestMs(int repeat, F&& f) {
  double best = 1e300;
  for (int r = 0; r < repeat; ++r) {
    const auto start = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  return best;
}

}  // namespace solid::bench
