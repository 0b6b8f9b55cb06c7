#pragma once
// Sibling order of the common format, which the any-hit kernels follow: they visit the children a ray
// enters in storage order, so a node's first children are the ones tried first for an occluder.

#include "core/bvh.h"

namespace sahbench {

/// Reorders the children of every inner node of `bvh` largest surface area first (stable: equal areas
/// keep the builder's order). Only sibling order changes: the same boxes, leaves and references, so
/// the SAH cost, the closest hits and the set of nodes a ray enters are those of the builder's tree.
///
/// Why: a shadow ray stops at its first occluder, and a larger box is more likely to hold one (the
/// probability that a ray meeting the parent meets a child is the ratio of their areas, the SAH's own
/// assumption); this is the simplest form of ordering children by their chance of occlusion (Ize and
/// Hansen 2011, "RTSAH Traversal Order for Occlusion Rays"). Measured on Sponza, bunny, dragon and the
/// 1M terrain, the 8-wide any-hit kernel in this order was 2 to 7% faster than nearest first
/// (results in the notes of issue 4). Every builder in the registry applies it to its output.
void order_children_by_area(Bvh& bvh);

}  // namespace sahbench
