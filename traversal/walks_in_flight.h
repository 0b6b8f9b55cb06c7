#pragma once
// Single rays traced with several walks in flight. One ray's walk down a tree is a chain of dependent
// loads, tests and branches; where the tree does not fit in the core's caches each step waits on memory.
// Walks of independent rays stepped in turn let the core overlap one ray's wait with the others' work
// (the software counterpart of a GPU's warps hiding memory latency, Aila and Laine 2009).
//
// The walks start together on neighbouring rays and the next group starts when all of them have ended.
// Neighbouring rays visit mostly the same nodes, and stepped in lock-step the later ones find in the
// cache the lines the first one asked for. Refilling a slot with the next ray as soon as its walk ended
// (asynchronous memory access chaining, Kocberber, Falsafi and Grot 2015) keeps every slot busy but lets
// the walks drift apart, and with four walks traced the primary and shadow rays of Sponza's atrium on
// bvh2_packed 35 to 41% slower than two walks in turn (scripts/ab.py on configs/tune.toml's scenes),
// the terrain's 7 to 17% faster.

#include <cstddef>
#include <optional>
#include <utility>

namespace sahbench::detail {

/// Rays [0, n) in groups of up to kWalks neighbours whose walks (of type `Walk`, `bool Walk::step()`:
/// whether it has steps left) are stepped in turn. `start(slot, j)` either emplaces ray j's walk into
/// `slot` (a std::optional<Walk>) and returns true, or answers ray j itself (a ray that misses the root,
/// say) and returns false. `finish(j, walk)` takes ray j's answer once its walk's step() returned false.
/// Each walk runs as it would alone, so each ray's answer is the one it gets alone.
template <class Walk, std::size_t kWalks, class Start, class Finish>
[[gnu::always_inline]] inline void step_interleaved(std::size_t n, Start&& start, Finish&& finish) {
  std::optional<Walk> walks[kWalks];
  std::size_t ray[kWalks] = {};
  std::size_t next = 0;
  while (next < n) {
    std::size_t live = 0;
    for (std::size_t s = 0; s < kWalks && next < n; ++next) {
      if (!start(walks[s], next)) {
        walks[s].reset();  // start() may have emplaced a walk with no step to take
        continue;
      }
      ray[s++] = next;
      ++live;
    }
    // The slots unrolled, so that each walk is an object of its own to the compiler, as named ones are.
    auto step_all = [&]<std::size_t... s>(std::index_sequence<s...>) {
      (
          [&] {
            if (walks[s] && !walks[s]->step()) {
              finish(ray[s], *walks[s]);
              walks[s].reset();
              --live;
            }
          }(),
          ...);
    };
    while (live != 0) step_all(std::make_index_sequence<kWalks>{});
  }
}

}  // namespace sahbench::detail
