#pragma once
/// Splits by size, a candidate beside the centroid planes of the top-down builders: the primitives whose
/// boxes are large against the node's on one side, the rest on the other.
///
/// No centroid plane takes an enclosing shell apart from what it encloses: the floor and the outer walls
/// of a room lie on every side of its furniture's centroids, so each plane leaves some of them with the
/// furniture, and that child's box spans the room (Crytek Sponza's top nodes; b50e90a has the figures).
/// Spatial splits (Stich et al. 2009) and early split clipping (Karras and Aila 2013) attack the same
/// large triangles by splitting their references; this costs no reference.
///
/// Size classes by powers of two: class k holds the boxes with half-area in (A / 2^(k+1), A / 2^k] of
/// the node's half-area A, the last class everything smaller (and boxes of no area). The candidates are
/// classes [0, k] against the rest, costed by the same SahCost as the planes. A class is a function of
/// the two half-areas alone, so binning and partitioning agree on every primitive, in any order and for
/// any thread count.

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <limits>

#include "builders/top_down.h"
#include "core/aabb.h"
#include "core/sah.h"

namespace sahbench {

inline constexpr uint32_t kSizeClasses = 8;
/// Split::axis of a size split; Split::position is then its last large class.
inline constexpr uint32_t kSizeSplitAxis = 3;
/// Nodes of fewer primitives are not offered size splits: they pay near the top of a tree, where a shell
/// encloses much, and each node offered one costs a pass over its primitives (the README's builders
/// section has the trade measured on Sponza).
inline constexpr uint32_t kSizeSplitMinPrims = 512;

/// The size class of a box of half-area `area` in a node of half-area `node_area` (> 0): floor(log2(
/// node_area / area)), clamped to the classes, from the two floats' exponents and mantissas (exact, and
/// without the division and the libm call that cost more than the rest of the pass).
inline uint32_t size_class(float area, float node_area) {
  const auto a = std::bit_cast<uint32_t>(area), n = std::bit_cast<uint32_t>(node_area);
  constexpr uint32_t kMantissa = (1u << 23) - 1;
  // Zero, negative, NaN and subnormal areas count as the smallest class.
  if (!(area > 0.0f) || (a >> 23) == 0) return kSizeClasses - 1;
  const int k = static_cast<int>(n >> 23) - static_cast<int>(a >> 23) - ((n & kMantissa) < (a & kMantissa));
  return static_cast<uint32_t>(std::clamp(k, 0, static_cast<int>(kSizeClasses) - 1));
}

/// Whether a primitive of half-area `area` goes to the left (large) side of the size split `split` of a
/// node of half-area `node_area`.
inline bool goes_left_of_size_split(const Split& split, float area, float node_area) {
  return size_class(area, node_area) <= split.position;
}

/// The boxes and counts of a node's size classes.
struct SizeBins {
  std::array<Aabb, kSizeClasses> bounds;
  std::array<uint32_t, kSizeClasses> counts{};

  void merge(const SizeBins& o) {
    for (uint32_t k = 0; k < kSizeClasses; ++k) {
      bounds[k].extend(o.bounds[k]);
      counts[k] += o.counts[k];
    }
  }
};

/// The size classes of a node of `n` primitives, `box(i)` the box of its i-th (i < n), of half-area
/// `node_area`. Nodes of 64K primitives or more are binned in parallel; boxes and counts merge exactly, so
/// the result depends neither on how TBB divides the range nor on the thread count. (The binned builder
/// has its own loop over its packed records, with the same result; the split-search tests compare them.)
template <class BoxAt>
SizeBins bin_sizes(uint32_t n, BoxAt&& box, float node_area) {
  constexpr uint32_t kChunk = 1u << 12, kParallel = 1u << 16;
  auto bin = [&](uint32_t begin, uint32_t end, SizeBins acc) {
    for (uint32_t i = begin; i < end; ++i) {
      const Aabb& b = box(i);
      const uint32_t k = size_class(b.half_area(), node_area);
      acc.bounds[k].extend(b);
      ++acc.counts[k];
    }
    return acc;
  };
  if (n < kParallel) return bin(0, n, {});
  return tbb::parallel_reduce(
      tbb::blocked_range<uint32_t>(0, n, kChunk), SizeBins{},
      [&](const tbb::blocked_range<uint32_t>& r, SizeBins acc) { return bin(r.begin(), r.end(), acc); },
      [](SizeBins a, const SizeBins& b) {
        a.merge(b);
        return a;
      });
}

/// A size split and the boxes of its two sides.
struct SizeSplit {
  Split split;
  Aabb large, rest;
};

/// The best size split of a node of `n` primitives binned into `bins`, of half-area `node_area`: invalid
/// when every primitive is in one class.
inline SizeSplit best_size_split(const SizeBins& bins, uint32_t n, float node_area, const SahCost& cost) {
  // Right-to-left suffixes, then a left-to-right sweep, as the plane searches weigh their candidates.
  std::array<float, kSizeClasses> right_weighted{};
  Aabb acc;
  uint32_t count = 0;
  for (uint32_t k = kSizeClasses; k-- > 1;) {
    acc.extend(bins.bounds[k]);
    count += bins.counts[k];
    right_weighted[k] = acc.half_area() * static_cast<float>(cost.blocks(count));
  }
  SizeSplit best;
  float best_weighted = std::numeric_limits<float>::infinity();
  acc = Aabb{};
  count = 0;
  for (uint32_t k = 0; k + 1 < kSizeClasses; ++k) {
    acc.extend(bins.bounds[k]);
    count += bins.counts[k];
    if (count == 0 || count == n) continue;
    const float weighted = acc.half_area() * static_cast<float>(cost.blocks(count)) + right_weighted[k + 1];
    if (weighted < best_weighted) {
      best_weighted = weighted;
      best.split.axis = kSizeSplitAxis;
      best.split.position = k;
      best.large = acc;
    }
  }
  if (!(best_weighted < std::numeric_limits<float>::infinity())) return {};
  best.split.cost = cost.split_cost_from_weighted(node_area, best_weighted);
  for (uint32_t k = best.split.position + 1; k < kSizeClasses; ++k) best.rest.extend(bins.bounds[k]);
  return best;
}

}  // namespace sahbench
