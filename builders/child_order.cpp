#include "builders/child_order.h"

#include <tbb/task_group.h>

#include <algorithm>
#include <cmath>

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

// Post-order over the tree: each node's key, and, with `reorder`, each node's children sorted by their
// keys once their subtrees are done (moving a child's record moves its subtree, since the record holds
// its children's and references' positions). The top levels run their children as parallel tasks: the
// subtrees are disjoint, and every sum is taken in the same order as sequentially.
class KeyPass {
 public:
  /// `reorder` is the same tree as `bvh`, to sort children in, or nullptr to only compute keys.
  KeyPass(const Bvh& bvh, std::span<const Triangle> triangles, const SahCost& cost, std::vector<double>& keys,
          Bvh* reorder)
      : bvh_(bvh), triangles_(triangles), cost_(cost), keys_(keys), reorder_(reorder) {}

  // The depth is at most kMaxDepth, which every builder guarantees.
  Subtree visit(uint32_t index, uint32_t depth) {
    const Node node = bvh_.nodes[index];
    const double half_area = node.bounds.half_area();
    Subtree s;
    if (node.is_leaf()) {
      for (uint32_t r = node.first; r < node.first + node.prim_count; ++r) {
        // Leaves are visited in the order of their references, so the triangles a few references on are
        // the next ones read: fetched ahead, since the references jump around the triangle array.
        if (r + kPrefetchRefs < bvh_.prim_refs.size())
          __builtin_prefetch(&triangles_[bvh_.prim_refs[r + kPrefetchRefs]]);
        s.triangle_area += triangle_area(triangles_[bvh_.prim_refs[r]]);
      }
      s.weighted_cost = half_area * cost_.leaf_cost(node.prim_count);
    } else {
      s.weighted_cost = half_area * cost_.c_trav;
      Subtree children[kMaxArity];
      if (depth < kParallelDepth) {
        tbb::task_group group;
        for (uint32_t c = 0; c < node.child_count; ++c)
          group.run([this, &children, &node, c, depth] { children[c] = visit(node.first + c, depth + 1); });
        group.wait();
      } else {
        for (uint32_t c = 0; c < node.child_count; ++c) children[c] = visit(node.first + c, depth + 1);
      }
      for (uint32_t c = 0; c < node.child_count; ++c) {
        s.triangle_area += children[c].triangle_area;
        s.weighted_cost += children[c].weighted_cost;
      }
      if (reorder_ != nullptr) sort_children(node);
    }
    // P / E[cost] = min(1, A / H) / (weighted / H). A flat box (H = 0) that holds triangles is a wall a
    // ray meets only edge-on: key 0, last.
    // A box whose area overflowed (inf / inf) gives NaN: key 0 as well, so that the sort below compares
    // numbers only.
    const double key = half_area > 0.0 && s.weighted_cost > 0.0
                           ? std::min(1.0, s.triangle_area / half_area) * half_area / s.weighted_cost
                           : 0.0;
    keys_[index] = key >= 0.0 ? key : 0.0;
    return s;
  }

 private:
  // Levels whose nodes visit their children as parallel tasks: at most 8 + 64 + 512 tasks in an 8-wide
  // tree, enough to balance 2 to 16 threads; below them a task's subtree is ~1/512 of the tree (only speed
  // depends on it).
  static constexpr uint32_t kParallelDepth = 3;
  // References ahead whose triangles the leaf loop prefetches: 32 made the pass 20-25% faster on Sponza
  // and the 1M terrain (16: a little less); only speed depends on it.
  static constexpr uint32_t kPrefetchRefs = 32;

  // Largest key first; stable, so equal keys keep the builder's order.
  void sort_children(const Node& parent) {
    const uint32_t count = parent.child_count;
    // Insertion sort: stable, and for at most kMaxArity children it needs no buffer, where
    // std::stable_sort allocates one per call (13-17% of this pass on Sponza and the 1M terrain).
    uint32_t order[kMaxArity];
    for (uint32_t c = 0; c < count; ++c) {
      const uint32_t child = parent.first + c;
      uint32_t at = c;
      for (; at > 0 && keys_[order[at - 1]] < keys_[child]; --at) order[at] = order[at - 1];
      order[at] = child;
    }
    Node nodes[kMaxArity];
    double keys[kMaxArity];
    for (uint32_t c = 0; c < count; ++c) {
      nodes[c] = bvh_.nodes[order[c]];
      keys[c] = keys_[order[c]];
    }
    std::copy(nodes, nodes + count, reorder_->nodes.begin() + parent.first);
    std::copy(keys, keys + count, keys_.begin() + parent.first);
  }

  const Bvh& bvh_;
  std::span<const Triangle> triangles_;
  const SahCost& cost_;
  std::vector<double>& keys_;
  Bvh* reorder_;
};

}  // namespace

std::vector<double> occlusion_order_keys(const Bvh& bvh, std::span<const Triangle> triangles,
                                         const SahCost& cost) {
  std::vector<double> keys(bvh.nodes.size());
  if (!bvh.nodes.empty()) KeyPass(bvh, triangles, cost, keys, nullptr).visit(0, 0);
  return keys;
}

void order_children_for_occlusion(Bvh& bvh, std::span<const Triangle> triangles, const SahCost& cost) {
  std::vector<double> keys(bvh.nodes.size());
  if (!bvh.nodes.empty()) KeyPass(bvh, triangles, cost, keys, &bvh).visit(0, 0);
}

}  // namespace sahbench
