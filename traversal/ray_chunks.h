#pragma once
// How layouts spread a batch of rays over TBB tasks: chunks of a fixed number of rays, each a task (the
// harness calls a layout once per batch, the layout its kernel once per chunk). Internal to the harness.

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <cstddef>

#include "traversal/layout.h"

namespace sahbench {

/// Calls `body(begin, end)` on chunks of at most `chunk` rays that cover [0, count), in parallel.
template <class Body>
void for_each_ray_chunk(std::size_t count, std::size_t chunk, Body body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, chunk),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
}

/// The sum of `counts(begin, end)` (the TraceCounts of rays [begin, end)) over chunks of at most
/// `chunk` rays that cover [0, count), counted in parallel.
template <class Counts>
TraceCounts sum_over_ray_chunks(std::size_t count, std::size_t chunk, Counts counts) {
  auto add = [](TraceCounts a, const TraceCounts& b) {
    a.rays += b.rays;
    a.nodes_visited += b.nodes_visited;
    a.prims_tested += b.prims_tested;
    return a;
  };
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, count, chunk), TraceCounts{},
      [&](const tbb::blocked_range<std::size_t>& r, TraceCounts acc) {
        return add(acc, counts(r.begin(), r.end()));
      },
      add);
}

}  // namespace sahbench
