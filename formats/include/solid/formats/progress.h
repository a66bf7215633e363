#pragma once

#include <cstdint>
#include <functional>

namespace solid {
// Called from the calling thread as work advances; `total` is the number of units
// (shards, images...) known at the start. May be empty.
using ProgressCallback = std::function<void(int64_t done, int64_t total)>;
}  // namespace solid
