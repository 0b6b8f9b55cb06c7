#pragma once
// How layouts spread a batch of rays over TBB tasks: chunks of a fixed number of rays, a few to a task (the
// harness calls a layout once per batch, the layout its kernel once per chunk). Internal to the harness.

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/partitioner.h>

#include <algorithm>
#include <cstddef>

#include "traversal/layout.h"

namespace sahbench {

/// Calls `body(begin, end)` on the chunks [i * chunk, (i + 1) * chunk) that cover [0, count) (the last one
/// shorter), in parallel. Chunks start at multiples of `chunk`, so that a packet kernel's packets (a
/// divisor of it) hold the rays the ray set put side by side, as Embree's packet calls get them.
///
/// Every run of kChunksPerTask chunks is a task of its own, as the harness runs each of Embree's 1024-ray
/// chunks (embree_trace.cpp), so that the threads end a ray set at most one task apart. TBB's default
/// auto_partitioner splits a range only when a thread steals from it: where rays' costs vary across the
/// image, a set could end with one thread alone on a long run of chunks. Fewer chunks per task cost
/// their scheduling more often, which shows on cheap primary rays.
inline constexpr std::size_t kChunksPerTask = 4;

template <class Body>
void for_each_ray_chunk(std::size_t count, std::size_t chunk, Body body) {
  const std::size_t chunks = (count + chunk - 1) / chunk;
  const std::size_t tasks = (chunks + kChunksPerTask - 1) / kChunksPerTask;
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, tasks, 1),
      [&](const tbb::blocked_range<std::size_t>& r) {
        const std::size_t last = std::min(chunks, r.end() * kChunksPerTask);
        for (std::size_t i = r.begin() * kChunksPerTask; i < last; ++i)
          body(i * chunk, std::min(count, (i + 1) * chunk));
      },
      tbb::simple_partitioner());
}

/// The sum of `counts(begin, end)` (the TraceCounts of rays [begin, end)) over chunks of at most
/// `chunk` rays that cover [0, count), counted in parallel.
template <class Counts>
TraceCounts sum_over_ray_chunks(std::size_t count, std::size_t chunk, Counts counts) {
  auto add = [](TraceCounts a, const TraceCounts& b) {
    a.rays += b.rays;
    a.nodes_visited += b.nodes_visited;
    a.prims_tested += b.prims_tested;
    a.leaves_visited += b.leaves_visited;
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
