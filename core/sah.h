#pragma once
// The one SAH cost model (Goldsmith and Salmon 1987; MacDonald and Booth 1990) used by every builder
// and by the statistics, so that a tree's cost is computed with the constants it was built with.

#include <cstdint>

namespace sahbench {

struct SahCost {
  /// Cost of visiting one inner node (box tests of its children), relative to one triangle test.
  /// 1 : 1 as in Embree's and madmann91/bvh's SAH statistics, so SAH figures compare with theirs.
  float c_trav = 1.0f;
  /// Cost of one ray/triangle test, or of one block test when `block` > 1.
  float c_isect = 1.0f;
  /// Primitives tested together, as one SIMD test (the bvh4/bvh8 layouts test 4 triangles at once): a
  /// leaf of n primitives costs c_isect per started block, ceil(n / block), so leaves fill their blocks
  /// (Embree's sahBlockSize, kernels/builders/heuristic_binning.h). 1: every primitive costs c_isect.
  /// A power of two.
  uint32_t block = 1;

  constexpr uint32_t blocks(uint32_t count) const { return (count + block - 1) / block; }

  /// Cost of a leaf holding `count` primitives, relative to its own area.
  constexpr float leaf_cost(uint32_t count) const { return c_isect * static_cast<float>(blocks(count)); }

  /// Cost of splitting a node of half-area `parent_area` into two children, relative to the parent's
  /// area. The terms are left unnormalised (area * count) so callers may compare candidates without
  /// dividing.
  constexpr float split_cost(float parent_area, float left_area, uint32_t left_count, float right_area,
                             uint32_t right_count) const {
    return split_cost_from_weighted(parent_area, left_area * static_cast<float>(blocks(left_count)) +
                                                     right_area * static_cast<float>(blocks(right_count)));
  }

  /// split_cost from the children's weighted area, left_area * blocks(left_count) + right_area *
  /// blocks(right_count).
  /// Split searches minimise that sum and convert only the winner; the conversion is monotone, so the
  /// winner is the same as when every candidate is converted.
  constexpr float split_cost_from_weighted(float parent_area, float weighted_area) const {
    return c_trav + c_isect * weighted_area / parent_area;
  }

  friend constexpr bool operator==(const SahCost&, const SahCost&) = default;
};

}  // namespace sahbench
