#pragma once
/// Treelet restructuring of a binary BVH: "Fast Parallel Construction of High-Quality Bounding Volume
/// Hierarchies", T. Karras and T. Aila, 2013, section 4. Bottom up, every inner node roots a treelet grown
/// by opening its largest leaf until it has `treelet_size` leaves (subtrees of the tree); dynamic
/// programming over the subsets of those leaves finds the binary topology of least SAH over them, which
/// replaces the treelet's inner nodes when it is cheaper. Disjoint subtrees are processed in parallel.
/// Topology only: the leaves stay as they are (the paper's collapse of subtrees into leaves is not done).

#include <cstdint>

#include "core/bvh.h"
#include "core/sah.h"

namespace sahbench {

/// The paper's treelet size; its cost grows as 3^n.
inline constexpr uint32_t kDefaultTreeletSize = 7;
inline constexpr uint32_t kMinTreeletSize = 3;
inline constexpr uint32_t kMaxTreeletSize = 10;

struct TreeletParams {
  uint32_t treelet_size = kDefaultTreeletSize;
  /// Bottom-up passes over the tree (the paper finds three enough).
  uint32_t iterations = 3;
  SahCost cost;
};

/// The tree `source` (binary) with its treelets restructured. Never returns a tree of higher SAH cost
/// (by `params.cost`, as core/bvh_stats.h computes it) than `source`, nor one deeper than kMaxDepth (a
/// pass that would is undone). Iterations stop early once one gains nothing. The same tree for any
/// thread count.
Bvh restructure_treelets(const Bvh& source, const TreeletParams& params);

}  // namespace sahbench
