#pragma once
// Refitting: after the triangles move, recompute every box of a tree bottom-up and keep its topology
// (the standard update for deforming geometry; e.g. Wald, Boulos and Shirley 2007, "Ray Tracing
// Deformable Scenes Using Dynamic Bounding Volume Hierarchies", section 4). Far cheaper than a rebuild;
// the tree's quality (SAH cost) degrades as the motion takes the geometry away from the pose it was
// built for.

#include <span>

#include "core/bvh.h"
#include "core/triangle.h"

namespace sahbench {

/// Recomputes every node box of `bvh` from `triangles`, the same triangles (same indices) in new
/// positions: a leaf's box becomes the union of the boxes of the triangles it references, an inner
/// node's the union of its children's. Works for any arity (2 to 8) and any node order. For trees with
/// spatial splits (references repeated, leaf boxes clipped to part of a triangle) a leaf's box becomes
/// its triangles' full boxes: larger than a rebuild's clipped boxes, but still containing every hit, so
/// traversal stays correct. Runs in parallel with TBB under the caller's thread limit; the result does
/// not depend on the thread count. `bvh` must be valid for `triangles` (every reference in range).
void refit(Bvh& bvh, std::span<const Triangle> triangles);

}  // namespace sahbench
