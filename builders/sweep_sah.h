#pragma once
/// Full-sweep SAH builder: evaluates every split between consecutive primitives in centroid order on all
/// three axes (MacDonald and Booth 1990; the O(n log n) presorted form of Wald and Havran 2006, "On
/// building fast kd-trees for ray tracing, and on doing that in O(N log N)", applied to BVHs). The
/// reference for binned builders: its chosen split never costs more than a binned one for the same node.
/// Both offer the same size splits (size_split.h) beside their planes.

#include <span>

#include "builders/top_down.h"
#include "core/build_input.h"

namespace sahbench {

struct SweepSahParams {
  TopDownConfig top_down;
};

Bvh build_sweep_sah(const BuildInput& input, const SweepSahParams& params);

/// The best full-sweep split of the primitives `prims` of `input`, by the same code the builder uses.
Split find_sweep_split(const BuildInput& input, std::span<const uint32_t> prims,
                       const SweepSahParams& params);

}  // namespace sahbench
