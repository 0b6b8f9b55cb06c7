#include "builders/leaf_collapse.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/huge_pages.h"

namespace sahbench {
namespace {

// Levels that halving n primitives down to single ones takes: ceil(log2 n).
uint32_t halving_height(uint32_t n) {
  return static_cast<uint32_t>(std::bit_width(n - 1));
}

// Rebuilds, in place, the subtrees that make the tree deeper than kClusterDepthLimit. From the root
// down, a node whose subtree fits under it is kept as it is; a node that does not fit is kept while each
// of its children could still be rebuilt by halving below it, and is rebuilt by halving otherwise. Every
// node this reaches could itself be halved below its depth (true of the root: a balanced tree over
// 2^31 primitives is 31 deep), so every rebuilt subtree fits, and a subtree is rebuilt only where
// keeping it down to its children would not. Only pathological inputs get here, so it runs serially.
class DepthBound {
 public:
  DepthBound(const ClusterTree& tree, const LeafCollapse& rule) : tree_(tree), rule_(rule) {}

  void run() {
    std::vector<std::pair<uint32_t, uint32_t>> stack{{tree_.root, 0}};  // (tag, depth)
    while (!stack.empty()) {
      const uint32_t tag = stack.back().first;
      const uint32_t depth = stack.back().second;  // clang 14 cannot capture a structured binding
      stack.pop_back();
      if (is_leaf_tag(tag)) continue;
      const ClusterNode& node = tree_.nodes[tag];
      if (depth + tree_.costs[tag].height <= kClusterDepthLimit) continue;
      auto fits = [&](uint32_t child) {
        return depth + 1 + halving_height(rule_.of(tree_, child).prims) <= kClusterDepthLimit;
      };
      if (fits(node.child[0]) && fits(node.child[1])) {
        stack.emplace_back(node.child[0], depth + 1);
        stack.emplace_back(node.child[1], depth + 1);
      } else {
        rebuild(tag);
      }
    }
    refresh(tree_.root);
  }

 private:
  // Replaces the subtree of inner node `root` by a median-split tree over the same primitives, in the
  // same node slots (a binary tree over m primitives has m - 1 inner nodes whatever its shape), with
  // `root` keeping its slot. Costs are set by refresh() afterwards.
  void rebuild(uint32_t root) {
    slots_.clear();
    leaves_.clear();
    std::vector<uint32_t> stack{root};  // the subtree may be far deeper than any call stack
    while (!stack.empty()) {
      const uint32_t tag = stack.back();
      stack.pop_back();
      if (is_leaf_tag(tag)) {
        leaves_.push_back(tag_index(tag));
        continue;
      }
      slots_.push_back(tag);
      stack.push_back(tree_.nodes[tag].child[1]);
      stack.push_back(tree_.nodes[tag].child[0]);
    }
    next_slot_ = 0;
    halve(0, static_cast<uint32_t>(leaves_.size()));
  }

  // Builds the node over leaves_[begin, end) into the next slot: the object median on the axis of largest
  // centre extent, ties broken by leaf position (as BinnedSplitter::partition_median). Returns its tag.
  uint32_t halve(uint32_t begin, uint32_t end) {
    if (end - begin == 1) return leaf_tag(leaves_[begin]);
    const uint32_t slot = slots_[next_slot_++];
    Aabb centres;
    for (uint32_t i = begin; i < end; ++i) centres.extend(prim_box(leaves_[i]).center());
    const auto axis = largest_axis(centres.extent());
    const uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(leaves_.begin() + begin, leaves_.begin() + mid, leaves_.begin() + end,
                     [&](uint32_t a, uint32_t b) {
                       const float ca = prim_box(a).center()[axis], cb = prim_box(b).center()[axis];
                       return ca < cb || (ca == cb && a < b);
                     });
    const uint32_t left = halve(begin, mid);
    const uint32_t right = halve(mid, end);
    ClusterNode& node = tree_.nodes[slot];
    node.child[0] = left;
    node.child[1] = right;
    node.bounds = merge(tag_bounds(tree_, left), tag_bounds(tree_, right));
    return slot;
  }

  const Aabb& prim_box(uint32_t position) const { return tree_.leaf_bounds[position]; }

  // Recomputes every node's costs, children first; the tree is now shallow enough to recurse.
  SubtreeCost refresh(uint32_t tag) {
    if (is_leaf_tag(tag)) return rule_.of(tree_, tag);
    ClusterNode& node = tree_.nodes[tag];
    const SubtreeCost left = refresh(node.child[0]);
    const SubtreeCost right = refresh(node.child[1]);
    tree_.costs[tag] = rule_.combine(node.bounds, left, right);
    return tree_.costs[tag];
  }

  const ClusterTree& tree_;
  const LeafCollapse& rule_;
  std::vector<uint32_t> slots_, leaves_;
  uint32_t next_slot_ = 0;
};

// Writes the collapsed tree in depth-first order. Each subtree's place follows from its left sibling's
// size, so large subtrees are written by tasks of their own, and the output does not depend on which.
class Emitter {
 public:
  // With `gather_refs` false the references are already in place (ClusterTree::leaves_in_order).
  Emitter(const ClusterTree& tree, Bvh& bvh, bool gather_refs)
      : tree_(tree), bvh_(bvh), gather_refs_(gather_refs) {}

  // Writes the node of `tag` at nodes[index] (whose box is already written), its children at
  // [children, children + 2) and their subtrees after them, its references from `refs` on.
  void place(uint32_t tag, uint32_t index, uint32_t children, uint32_t refs) const {
    const Size size = size_of(tag);
    if (size.out_nodes == 1)
      place_leaf(tag, index, refs, size.prims);
    else if (size.out_nodes >= 2 * kTaskNodes)
      place_inner<true>(tag, index, children, refs);
    else
      place_inner<false>(tag, index, children, refs);
  }

 private:
  struct Size {
    uint32_t out_nodes, prims;
  };
  // Subtrees of this many nodes or more are written by a task of their own: tens of microseconds of
  // copying (the value only affects speed).
  static constexpr uint32_t kTaskNodes = 4096;

  Size size_of(uint32_t tag) const {
    if (is_leaf_tag(tag)) return {1, 1};
    return {tree_.costs[tag].out_nodes, tree_.costs[tag].prims};
  }

  void place_leaf(uint32_t tag, uint32_t index, uint32_t refs, uint32_t prims) const {
    Node& node = bvh_.nodes[index];
    node.first = refs;
    node.prim_count = static_cast<uint16_t>(prims);
    if (gather_refs_) {
      uint32_t* out = bvh_.prim_refs.data() + refs;
      gather(tag, out);
    }
  }

  // An inner node, with its leaf children written here rather than by a call each. With kTasks (a
  // large subtree), its large children are written by tasks; without, the frame holds no task group.
  template <bool kTasks>
  void place_inner(uint32_t tag, uint32_t index, uint32_t children, uint32_t refs) const {
    Node& node = bvh_.nodes[index];
    node.first = children;
    node.child_count = 2;
    const ClusterNode& inner = tree_.nodes[tag];
    // The walk is bound by its branches, not by cache misses: it took as long per node on a tree that
    // fits the second-level cache, and asking for the grandchildren ahead made it slower.
    const uint32_t child[2] = {inner.child[0], inner.child[1]};
    const Size child_size[2] = {size_of(child[0]), size_of(child[1])};
    for (uint32_t c = 0; c < 2; ++c) bvh_.nodes[children + c].bounds = tag_bounds(tree_, child[c]);
    struct NoGroup {
      void wait() {}
    };
    std::conditional_t<kTasks, tbb::task_group, NoGroup> group;
    uint32_t below = children + 2;
    for (uint32_t c = 0; c < 2; ++c) {
      const uint32_t tag_c = child[c], at = children + c, grandchildren = below, child_refs = refs;
      if (child_size[c].out_nodes == 1) {
        place_leaf(tag_c, at, child_refs, child_size[c].prims);
      } else if constexpr (kTasks) {
        if (child_size[c].out_nodes >= kTaskNodes)
          group.run(
              [this, tag_c, at, grandchildren, child_refs] { place(tag_c, at, grandchildren, child_refs); });
        else
          place_inner<false>(tag_c, at, grandchildren, child_refs);
      } else {
        place_inner<false>(tag_c, at, grandchildren, child_refs);
      }
      below += child_size[c].out_nodes - 1;
      refs += child_size[c].prims;
    }
    group.wait();
  }

  // The primitives under `tag`, left to right.
  void gather(uint32_t tag, uint32_t*& out) const {
    if (is_leaf_tag(tag)) {
      *out++ = tree_.order[tag_index(tag)];
      return;
    }
    gather(tree_.nodes[tag].child[0], out);
    gather(tree_.nodes[tag].child[1], out);
  }

  const ClusterTree& tree_;
  Bvh& bvh_;
  bool gather_refs_;
};

}  // namespace

HugePageArray<Aabb> bounds_in_order(std::span<const Aabb> prim_bounds, std::span<const uint32_t> order) {
  HugePageArray<Aabb> out(order.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, order.size(), std::size_t{1} << 14),
                    [&](const auto& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                        std::construct_at(&out[i], prim_bounds[order[i]]);
                    });
  return out;
}

Bvh finish_cluster_tree(const ClusterTree& tree, const LeafCollapse& rule) {
  Bvh bvh;
  if (tree.order.empty()) return bvh;
  // The rebuilt subtrees reorder their leaves.
  const bool too_deep = !is_leaf_tag(tree.root) && tree.costs[tree.root].height > kClusterDepthLimit;
  if (too_deep) DepthBound(tree, rule).run();
  const bool refs_in_order = tree.leaves_in_order && !too_deep;
  const SubtreeCost root = rule.of(tree, tree.root);
  bvh.nodes.resize(root.out_nodes);
  bvh.prim_refs.resize(root.prims);
  bvh.nodes[0].bounds = tag_bounds(tree, tree.root);
  if (refs_in_order)
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tree.order.size(), std::size_t{1} << 16),
                      [&](const auto& r) {
                        std::copy(tree.order.begin() + r.begin(), tree.order.begin() + r.end(),
                                  bvh.prim_refs.begin() + r.begin());
                      });
  Emitter(tree, bvh, !refs_in_order).place(tree.root, 0, 1, 0);
  return bvh;
}

}  // namespace sahbench
