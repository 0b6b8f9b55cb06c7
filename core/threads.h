#pragma once
// The number of threads the caller's TBB work may use: the smaller of the current arena's concurrency and
// a tbb::global_control limit (the harness runs each thread count of a config under one), at least 1.
// The arena's alone ignores the global limit.

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstddef>

namespace sahbench {

inline int caller_threads() {
  const auto global = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  const auto arena = static_cast<std::size_t>(tbb::this_task_arena::max_concurrency());
  return static_cast<int>(std::max<std::size_t>(1, std::min(global, arena)));
}

}  // namespace sahbench
