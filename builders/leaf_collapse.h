#pragma once
// The last step of the bottom-up builders (lbvh, ploc): from their binary tree over single primitives
// to the common format, with leaves collapsed by the SAH. A subtree of up to max_leaf primitives becomes
// one leaf where, as a leaf, it costs no more than as an inner node over its children's best forms (the
// post-pass of Karras and Aila 2013, "Fast Parallel Construction of High-Quality Bounding Volume
// Hierarchies", section 4, and of the PLOC paper's builder); min_leaf primitives or fewer always do.
// The builders compute each node's costs as they create it (LeafCollapse::combine), bottom-up, so the
// collapse costs no pass of its own.
//
// Bottom-up trees can be deep: Karras's trees over clustered codes, or clustering along a chain of
// exponentially spaced primitives. finish_cluster_tree keeps every leaf within kMaxDepth - 1 of the root
// by rebuilding, by median splits, the largest subtrees that would reach deeper (see its comment).

#include <algorithm>
#include <cstdint>
#include <span>

#include "builders/top_down.h"
#include "core/aabb.h"
#include "core/bvh.h"
#include "core/huge_pages.h"

namespace sahbench {

/// A child reference: the index of an inner node, or kLeafTag | position of a primitive in the
/// builder's order (ClusterTree::order).
inline constexpr uint32_t kLeafTag = 1u << 31;
constexpr bool is_leaf_tag(uint32_t tag) {
  return (tag & kLeafTag) != 0;
}
constexpr uint32_t leaf_tag(uint32_t position) {
  return position | kLeafTag;
}
constexpr uint32_t tag_index(uint32_t tag) {
  return tag & ~kLeafTag;
}

/// What the collapse knows of a subtree: its cost as collapsed and its size. 16 bytes.
struct SubtreeCost {
  /// SAH cost of the subtree in its best collapsed form, times the half area of its box (so that a
  /// parent adds its children's costs without dividing). Computed in double, where the areas of float
  /// boxes never overflow; held in float, where such a cost may round to infinity, which compares
  /// as the largest (never NaN).
  float cost = 0.0f;
  uint32_t prims = 0;
  /// Nodes of the collapsed subtree: 1 when it becomes a leaf.
  uint32_t out_nodes = 0;
  /// Height of the binary subtree before the collapse: 0 for a single primitive.
  uint32_t height = 0;
};

/// An inner node of a bottom-up builder's binary tree: its box and its two children. 32 bytes.
struct ClusterNode {
  Aabb bounds;
  uint32_t child[2];
};

struct ClusterTree {
  std::span<ClusterNode> nodes;       ///< inner nodes
  std::span<SubtreeCost> costs;       ///< of each inner node's subtree
  std::span<const uint32_t> order;    ///< primitive at each leaf position
  std::span<const Aabb> leaf_bounds;  ///< box of the primitive at each leaf position (bounds_in_order)
  uint32_t root = 0;                  ///< a tag; leaf_tag(0) for a single primitive
  /// True where every subtree's leaves are consecutive positions, left to right (a radix tree over
  /// sorted codes): the output's references are then `order` itself, and no leaf's are gathered.
  bool leaves_in_order = false;
};

/// The primitives' boxes in leaf order: out[i] = prim_bounds[order[i]], gathered in parallel. The
/// passes over a cluster tree read the boxes of neighbouring leaf positions together; read through
/// `order` they are reads all over the scene's array, each a cache miss that the passes' atomics (a
/// locked exchange is a full fence on x86) keep from overlapping with the next. One gather with no
/// atomics lets the misses overlap, and leaves the passes sequential reads.
HugePageArray<Aabb> bounds_in_order(std::span<const Aabb> prim_bounds, std::span<const uint32_t> order);

/// The collapse rule: min_leaf, max_leaf and the SAH constants of a TopDownConfig (arity is ignored).
class LeafCollapse {
 public:
  explicit LeafCollapse(const TopDownConfig& config) : config_(config) {}

  /// A single primitive with box `bounds`.
  SubtreeCost leaf(const Aabb& bounds) const {
    return {static_cast<float>(half_area(bounds) * double(config_.cost.leaf_cost(1))), 1, 1, 0};
  }

  /// A node with box `bounds` over subtrees `left` and `right`: a leaf where the rule says so.
  SubtreeCost combine(const Aabb& bounds, const SubtreeCost& left, const SubtreeCost& right) const {
    const uint32_t prims = left.prims + right.prims;
    const uint32_t height = 1 + std::max(left.height, right.height);
    const double area = half_area(bounds);
    const double as_inner = area * double(config_.cost.c_trav) + double(left.cost) + double(right.cost);
    if (prims <= config_.max_leaf) {
      const double as_leaf = area * double(config_.cost.leaf_cost(prims));
      if (prims <= config_.min_leaf || as_leaf <= as_inner)
        return {static_cast<float>(as_leaf), prims, 1, height};
    }
    return {static_cast<float>(as_inner), prims, 1 + left.out_nodes + right.out_nodes, height};
  }

  /// The subtree under `tag` (a leaf tag or a node whose cost is set).
  SubtreeCost of(const ClusterTree& tree, uint32_t tag) const {
    if (is_leaf_tag(tag)) return leaf(tree.leaf_bounds[tag_index(tag)]);
    return tree.costs[tag];
  }

 private:
  // In double (see SubtreeCost::cost); the boxes are never empty.
  static double half_area(const Aabb& box) {
    const double x = double(box.max.x) - box.min.x;
    const double y = double(box.max.y) - box.min.y;
    const double z = double(box.max.z) - box.min.z;
    return x * y + y * z + z * x;
  }

  TopDownConfig config_;
};

/// The box of the subtree under `tag`.
inline const Aabb& tag_bounds(const ClusterTree& tree, uint32_t tag) {
  if (is_leaf_tag(tag)) return tree.leaf_bounds[tag_index(tag)];
  return tree.nodes[tag].bounds;
}

/// Deepest leaf the bottom-up builders write (the root at depth 0); the traversal stacks and the wide
/// layouts hold trees whose leaves are at depth kMaxDepth - 1 or less.
inline constexpr uint32_t kClusterDepthLimit = kMaxDepth - 1;

/// The common-format tree (arity 2) of `tree`, whose nodes' costs are all set by `rule`
/// (the same rule): nodes in depth-first order, each node's two children side by side, leaf references
/// in the order the leaves are met. Where the tree is deeper than kClusterDepthLimit, subtrees are
/// rebuilt first (in place, which is why the nodes are not const). The result does not depend on the
/// thread count.
Bvh finish_cluster_tree(const ClusterTree& tree, const LeafCollapse& rule);

}  // namespace sahbench
