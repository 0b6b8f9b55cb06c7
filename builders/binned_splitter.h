#pragma once
// The binned SAH split search and partition (Wald 2007, see binned_sah.h) over PrimRefs: the splitter of
// the binned_sah builder, and the object-split half of the SBVH builder, whose references carry clipped
// boxes. Binning, the SAH sweep and partitioning are SIMD over the three axes (core/simd.h).

#include <cstdint>
#include <memory>
#include <span>

#include "builders/binned_sah.h"
#include "builders/prim_ref.h"
#include "builders/top_down.h"
#include "core/build_input.h"
#include "core/huge_pages.h"

namespace sahbench {

/// The boxes of the two sides of a split, as the split search saw them.
struct SplitBounds {
  Aabb left, right;
};

/// A Splitter for build_top_down (see top_down.h) over `refs`: each node's references are binned by box
/// centre into bins_for_node() bins per axis, and the plane of least SAH cost is chosen, or a size split
/// (size_split.h) where one costs less and TopDownConfig::size_split offers it. Nodes of 64K
/// references or more are binned and partitioned in parallel, in fixed chunks, so the result does not
/// depend on the thread count. Partitions leave NodeRange::spare at 0.
class BinnedSplitter {
 public:
  BinnedSplitter(std::span<PrimRef> refs, const BinnedSahParams& params) : refs_(refs), params_(params) {}

  Split find_split(const NodeRange& range) const;
  /// Same, and the boxes of the two sides of the split found (untouched when it is invalid).
  Split find_split(const NodeRange& range, SplitBounds& sides) const;
  Partition partition(const NodeRange& range, const Split& split);
  /// Object median on the axis of largest centroid extent, ties broken by primitive index.
  Partition partition_median(const NodeRange& range);
  uint32_t prim_id(uint32_t position) const { return refs_[position].id; }

 private:
  std::span<PrimRef> refs_;
  const BinnedSahParams& params_;
};

/// Writes refs[i] = {input.bounds[i], i} for every primitive, in parallel, and returns the root range
/// [0, n) with its bounds (merged exactly, so deterministic). `refs` may be uninitialised memory.
NodeRange make_prim_refs(const BuildInput& input, std::span<PrimRef> refs);

/// The range [begin, end) of `refs` with its bounds and centroid bounds, computed as the splitter does.
NodeRange bounds_of(std::span<const PrimRef> refs, uint32_t begin, uint32_t end);

// Storage for PrimRefs, left uninitialised on allocation and on huge pages (core/huge_pages.h):
// make_prim_refs (or its caller) writes every element in its parallel loop, so the memory is written
// once, and the first touch of each page is taken there, by all threads.
using PrimRefArray = HugePageArray<PrimRef>;

}  // namespace sahbench
