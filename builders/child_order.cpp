#include "builders/child_order.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace sahbench {

namespace {

double triangle_area(const Triangle& t) {
  // In double: the sum over a large subtree must not lose its small triangles.
  const double ax = double(t.v1.x) - t.v0.x, ay = double(t.v1.y) - t.v0.y, az = double(t.v1.z) - t.v0.z;
  const double bx = double(t.v2.x) - t.v0.x, by = double(t.v2.y) - t.v0.y, bz = double(t.v2.z) - t.v0.z;
  const double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
  return 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
}

// A subtree's triangle area and its SAH cost weighted by area (relative cost times the half area).
struct Subtree {
  double triangle_area = 0.0;
  double weighted_cost = 0.0;
};

class KeyPass {
 public:
  KeyPass(const Bvh& bvh, std::span<const Triangle> triangles, const SahCost& cost, std::vector<double>& keys)
      : bvh_(bvh), triangles_(triangles), cost_(cost), keys_(keys) {}

  // Post-order; the depth is at most kMaxDepth, which every builder guarantees.
  Subtree visit(uint32_t index) {
    const Node& node = bvh_.nodes[index];
    const double half_area = node.bounds.half_area();
    Subtree s;
    if (node.is_leaf()) {
      for (uint32_t r = node.first; r < node.first + node.prim_count; ++r)
        s.triangle_area += triangle_area(triangles_[bvh_.prim_refs[r]]);
      s.weighted_cost = half_area * cost_.leaf_cost(node.prim_count);
    } else {
      s.weighted_cost = half_area * cost_.c_trav;
      for (uint32_t c = 0; c < node.child_count; ++c) {
        const Subtree child = visit(node.first + c);
        s.triangle_area += child.triangle_area;
        s.weighted_cost += child.weighted_cost;
      }
    }
    // P / E[cost] = min(1, A / H) / (weighted / H). A flat box (H = 0) that holds triangles is a wall a
    // ray meets only edge-on: key 0, last.
    keys_[index] = half_area > 0.0 && s.weighted_cost > 0.0
                       ? std::min(1.0, s.triangle_area / half_area) * half_area / s.weighted_cost
                       : 0.0;
    return s;
  }

 private:
  const Bvh& bvh_;
  std::span<const Triangle> triangles_;
  const SahCost& cost_;
  std::vector<double>& keys_;
};

}  // namespace

std::vector<double> occlusion_order_keys(const Bvh& bvh, std::span<const Triangle> triangles, const SahCost& cost) {
  std::vector<double> keys(bvh.nodes.size());
  if (!bvh.nodes.empty()) KeyPass(bvh, triangles, cost, keys).visit(0);
  return keys;
}

void order_children_for_occlusion(Bvh& bvh, std::span<const Triangle> triangles, const SahCost& cost) {
  std::vector<double> keys = occlusion_order_keys(bvh, triangles, cost);
  std::vector<uint32_t> order;
  std::vector<Node> nodes;
  std::vector<double> sorted_keys;
  for (std::size_t p = 0; p < bvh.nodes.size(); ++p) {
    const Node parent = bvh.nodes[p];
    if (parent.is_leaf() || parent.child_count < 2) continue;
    // A child's record carries its own children and references, so moving the records (with their
    // keys) moves the subtrees; the parent's range [first, first + child_count) stays the same.
    order.resize(parent.child_count);
    std::iota(order.begin(), order.end(), parent.first);
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return keys[a] > keys[b]; });
    nodes.clear();
    sorted_keys.clear();
    for (uint32_t i : order) {
      nodes.push_back(bvh.nodes[i]);
      sorted_keys.push_back(keys[i]);
    }
    std::copy(nodes.begin(), nodes.end(), bvh.nodes.begin() + parent.first);
    std::copy(sorted_keys.begin(), sorted_keys.end(), keys.begin() + parent.first);
  }
}

}  // namespace sahbench
