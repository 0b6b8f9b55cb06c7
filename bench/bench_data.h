#pragma once
// Inputs shared by the micro-benchmarks: deterministic from fixed seeds, built once per process.

#include <vector>

#include "core/bvh.h"
#include "core/ray.h"
#include "core/triangle.h"

namespace sahbench::bench {

/// `count` random triangles in [-10, 10]^3 with edges up to 1 (a soup, so trees are not trivial).
const std::vector<Triangle>& soup(std::size_t count);
/// Rays from random points of the soup's box towards random points of it.
const std::vector<Ray>& rays(std::size_t count);
/// A binned SAH tree over soup(count).
const Bvh& binary_tree(std::size_t count);

}  // namespace sahbench::bench
