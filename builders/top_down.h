#pragma once
// The one top-down recursion shared by the SAH builders. A builder supplies only a Splitter that finds
// the best split of a node's primitives and partitions them; leaf decisions, fallbacks, task spawning
// and the node layout live here (the structure of madmann91/bvh's TopDownSahBuilder and of pbrt-v4's
// BVHAggregate::buildRecursive).
//
// Node slots: a node's children take consecutive slots of one buffer, and compact() then copies the
// tree into depth-first order, so the slots a node gets do not affect the result, and the tree is the
// same for any thread count. Nodes large enough to be split by parallel tasks take their children's
// slots from a shared atomic counter; a task that builds a smaller subtree alone first reserves from it
// the most slots the subtree can need and then hands them out in order. A subtree over n primitives has
// at most 2n - 1 nodes (a full binary tree with at most n leaves), so 2n - 2 slots hold its
// descendants, and the slots taken never exceed the buffer's 2n - 1. A wide node with k children
// uses fewer. Slots are written in order from the front of each reservation, so the pages of the unused
// rest are never touched (on the 1M-triangle terrain the 244K nodes of the 8-wide tree use 10 MB of the
// buffer's 80).
//
// Builders that split primitives (SBVH) add references as they go. Each node then owns `spare` reference
// positions after its range, which its splits may fill and which its partition hands on to the children;
// a node's subtree ends with at most size + spare references, and its slot reservation is sized for that
// many. Positions left unused are holes in the reference order, and compact() gathers the leaves' references.

#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cassert>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "builders/prim_ref.h"
#include "core/bvh.h"
#include "core/error.h"
#include "core/sah.h"

namespace sahbench {

struct TopDownConfig {
  uint32_t min_leaf = 1;  ///< nodes with this many primitives or fewer become leaves
  uint32_t max_leaf = 8;  ///< nodes with more are split even where the SAH prefers a leaf
  SahCost cost{};
  /// Children per inner node, 2 to 8. Above 2, a node's children are found by splitting, again and
  /// again, the child of largest surface area until there are `arity` of them or none can be split
  /// (the direct wide build of Wald, Benthin and Boulos 2008, "Getting Rid of Packets", and of
  /// Embree's BVHN builders).
  uint32_t arity = 2;
  /// Also offer, where a node has kSizeSplitMinPrims primitives or more, the split of its large
  /// primitives from the rest (builders/size_split.h), in the builders that search centroid planes.
  bool size_split = true;
};

/// A node's primitives: the range [begin, end) of the splitter's reference order, and their bounds.
struct NodeRange {
  uint32_t begin = 0;
  uint32_t end = 0;
  Aabb bounds;
  Aabb centroid_bounds;
  /// Positions [end, end + spare) are the node's to fill with references that splitting primitives adds.
  uint32_t spare = 0;

  uint32_t size() const { return end - begin; }
  /// The most references the node's subtree may end with.
  uint32_t capacity() const { return size() + spare; }
};

/// A split proposed by a Splitter. `cost` is SahCost::split_cost; infinite when no split separates the
/// primitives (e.g. all centroids equal on every axis). `axis` and `position` mean what the splitter
/// wants them to mean (a bin index, or a position in sorted order; a size split's last class on axis
/// kSizeSplitAxis, builders/size_split.h).
struct Split {
  float cost = std::numeric_limits<float>::infinity();
  uint32_t axis = 0;
  uint32_t position = 0;

  bool valid() const { return cost < std::numeric_limits<float>::infinity(); }
};

/// The two halves after partitioning: [left.begin, left.end) and [right.begin, right.end), both non-empty.
/// The halves split the parent's positions: left.begin is the parent's begin, right.begin is
/// left.begin + left.capacity(), and right ends its capacity where the parent's capacity ends.
struct Partition {
  NodeRange left, right;
};

/*
 A Splitter provides:
   S find_split(const NodeRange&);                     // best split, or an invalid one; S is Split or a type
                                                       // with the same cost and valid()
   Partition partition(const NodeRange&, const S&);    // reorder so the split's left side comes first
   Partition partition_median(const NodeRange&);        // fallback: halves by count, always non-empty
   uint32_t prim_id(uint32_t position) const;           // primitive at a position of the final order
 Each may be called concurrently on disjoint ranges.
*/

namespace detail {

// A node in its slot. The slot buffer is left uninitialised and is written slot by slot (see above).
struct SlotNode {
  Aabb bounds;
  uint32_t first;        // children: slot of the first child; leaf: first position in the reference order
  uint16_t child_count;  // 0 for a leaf
  uint16_t prim_count;   // 0 for an inner node
  uint32_t descendants;  // nodes below this one
  uint32_t references;   // leaf references below this one (or in it)
};

// The size of a subtree, as build_node returns it; compact() places subtrees by these counts.
struct SubtreeSize {
  uint32_t descendants = 0;
  uint32_t references = 0;
};

// Nodes below this many primitives are built by the task that reaches them; above it, the children
// are built as separate TBB tasks. 1024 primitives is tens of microseconds of work, enough to amortise
// task overhead (the value only affects speed, not the tree).
inline constexpr uint32_t kSpawnThreshold = 1024;

// True when only median splits can still keep every node shallower than kMaxDepth. Halving n primitives
// down to single ones takes ceil(log2 n) = bit_width(n - 1) more levels, and each median split lowers
// that by one; an SAH split may be arbitrarily unbalanced, so it is allowed only while one more level
// would still leave room to halve. Only pathological inputs get here (trees are ~30 deep at 1M).
inline bool must_halve(uint32_t depth, uint32_t n) {
  return depth + std::bit_width(n - 1) >= kMaxDepth - 1;
}

template <class Splitter>
class TopDownBuilder {
 public:
  TopDownBuilder(Splitter& splitter, const TopDownConfig& config, uint32_t capacity)
      // Raw storage from operator new, not huge pages: a 2 MiB page is zeroed in full when any slot on
      // it is written, and the used slots are spread over the whole buffer.
      : splitter_(splitter),
        config_(config),
        slots_(static_cast<SlotNode*>(::operator new(sizeof(SlotNode) * (2 * std::size_t{capacity} - 1)))) {}

  Bvh build(const NodeRange& root) {
    build_subtree(root, 0, 0);
    assert(next_slot_.load() <= 2 * root.capacity() - 1);
    return compact();
  }

 private:
  SubtreeSize make_leaf(const NodeRange& range, uint32_t slot) {
    const uint32_t n = range.size();
    std::construct_at(&slots_[slot], SlotNode{range.bounds, range.begin, 0, static_cast<uint16_t>(n), 0, n});
    return {0, n};
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
    const float leaf_cost = config_.cost.leaf_cost(n);
    // A split costs at least c_trav (SahCost::split_cost_from_weighted), so where a leaf costs no more,
    // the SAH keeps the leaf whatever the split: no search. With the wide builders' blocks of 4
    // triangles and c_trav = c_isect, that is every node of at most 4 triangles.
    if (n <= config_.max_leaf && leaf_cost <= config_.cost.c_trav) return false;
    const auto split = splitter_.find_split(range);
    // Prefer a leaf where the SAH does, unless the leaf would be too large to be useful.
    if (n <= config_.max_leaf && !(split.valid() && split.cost < leaf_cost)) return false;
    // A split whose children both keep the parent's full area costs c_trav + leaf cost: the SAH sees
    // no difference between candidates (identical or nested primitives), and taking its first one
    // would peel off one primitive per level. Halving by count instead keeps the depth logarithmic;
    // for lots of overlapping primitives this gives poor but valid trees.
    const bool informative = split.valid() && split.cost < config_.cost.c_trav + leaf_cost;
    halves = informative ? splitter_.partition(range, split) : splitter_.partition_median(range);
    assert(halves.left.begin == range.begin &&
           halves.right.begin == halves.left.begin + halves.left.capacity() &&
           halves.right.begin + halves.right.capacity() == range.begin + range.capacity());
    return true;
  }

  // One child of the node being built: its primitives, its binary depth, and whether it was already
  // found to be a leaf (so its split search is not repeated).
  struct Child {
    NodeRange range;
    uint32_t depth;
    bool leaf;
  };

  // Hands out slots to one task's subtree, in order; nullptr `next` means the shared counter.
  uint32_t take_slots(uint32_t count, uint32_t* next) {
    if (next == nullptr) return next_slot_.fetch_add(count, std::memory_order_relaxed);
    const uint32_t first = *next;
    *next += count;
    return first;
  }

  // Builds the node for `range` into `slot`. A node small enough to be built by one task reserves its
  // descendants' slots and builds them from that reservation.
  SubtreeSize build_subtree(const NodeRange& range, uint32_t slot, uint32_t depth) {
    if (range.size() >= kSpawnThreshold) return build_node(range, slot, depth, nullptr);
    const uint32_t reserved = 2 * range.capacity() - 2;
    uint32_t next = take_slots(reserved, nullptr);
    [[maybe_unused]] const uint32_t end = next + reserved;
    const SubtreeSize size = build_node(range, slot, depth, &next);
    assert(next <= end);
    return size;
  }

  // Builds the node for `range` into `slot`, taking its children's slots from `next` (see take_slots).
  SubtreeSize build_node(const NodeRange& range, uint32_t slot, uint32_t depth, uint32_t* next) {
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

    const uint32_t first = take_slots(count, next);
    SubtreeSize sizes[kMaxArity];
    if (next == nullptr) {
      // Every child its own task: each large one spreads further, each small one reserves its slots.
      tbb::task_group group;
      for (uint32_t c = 0; c + 1 < count; ++c)
        group.run(
            [this, &children, &sizes, first, c] { sizes[c] = build_child(children[c], first + c, nullptr); });
      sizes[count - 1] = build_child(children[count - 1], first + count - 1, nullptr);
      group.wait();
    } else {
      for (uint32_t c = 0; c < count; ++c) sizes[c] = build_child(children[c], first + c, next);
    }
    SubtreeSize size{count, 0};
    for (uint32_t c = 0; c < count; ++c) {
      size.descendants += sizes[c].descendants;
      size.references += sizes[c].references;
    }
    std::construct_at(&slots_[slot], SlotNode{range.bounds, first, static_cast<uint16_t>(count), 0,
                                              size.descendants, size.references});
    return size;
  }

  SubtreeSize build_child(const Child& child, uint32_t slot, uint32_t* next) {
    if (child.leaf) return make_leaf(child.range, slot);
    if (next == nullptr) return build_subtree(child.range, slot, child.depth);
    return build_node(child.range, slot, child.depth, next);
  }

  // Copies the used slots into a dense node array in depth-first order, children kept contiguous, and
  // writes each leaf's references in the splitter's final order, leaves in depth-first order. A child's
  // positions come before its right siblings', so without spare positions the references are the
  // splitter's order itself. Every subtree's place follows from its left siblings' sizes, so large
  // subtrees are copied by parallel tasks.
  Bvh compact() const {
    Bvh bvh;
    bvh.arity = config_.arity;
    const SlotNode& root = slots_[0];
    bvh.nodes.resize(std::size_t{root.descendants} + 1);
    bvh.prim_refs.resize(root.references);
    bvh.nodes[0].bounds = root.bounds;
    place(bvh, 0, 0, 1, 0);
    return bvh;
  }

  // Writes the node of `slot`, whose record is bvh.nodes[index], and its subtree: its children go to
  // [children, children + k) and their subtrees right after them, its references from `references` on.
  void place(Bvh& bvh, uint32_t slot, uint32_t index, uint32_t children, uint32_t references) const {
    const SlotNode& s = slots_[slot];
    Node& node = bvh.nodes[index];
    if (s.child_count == 0) {
      node.first = references;
      node.prim_count = s.prim_count;
      for (uint32_t i = 0; i < s.prim_count; ++i)
        bvh.prim_refs[references + i] = splitter_.prim_id(s.first + i);
      return;
    }
    node.first = children;
    node.child_count = s.child_count;
    // Subtrees of this many nodes or more are copied by a task of their own: a few tens of
    // microseconds of copying, as kSpawnThreshold's primitives are of building (only speed depends on it).
    constexpr uint32_t kTaskNodes = 4096;
    // A group only where a child can be that large (it is never larger than its parent): most nodes are
    // small, and a task group costs its construction and wait on each.
    std::optional<tbb::task_group> group;
    if (s.descendants >= kTaskNodes) group.emplace();
    uint32_t below = children + s.child_count;  // where the next child's descendants start
    for (uint32_t c = 0; c < s.child_count; ++c) {
      const uint32_t child_slot = s.first + c, at = children + c, grandchildren = below, refs = references;
      const SlotNode& child = slots_[child_slot];
      bvh.nodes[at].bounds = child.bounds;
      if (child.descendants >= kTaskNodes)
        group->run([this, &bvh, child_slot, at, grandchildren, refs] {
          place(bvh, child_slot, at, grandchildren, refs);
        });
      else
        place(bvh, child_slot, at, grandchildren, refs);
      below += child.descendants;
      references += child.references;
    }
    if (group) group->wait();
  }

  Splitter& splitter_;
  const TopDownConfig& config_;
  struct FreeStorage {
    void operator()(SlotNode* p) const { ::operator delete(p); }
  };
  std::unique_ptr<SlotNode[], FreeStorage> slots_;
  std::atomic<uint32_t> next_slot_{1};  // slot 0 is the root's
};

}  // namespace detail

/// Runs the shared recursion over the primitives of `root`, whose capacity bounds the references the
/// tree may end with. The caller checks the configuration (see check_config) before building.
template <class Splitter>
Bvh build_top_down(Splitter& splitter, const TopDownConfig& config, const NodeRange& root) {
  if (root.size() == 0) return Bvh{};
  detail::TopDownBuilder<Splitter> builder(splitter, config, root.capacity());
  return builder.build(root);
}

/// Rejects configurations the node format cannot represent; the message names the builder and value.
void check_config(const TopDownConfig& config, std::string_view builder);
/// Rejects inputs too large for 32-bit node indices.
void check_prim_count(std::size_t count, std::string_view builder);

}  // namespace sahbench
