#pragma once
// A binary tree with parent links, for the passes that rewrite a built tree's topology in place
// (reinsert.h, treelet.h): read from a binary common-format Bvh, its inner boxes recomputed after a
// rewrite, and written back depth first. Leaves keep their boxes and references, so a tree with spatial
// splits keeps its clipped leaf boxes.

#include <cstdint>
#include <string_view>
#include <vector>

#include "core/aabb.h"
#include "core/bvh.h"

namespace sahbench {

inline constexpr uint32_t kNoNode = 0xFFFFFFFFu;

struct LinkedNode {
  Aabb bounds;
  uint32_t parent = kNoNode;
  uint32_t child[2] = {kNoNode, kNoNode};  ///< inner nodes
  uint32_t first = 0;                      ///< leaves: the input's prim_refs[first, first + count)
  uint32_t count = 0;                      ///< 0 for inner nodes

  bool is_leaf() const { return count != 0; }
};

/// Half the surface area in double, as the statistics compute it (core/bvh_stats.cpp), so that neither
/// 1e30 coordinates overflow nor 1e-25 ones underflow.
inline double area_in_double(const Aabb& box) {
  if (box.is_empty()) return 0.0;
  const double x = static_cast<double>(box.max.x) - box.min.x;
  const double y = static_cast<double>(box.max.y) - box.min.y;
  const double z = static_cast<double>(box.max.z) - box.min.z;
  return x * y + y * z + z * x;
}

class LinkedTree {
 public:
  /// The tree of `bvh`, which must be binary (arity 2); anything else is an Error naming `pass`.
  LinkedTree(const Bvh& bvh, std::string_view pass);

  std::vector<LinkedNode> nodes;
  uint32_t root = kNoNode;

  /// The other child of n's parent; n must not be the root.
  uint32_t sibling(uint32_t n) const;
  /// Makes `now` the child of `parent` that `old` was.
  void replace_child(uint32_t parent, uint32_t old, uint32_t now);
  /// Whether `n` lies in the subtree of `ancestor` (or is it), by walking up the parent links.
  bool in_subtree(uint32_t n, uint32_t ancestor) const;

  /// What refit() finds on its way: the tree's height (its deepest node's depth, the root's being 0)
  /// and the sum of its inner nodes' areas (area_in_double), the part of the SAH that a change of
  /// topology changes. The sum is taken child before parent along the tree, the same on any thread.
  struct Summary {
    uint32_t height = 0;
    double inner_area = 0.0;
  };
  /// depth[n] and height[n] (0 for leaves) of every node, as refit() may record them.
  struct Levels {
    std::vector<uint32_t> depth, height;
  };

  /// Every inner box recomputed as the union of its children's, bottom up, in parallel with TBB (the
  /// boxes are exact unions, so the result does not depend on the thread count); `levels`, when given,
  /// gets every node's depth and height.
  Summary refit(Levels* levels = nullptr);

  /// The tree in the common format: depth first, each node's two children side by side, and the leaves'
  /// references in the order the leaves are met.
  Bvh to_bvh() const;

 private:
  std::vector<uint32_t> refs_;  ///< the input's prim_refs
};

}  // namespace sahbench
