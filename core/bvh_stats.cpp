#include "core/bvh_stats.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace sahbench {
namespace {

// Aabb::half_area in double: a scene with coordinates near 1e38 has float extents and products that
// overflow to inf, and inf / inf made its SAH cost NaN.
double half_area_in_double(const Aabb& box) {
  if (box.is_empty()) return 0.0;
  const double x = static_cast<double>(box.max.x) - box.min.x;
  const double y = static_cast<double>(box.max.y) - box.min.y;
  const double z = static_cast<double>(box.max.z) - box.min.z;
  return x * y + y * z + z * x;
}

}  // namespace

double sah_cost(const Bvh& bvh, const SahCost& cost) {
  if (bvh.nodes.empty()) return 0.0;
  const double root_area = half_area_in_double(bvh.root().bounds);
  // A flat or point-sized scene has no area to weigh by; every node then counts fully.
  const bool degenerate = !(root_area > 0.0);
  double total = 0.0;
  for (const Node& node : bvh.nodes) {
    const double weight = degenerate ? 1.0 : half_area_in_double(node.bounds) / root_area;
    total += weight * (node.is_leaf() ? cost.leaf_cost(node.prim_count) : cost.c_trav);
  }
  return total;
}

BvhStats compute_stats(const Bvh& bvh, std::size_t prim_count, const SahCost& cost) {
  BvhStats stats;
  stats.nodes = static_cast<uint32_t>(bvh.nodes.size());
  stats.bytes = bvh.bytes();
  stats.sah_cost = sah_cost(bvh, cost);
  stats.refs_per_prim = prim_count ? static_cast<double>(bvh.prim_refs.size()) / prim_count : 0.0;
  if (bvh.nodes.empty()) return stats;

  // Depth-first walk with an explicit stack of (node, depth); the validator guarantees a tree.
  std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};
  double depth_sum = 0.0;
  uint64_t refs_in_leaves = 0;
  while (!stack.empty()) {
    const auto [index, depth] = stack.back();
    stack.pop_back();
    const Node& node = bvh.nodes[index];
    stats.max_depth = std::max(stats.max_depth, depth);
    if (node.is_leaf()) {
      ++stats.leaves;
      depth_sum += depth;
      refs_in_leaves += node.prim_count;
      stats.max_leaf_size = std::max<uint32_t>(stats.max_leaf_size, node.prim_count);
      continue;
    }
    for (uint32_t c = 0; c < node.child_count; ++c) stack.emplace_back(node.first + c, depth + 1);
  }
  stats.mean_leaf_depth = depth_sum / stats.leaves;
  stats.mean_leaf_size = static_cast<double>(refs_in_leaves) / stats.leaves;
  return stats;
}

}  // namespace sahbench
