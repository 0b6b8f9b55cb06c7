#pragma once
// The common BVH format that every builder writes and every pass and layout reads (DESIGN.md).

#include <cstdint>
#include <vector>

#include "core/aabb.h"
#include "core/huge_pages.h"

namespace sahbench {

/// One node, 32 bytes. Children of an inner node are stored contiguously at
/// nodes[first .. first + child_count); a leaf references prim_refs[first .. first + prim_count).
/// Exactly one of child_count and prim_count is non-zero.
struct Node {
  Aabb bounds;
  uint32_t first = 0;
  uint16_t child_count = 0;
  uint16_t prim_count = 0;

  constexpr bool is_leaf() const { return prim_count != 0; }

  friend constexpr bool operator==(const Node&, const Node&) = default;
};
static_assert(sizeof(Node) == 32, "the common node format is 32 bytes");

/// A tree in the common format. Its arrays are on huge pages from 2 MiB (core/huge_pages.h): the bvh2
/// layout traces this very tree, reading nodes all over it, as Embree's and the other layouts' trees are.
struct Bvh {
  std::vector<Node, HugePageAllocator<Node>> nodes;              ///< nodes[0] is the root
  std::vector<uint32_t, HugePageAllocator<uint32_t>> prim_refs;  ///< scene indices; may repeat (splits)
  uint32_t arity = 2;  ///< the most children any node may have: 2, 4 or 8

  const Node& root() const { return nodes.front(); }

  /// Exact bytes of the structure: nodes plus references (capacity slack excluded).
  std::size_t bytes() const { return nodes.size() * sizeof(Node) + prim_refs.size() * sizeof(uint32_t); }

  friend bool operator==(const Bvh&, const Bvh&) = default;
};

/// Most children a node of the common format has (Bvh::arity is 2, 4 or 8).
inline constexpr uint32_t kMaxArity = 8;
/// Largest leaf a Node can describe (prim_count is 16 bits).
inline constexpr uint32_t kMaxLeafPrims = 0xFFFFu;
/// Deepest tree any kernel in this project traverses with a fixed-size stack. Builders check it;
/// a binary tree this deep would need 2^kMaxDepth primitives to be balanced, so only pathological
/// inputs reach it, and for those the builder makes a leaf instead of recursing further.
inline constexpr uint32_t kMaxDepth = 64;

}  // namespace sahbench
