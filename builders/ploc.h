#pragma once
/// PLOC: "Parallel Locally-Ordered Clustering for Bounding Volume Hierarchy Construction", D. Meister and
/// J. Bittner, IEEE TVCG 2018. Agglomerative clustering over the primitives in Morton order
/// (builders/morton.h): each round, every cluster finds its nearest neighbour among the `radius`
/// clusters before and after it in the order, by the surface area of their merged box; mutual nearest
/// neighbours merge into a new node that takes the lower one's place; and a prefix sum closes the gaps.
/// Rounds repeat until one cluster is left. Then the leaves are collapsed by the SAH
/// (builders/leaf_collapse.h).
///
/// Deterministic: a cluster's neighbour is the least of its candidates in a total order on pairs (area,
/// then the pair's indices, see ploc.cpp), so the neighbours, the merges and the tree are the same for any
/// thread count; the order also makes the pair least of all mutual, so every round merges.

#include <cstdint>

#include "builders/top_down.h"
#include "core/build_input.h"

namespace sahbench {

/// Largest search radius accepted; the search costs time in proportion to the radius.
inline constexpr uint32_t kPlocMaxRadius = 256;

struct PlocParams {
  /// Clusters searched on each side of a cluster in the Morton order. 16: on the tuning scenes the SAH
  /// moved by 1-3% either way from 8 to 32 (Sponza gaining with the radius, the terrain and the bunny
  /// losing), while the search's time grows with it; madmann91/bvh v1 takes 14, AMD's HIPRT 8.
  uint32_t radius = 16;
  /// Morton code length (30 or 63), as lbvh's `bits`: it only orders the clusters.
  uint32_t bits = 30;
  /// min_leaf, max_leaf and the SAH constants of the leaf collapse; arity must be 2.
  TopDownConfig top_down;
};

Bvh build_ploc(const BuildInput& input, const PlocParams& params);

/// Rejects parameters out of range; the message names the parameter and its value.
void check_ploc_params(const PlocParams& params);

}  // namespace sahbench
