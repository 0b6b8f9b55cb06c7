#pragma once
// The one top-down recursion shared by the SAH builders. A builder supplies only a Splitter that finds
// the best split of a node's primitives and partitions them; leaf decisions, fallbacks, task spawning
// and the node layout live here (the structure of madmann91/bvh's TopDownSahBuilder and of pbrt-v4's
// BVHAggregate::buildRecursive).
//
// Determinism: every node's descendants are written into a slot region fixed in advance, so tasks never
// race for node indices and the tree is the same for any thread count. A subtree over n primitives has at
// most 2n - 1 nodes (a full binary tree with at most n leaves), so a node over n primitives reserves
// 2n - 2 slots for its descendants: its two children first, then the left child's region (2 n_left - 2),
// then the right child's. Leaves holding several primitives leave holes, which compact() removes. A wide
// node with k children uses k + sum(2 n_i - 2) = 2n - k slots, so the same regions hold wide trees.

#include <tbb/task_group.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "builders/prim_ref.h"
#include "core/bvh.h"
#include "core/error.h"
#include "core/sah.h"

namespace sahbench {

/// Most children a node of the common format has (core/bvh.h allows 2 to 8).
inline constexpr uint32_t kMaxArity = 8;

struct TopDownConfig {
  uint32_t min_leaf = 1;  ///< nodes with this many primitives or fewer become leaves
  uint32_t max_leaf = 8;  ///< nodes with more are split even where the SAH prefers a leaf
  SahCost cost;
  /// Children per inner node, 2 to 8. Above 2, a node's children are found by splitting, again and
  /// again, the child of largest surface area until there are `arity` of them or none can be split
  /// (the direct wide build of Wald, Benthin and Boulos 2008, "Getting Rid of Packets", and of
  /// Embree's BVHN builders).
  uint32_t arity = 2;
};

/// A node's primitives: the range [begin, end) of the splitter's reference order, and their bounds.
struct NodeRange {
  uint32_t begin = 0;
  uint32_t end = 0;
  Aabb bounds;
  Aabb centroid_bounds;

  uint32_t size() const { return end - begin; }
};

/// A split proposed by a Splitter. `cost` is SahCost::split_cost; infinite when no split separates the
/// primitives (e.g. all centroids equal on every axis). `axis` and `position` mean what the splitter
/// wants them to mean (a bin index, or a position in sorted order).
struct Split {
  float cost = std::numeric_limits<float>::infinity();
  uint32_t axis = 0;
  uint32_t position = 0;

  bool valid() const { return cost < std::numeric_limits<float>::infinity(); }
};

/// The two halves after partitioning: [left.begin, left.end) and [right.begin, right.end), both non-empty.
struct Partition {
  NodeRange left, right;
};

/*
 A Splitter provides:
   Split find_split(const NodeRange&);                 // best split, or an invalid one
   Partition partition(const NodeRange&, const Split&); // reorder so the split's left side comes first
   Partition partition_median(const NodeRange&);        // fallback: halves by count, always non-empty
   uint32_t prim_id(uint32_t position) const;           // primitive at a position of the final order
 Each may be called concurrently on disjoint ranges.
*/

namespace detail {

// A node in its preassigned slot; trivially constructible so the slot buffer is not zero-filled.
struct SlotNode {
  Aabb bounds;
  uint32_t first;        // children: slot of the first child; leaf: first position in the reference order
  uint32_t child_count;  // 0 for a leaf
  uint32_t prim_count;   // 0 for an inner node
};

// Nodes below this many primitives are built by the task that reaches them; above it, the two children
// are built as separate TBB tasks. 1024 primitives is tens of microseconds of work, enough to amortise
// task overhead (the value only affects speed, not the tree).
inline constexpr uint32_t kSpawnThreshold = 1024;

// True when only median splits can still keep every node shallower than kMaxDepth. Halving n primitives
// down to single ones takes ceil(log2 n) = bit_width(n - 1) more levels, and each median split lowers
// that by one; an SAH split may be arbitrarily unbalanced, so it is allowed only while one more level
// would still leave room to halve. Only pathological inputs get here (trees are ~30 deep at 1M).
inline bool must_halve(uint32_t depth, uint32_t n) { return depth + std::bit_width(n - 1) >= kMaxDepth - 1; }

template <class Splitter>
class TopDownBuilder {
 public:
  TopDownBuilder(Splitter& splitter, const TopDownConfig& config, uint32_t prim_count)
      : splitter_(splitter), config_(config), slots_(std::make_unique_for_overwrite<SlotNode[]>(2 * std::size_t{prim_count} - 1)) {}

  Bvh build(const NodeRange& root) {
    build_node(root, 0, 1, 0);
    return compact(root.size());
  }

 private:
  void make_leaf(const NodeRange& range, uint32_t slot) {
    slots_[slot] = {range.bounds, range.begin, 0, range.size()};
  }

  // Decides whether `range` is split and, if so, partitions it into `halves`; false makes it a leaf.
  // `depth` counts binary splits from the root, so the depth bound holds for wide trees as well.
  bool try_split(const NodeRange& range, uint32_t depth, Partition& halves) {
    const uint32_t n = range.size();
    if (n <= config_.min_leaf) return false;
    if (must_halve(depth, n)) {
      if (n <= config_.max_leaf) return false;
      halves = splitter_.partition_median(range);
      return true;
    }
    const Split split = splitter_.find_split(range);
    const float leaf_cost = config_.cost.leaf_cost(n);
    // Prefer a leaf where the SAH does, unless the leaf would be too large to be useful.
    if (n <= config_.max_leaf && !(split.valid() && split.cost < leaf_cost)) return false;
    // A split whose children both keep the parent's full area costs c_trav + leaf cost: the SAH sees
    // no difference between candidates (identical or nested primitives), and taking its first one
    // would peel off one primitive per level. Halving by count instead keeps the depth logarithmic;
    // for lots of overlapping primitives this gives poor but valid trees.
    const bool informative = split.valid() && split.cost < config_.cost.c_trav + leaf_cost;
    halves = informative ? splitter_.partition(range, split) : splitter_.partition_median(range);
    return true;
  }

  // One child of the node being built: its primitives, its binary depth, and whether it was already
  // found to be a leaf (so its split search is not repeated).
  struct Child {
    NodeRange range;
    uint32_t depth;
    bool leaf;
  };

  // Builds the node for `range` into `slot`; its descendants go into slots [region, region + 2n - 2):
  // its k children first, then each child's own region of 2 n_i - 2 slots, which sums to 2n - k.
  void build_node(const NodeRange& range, uint32_t slot, uint32_t region, uint32_t depth) {
    Partition halves;
    if (!try_split(range, depth, halves)) return make_leaf(range, slot);

    Child children[kMaxArity];
    uint32_t count = 2;
    children[0] = {halves.left, depth + 1, false};
    children[1] = {halves.right, depth + 1, false};
    while (count < config_.arity) {
      // Split the open child of largest area; its halves take its place, so children stay in
      // primitive order.
      uint32_t best = count;
      float best_area = -1.0f;
      for (uint32_t c = 0; c < count; ++c) {
        const float area = children[c].range.bounds.half_area();
        if (!children[c].leaf && area > best_area) best = c, best_area = area;
      }
      if (best == count) break;
      Partition parts;
      if (!try_split(children[best].range, children[best].depth, parts)) {
        children[best].leaf = true;
        continue;
      }
      const uint32_t child_depth = children[best].depth + 1;
      std::move_backward(children + best + 1, children + count, children + count + 1);
      children[best] = {parts.left, child_depth, false};
      children[best + 1] = {parts.right, child_depth, false};
      ++count;
    }

    slots_[slot] = {range.bounds, region, count, 0};
    uint32_t child_region = region + count;
    auto build_child = [&](uint32_t c, uint32_t child_region_begin) {
      if (children[c].leaf) return make_leaf(children[c].range, region + c);
      build_node(children[c].range, region + c, child_region_begin, children[c].depth);
    };
    if (range.size() >= kSpawnThreshold) {
      tbb::task_group group;
      for (uint32_t c = 0; c + 1 < count; ++c) {
        group.run([&build_child, c, child_region] { build_child(c, child_region); });
        child_region += 2 * children[c].range.size() - 2;
      }
      build_child(count - 1, child_region);
      group.wait();
    } else {
      for (uint32_t c = 0; c < count; ++c) {
        build_child(c, child_region);
        child_region += 2 * children[c].range.size() - 2;
      }
    }
  }

  // Copies the used slots into a dense node array in depth-first order, children pairs kept contiguous,
  // and writes the primitive references in the splitter's final order.
  Bvh compact(uint32_t prim_count) const {
    Bvh bvh;
    bvh.arity = config_.arity;
    bvh.nodes.reserve(2 * std::size_t{prim_count} - 1);
    bvh.nodes.push_back({slots_[0].bounds, 0, 0, 0});
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};  // (slot, index in bvh.nodes)
    while (!stack.empty()) {
      const auto [slot, index] = stack.back();
      stack.pop_back();
      const SlotNode& s = slots_[slot];
      Node& node = bvh.nodes[index];
      if (s.child_count == 0) {
        node.first = s.first;
        node.prim_count = static_cast<uint16_t>(s.prim_count);
        continue;
      }
      node.first = static_cast<uint32_t>(bvh.nodes.size());
      node.child_count = static_cast<uint16_t>(s.child_count);
      const uint32_t first_child = node.first;  // `node` may dangle once we push
      for (uint32_t c = 0; c < s.child_count; ++c) bvh.nodes.push_back({slots_[s.first + c].bounds, 0, 0, 0});
      // Push the right child first so the left subtree is laid out right after the pair.
      for (uint32_t c = s.child_count; c-- > 0;) stack.emplace_back(s.first + c, first_child + c);
    }
    bvh.prim_refs.resize(prim_count);
    for (uint32_t i = 0; i < prim_count; ++i) bvh.prim_refs[i] = splitter_.prim_id(i);
    return bvh;
  }

  Splitter& splitter_;
  const TopDownConfig& config_;
  std::unique_ptr<SlotNode[]> slots_;
};

}  // namespace detail

/// Runs the shared recursion over `prim_count` primitives whose bounds are `root`. The caller checks the
/// configuration (see check_config) before building.
template <class Splitter>
Bvh build_top_down(Splitter& splitter, const TopDownConfig& config, const NodeRange& root) {
  if (root.size() == 0) return Bvh{};
  detail::TopDownBuilder<Splitter> builder(splitter, config, root.size());
  return builder.build(root);
}

/// Rejects configurations the node format cannot represent; the message names the builder and value.
void check_config(const TopDownConfig& config, std::string_view builder);
/// Rejects inputs too large for 32-bit node indices.
void check_prim_count(std::size_t count, std::string_view builder);

}  // namespace sahbench
