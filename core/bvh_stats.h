#pragma once
// Statistics computed on the common format, so every builder is measured by the same code.

#include <cstdint>

#include "core/bvh.h"
#include "core/sah.h"

namespace sahbench {

struct BvhStats {
  uint32_t nodes = 0;  ///< all nodes, inner and leaf
  uint32_t leaves = 0;
  uint32_t max_depth = 0;        ///< root has depth 0
  double mean_leaf_depth = 0.0;  ///< averaged over leaves
  double mean_leaf_size = 0.0;   ///< references per leaf
  uint32_t max_leaf_size = 0;
  double refs_per_prim = 0.0;  ///< references / primitives (1 without spatial splits)
  double sah_cost = 0.0;       ///< SAH cost of the whole tree, relative to the root's area
  std::size_t bytes = 0;       ///< exact bytes of nodes and references
};

/// `prim_count` is the number of scene primitives (for refs_per_prim). The tree must be valid.
BvhStats compute_stats(const Bvh& bvh, std::size_t prim_count, const SahCost& cost);

/// SAH cost of a tree: sum over inner nodes of A(n)/A(root) * c_trav, plus over leaves of
/// A(n)/A(root) * c_isect * count. A degenerate root (zero area) counts every node at weight 1.
double sah_cost(const Bvh& bvh, const SahCost& cost);

}  // namespace sahbench
