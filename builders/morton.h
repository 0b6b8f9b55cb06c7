#pragma once
// Morton codes of primitive box centres and the primitives sorted by them: the first steps of the linear
// BVH builders (Lauterbach et al. 2009, "Fast BVH Construction on GPUs"; Karras 2012, "Maximizing
// Parallelism in the Construction of BVHs, Octrees, and k-d Trees", section 4). A code interleaves the
// bits of the centre's cell on a 2^b grid per axis (b = 10 for 30-bit codes, 21 for 63-bit ones), so
// sorting by code orders the primitives along a Z-order curve and each run of equal leading bits is an
// octree cell.

#include <cstdint>
#include <span>

#include "core/aabb.h"
#include "core/huge_pages.h"

namespace sahbench {

/// Bits of a Morton code held in `Code`: 30 in a uint32_t, 63 in a uint64_t.
template <class Code>
inline constexpr uint32_t kMortonBits = sizeof(Code) == 4 ? 30 : 63;

/// Interleaves the low 10 bits of x, y and z: bit i of x becomes bit 3i + 2 of the code, of y bit 3i + 1,
/// of z bit 3i.
uint32_t morton30(uint32_t x, uint32_t y, uint32_t z);
/// The same with the low 21 bits of each.
uint64_t morton63(uint32_t x, uint32_t y, uint32_t z);

template <class Code>
struct MortonOrder {
  HugePageArray<Code> codes;    ///< sorted, one per position
  HugePageArray<uint32_t> ids;  ///< the primitive at each position
};

/// The primitives sorted by the Morton codes of their box centres, stably: equal codes keep the order of
/// the primitives' indices. The grid spans the centres' bounding box with cubic cells (the box's largest
/// extent divided into 2^b), so that each level of the code halves space along one axis in world units,
/// as a spatial median split would. Codes and the sort are computed in parallel, and the result does not
/// depend on the thread count.
template <class Code>
MortonOrder<Code> sort_by_morton(std::span<const Aabb> bounds);

extern template MortonOrder<uint32_t> sort_by_morton<uint32_t>(std::span<const Aabb>);
extern template MortonOrder<uint64_t> sort_by_morton<uint64_t>(std::span<const Aabb>);

}  // namespace sahbench
