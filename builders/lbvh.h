#pragma once
/// Linear BVH: the primitives sorted by the Morton codes of their box centres (builders/morton.h), the
/// binary radix tree over the sorted codes ("Maximizing Parallelism in the Construction of BVHs, Octrees,
/// and k-d Trees", T. Karras, HPG 2012), boxes and SAH costs computed bottom-up by the last of each
/// node's two children to finish (atomic arrivals, as in section 4 of that paper), then leaves collapsed
/// by the SAH (builders/leaf_collapse.h). Equal codes are told apart by their position in the sorted
/// order, which Karras appends to each key (section 4), so runs of equal codes become balanced subtrees.
/// The tree is found either by Karras's searches, one parallel task per inner node (section 4, Figure 4),
/// or by Apetrei's bottom-up pass ("Fast and Simple Agglomerative LBVH Construction", C. Apetrei, 2014),
/// which finds the same tree along with the boxes, walking the leaves in fixed chunks so that only the
/// nodes over a chunk boundary need an atomic arrival (lbvh.cpp). The fast-build end of the registry: no
/// split is ever searched for by cost.

#include <cstdint>

#include "builders/top_down.h"
#include "core/build_input.h"

namespace sahbench {

/// How the radix tree is found: Karras 2012's search per inner node, or Apetrei 2014's bottom-up pass
/// (the same tree, and the same output, node for node). Apetrei's is the default: it drops the searches
/// and the parent links, and finds the boxes and collapse costs in the same pass.
enum class LbvhHierarchy { kKarras, kApetrei };

struct LbvhParams {
  /// Morton code length: 30 (10 bits per axis, Karras's choice) or 63 (21 bits per axis; finer cells for
  /// scenes with detail in a large box, at twice the sorting).
  uint32_t bits = 30;
  LbvhHierarchy hierarchy = LbvhHierarchy::kApetrei;
  /// min_leaf, max_leaf and the SAH constants of the leaf collapse; arity must be 2.
  TopDownConfig top_down;
};

Bvh build_lbvh(const BuildInput& input, const LbvhParams& params);

/// Rejects parameters out of range; the message names the parameter and its value.
void check_lbvh_params(const LbvhParams& params);

}  // namespace sahbench
