// Cooperative cancellation of long library calls (render, convert, sample, optimize,
// export). The caller owns a CancelFlag and passes its address in the call's options; the
// call polls it between units of work (an image, an asset, a layout) and stops at the next
// point where stopping leaves nothing half-written. Libraries never install signal
// handlers: the `solid` CLI sets the flag from its SIGINT/SIGTERM handler, which is allowed
// because a store to a lock-free atomic is async-signal-safe.
#pragma once

#include <atomic>

namespace solid {

using CancelFlag = std::atomic<bool>;
static_assert(CancelFlag::is_always_lock_free, "set from a signal handler");

inline bool CancelRequested(const CancelFlag* flag) {
  return flag != nullptr && flag->load(std::memory_order_relaxed);
}

}  // namespace solid
