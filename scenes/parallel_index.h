#pragma once
// The parallel loop the procedural generators share. Internal to scenes/.

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstddef>

namespace sahbench {

/// Items per task: large enough that scheduling is negligible next to generating them.
inline constexpr std::size_t kGeneratorGrain = 4096;

/// Calls body(i) for i in [0, n), in parallel. Every body writes only its own outputs, so the result
/// does not depend on the thread count.
template <typename Body>
void parallel_for_each_index(std::size_t n, Body body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kGeneratorGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) body(i);
                    });
}

}  // namespace sahbench
