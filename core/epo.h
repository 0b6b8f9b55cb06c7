#pragma once
// The end-point overlap (EPO) cost of a tree (Aila, Karras and Laine 2013, "On Quality Metrics of Bounding
// Volume Hierarchies", section 4): rays start and end on the scene's surfaces, and a node whose box
// contains surface that is not in its subtree is visited by rays that end there without finding their hit
// in it. SAH (section 2) counts only the boxes' areas; EPO counts that overlap, and the two together
// predict the measured ray tracing cost better than SAH alone (section 5).

#include <span>

#include "core/bvh.h"
#include "core/sah.h"
#include "core/triangle.h"

namespace sahbench {

/// EPO = sum over nodes n of C(n) * A((S \ Q(n)) ∩ box(n)) / A(S): S is every triangle of the scene,
/// Q(n) the triangles referenced in n's subtree (with spatial splits a triangle is in every subtree that
/// references any part of it), A the surface area (each triangle clipped to the closed box), and C(n) the
/// node's cost by `cost` as SAH weighs it: c_trav for an inner node, cost.leaf_cost(count) for a leaf.
/// 0 for an empty tree or a scene without area. `bvh` must be valid for `triangles` (validate.h); a
/// reference out of range is an Error.
///
/// Each triangle walks the tree from the root through the nodes its box overlaps, skipping the area
/// test on the nodes whose subtree references it (known from its leaves' positions in depth-first
/// order) and leaving a subtree once the triangle has no area in its box, since children lie inside
/// their parent. Triangles run in parallel with TBB in fixed blocks whose sums are added in order, so
/// the result is the same for any thread count.
double epo_cost(const Bvh& bvh, std::span<const Triangle> triangles, const SahCost& cost);

/// Weight of EPO in the paper's combined predictor, (1 - w) * SAH + w * EPO (section 5). The value is
/// tinybvh's (W_EPO = 0.71, used by its BVH::EPOCost for this blend); it is taken from there, not from
/// the paper's text, whose weight depends on the scene and rays it was fitted to.
inline constexpr double kEpoWeight = 0.71;

/// The combined predictor: (1 - kEpoWeight) * sah + kEpoWeight * epo.
constexpr double sah_epo_cost(double sah, double epo) {
  return (1.0 - kEpoWeight) * sah + kEpoWeight * epo;
}

}  // namespace sahbench
