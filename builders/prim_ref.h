#pragma once
// The working record of top-down builders: a primitive's box and its index, 32 bytes, permuted in
// place during the build. Moving these records rather than indices keeps each node's primitives
// contiguous in memory, which is what makes binning fast on large inputs (as in Embree's PrimRef).

#include <cstdint>

#include "core/aabb.h"

namespace sahbench {

struct PrimRef {
  Aabb bounds;
  uint32_t id = 0;
  uint32_t pad_ = 0;

  /// Box centre, the point the builders bin and sort by.
  Vec3 centroid() const { return bounds.center(); }
};
static_assert(sizeof(PrimRef) == 32);

}  // namespace sahbench
