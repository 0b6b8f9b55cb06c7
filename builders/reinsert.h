#pragma once
/// Insertion-based optimisation of a binary BVH: "Fast Insertion-Based Optimization of Bounding Volume
/// Hierarchies", J. Bittner, M. Hapala and V. Havran, 2013, in the parallel form of "Parallel Reinsertion
/// for Bounding Volume Hierarchy Optimization", D. Meister and J. Bittner, 2018. Each iteration takes the
/// `batch` fraction of nodes with the largest boxes, finds for each in parallel the place whose
/// reinsertion lowers the SAH most (a branch-and-bound search over the tree without that node), and
/// applies the moves in order of gain, skipping any that touches a node an earlier move of the
/// iteration changed.

#include <cstdint>

#include "core/bvh.h"
#include "core/sah.h"

namespace sahbench {

struct ReinsertParams {
  uint32_t iterations = 8;
  /// Fraction of the nodes (the largest by area) searched for a better place per iteration.
  double batch = 0.05;
  /// An iteration whose search finds moves that together would lower the inner nodes' summed area by
  /// less than this fraction of it is the last: what is left to gain is small next to a round's time.
  double min_gain = 1e-3;
  SahCost cost;
};

/// The largest min_gain accepted: above it, a search that finds half of the tree's area to gain would
/// still be taken as converged.
inline constexpr double kMaxMinGain = 0.5;

/// The tree `source` (binary) with nodes moved to lower its SAH. Never returns a tree of higher SAH cost
/// (by `params.cost`, as core/bvh_stats.h computes it) than `source`: an iteration whose moves together
/// raise it (moves that interact through shared ancestors' boxes) is retried with half as many, and
/// where nothing helps the source comes back unchanged. Moves that would put a node deeper than
/// kMaxDepth are not made. The same tree for any thread count.
Bvh reinsert(const Bvh& source, const ReinsertParams& params);

}  // namespace sahbench
