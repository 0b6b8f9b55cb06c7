#pragma once
// A tiny builder for the traversal tests only, so that the kernels can be tested while the real builders
// are written: object median split on the longest centroid axis, cut into `arity` equal parts, leaves of
// 1..max_leaf_prims primitives, children stored contiguously as the common format requires. No SAH.

#include <cstdint>
#include <span>

#include "core/bvh.h"
#include "core/triangle.h"

namespace sahbench::test {

/// Leaf size of the test trees: the 1..4 range a SAH builder typically ends up with.
inline constexpr uint32_t kTestMaxLeafPrims = 4;

/// A tree over `triangles` of the given arity (2, 4 or 8); arity 2 is the classic median split.
/// An empty input gives a Bvh with no nodes.
Bvh build_median_bvh(std::span<const Triangle> triangles, uint32_t arity = 2,
                     uint32_t max_leaf_prims = kTestMaxLeafPrims);

}  // namespace sahbench::test
