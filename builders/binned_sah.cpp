#include "builders/binned_sah.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace sahbench {
namespace {

// Nodes with at least this many primitives are binned and partitioned by several tasks. Below it, one
// task is faster than the coordination. The value only affects speed: both paths give the same result
// (binning merges with min/max and integer sums, which are exact in any order).
constexpr uint32_t kParallelThreshold = 1u << 16;
// Chunk of primitives handled by one task in the parallel passes. Fixed, so that the parallel partition's
// output order does not depend on the thread count.
constexpr uint32_t kChunk = 1u << 12;

// Trivially constructible, so a BinSet costs nothing until its `bin_count` bins per axis are reset:
// nodes are small on average and initialising all kMaxBins bins would dominate their binning.
struct Bin {
  float lo[3], hi[3];
  uint32_t count;

  void reset() {
    for (int a = 0; a < 3; ++a) lo[a] = std::numeric_limits<float>::infinity(), hi[a] = -lo[a];
    count = 0;
  }
  void extend(const Aabb& b) {
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], b.min[a]), hi[a] = std::max(hi[a], b.max[a]);
  }
  void merge(const Bin& o) {
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], o.lo[a]), hi[a] = std::max(hi[a], o.hi[a]);
    count += o.count;
  }
  Aabb box() const { return {{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}}; }
};

// Maps a centroid coordinate to a bin: bin = floor((c - min) * bins / extent), clamped to the last bin.
// Rounding is monotone, so bins are ordered by centroid and every binned split is a prefix of the
// sorted order (which is why a full sweep can never do worse).
struct BinMapping {
  Vec3 offset;
  Vec3 scale;  // 0 on an axis with no centroid extent: every primitive lands in bin 0 there
  uint32_t bin_count;

  BinMapping(const Aabb& centroid_bounds, uint32_t bins) : offset(centroid_bounds.min), bin_count(bins) {
    const Vec3 extent = centroid_bounds.extent();
    // An extent so small that bins / extent overflows (denormals) is treated as no extent, so that
    // (c - min) * scale is always finite and the bin index well defined.
    for (int a = 0; a < 3; ++a) {
      const float s = extent[a] > 0.0f ? static_cast<float>(bins) / extent[a] : 0.0f;
      scale[a] = std::isfinite(s) ? s : 0.0f;
    }
  }

  uint32_t bin(float c, int axis) const {
    const auto b = static_cast<uint32_t>((c - offset[axis]) * scale[axis]);
    return b < bin_count ? b : bin_count - 1;
  }
};

struct BinSet {
  Bin bins[3][kMaxBins];
  uint32_t bin_count;

  explicit BinSet(uint32_t count) : bin_count(count) {
    for (int a = 0; a < 3; ++a)
      for (uint32_t b = 0; b < count; ++b) bins[a][b].reset();
  }

  void add(const BinMapping& mapping, const PrimRef& ref) {
    const Vec3 c = ref.centroid();
    for (int a = 0; a < 3; ++a) {
      Bin& bin = bins[a][mapping.bin(c[a], a)];
      bin.extend(ref.bounds);
      ++bin.count;
    }
  }

  void merge(const BinSet& other) {
    for (int a = 0; a < 3; ++a)
      for (uint32_t b = 0; b < bin_count; ++b) bins[a][b].merge(other.bins[a][b]);
  }
};

// SAH sweep over the bins: right-to-left accumulates the right side's areas, left-to-right evaluates
// the split before each bin. Only non-empty bins are visited (a plane between two empty bins gives the
// same partition as its neighbour), which keeps small nodes cheap whatever the bin count. Candidates
// are compared by weighted area and only the winner is converted to a cost (SahCost explains why that
// picks the same split). Ties keep the first candidate (lowest axis, lowest bin).
Split best_split(const BinSet& set, const BinMapping& mapping, float parent_area, const SahCost& cost) {
  Split best;
  if (!(parent_area > 0.0f)) return best;  // a point-sized node: areas carry no information
  float best_weighted = std::numeric_limits<float>::infinity();
  std::array<uint32_t, kMaxBins> used;  // indices of the non-empty bins, in order
  std::array<float, kMaxBins> right_weighted;
  for (int a = 0; a < 3; ++a) {
    if (mapping.scale[a] == 0.0f) continue;
    const Bin* bins = set.bins[a];
    uint32_t k = 0;
    for (uint32_t b = 0; b < set.bin_count; ++b)
      if (bins[b].count) used[k++] = b;
    if (k < 2) continue;
    Aabb acc;
    uint32_t count = 0;
    for (uint32_t j = k; j-- > 1;) {
      acc.extend(bins[used[j]].box());
      count += bins[used[j]].count;
      right_weighted[j] = acc.half_area() * static_cast<float>(count);
    }
    acc = Aabb{};
    count = 0;
    for (uint32_t j = 1; j < k; ++j) {
      acc.extend(bins[used[j - 1]].box());
      count += bins[used[j - 1]].count;
      const float weighted = acc.half_area() * static_cast<float>(count) + right_weighted[j];
      if (weighted < best_weighted) {
        best_weighted = weighted;
        best.axis = static_cast<uint32_t>(a);
        best.position = used[j];
      }
    }
  }
  if (best_weighted < std::numeric_limits<float>::infinity())
    best.cost = cost.split_cost_from_weighted(parent_area, best_weighted);
  return best;
}

// Accumulates the bounds of one side of a partition.
struct SideBounds {
  Aabb bounds, centroid_bounds;
  void add(const PrimRef& ref) {
    bounds.extend(ref.bounds);
    centroid_bounds.extend(ref.centroid());
  }
  void merge(const SideBounds& o) {
    bounds.extend(o.bounds);
    centroid_bounds.extend(o.centroid_bounds);
  }
};

class BinnedSplitter {
 public:
  BinnedSplitter(std::span<PrimRef> refs, const BinnedSahParams& params) : refs_(refs), params_(params) {
    if (refs.size() >= kParallelThreshold) scratch_.resize(refs.size());
  }

  Split find_split(const NodeRange& range) const {
    const BinMapping mapping(range.centroid_bounds, bins_for_node(params_, range.size()));
    const BinSet set = bin(range, mapping);
    return best_split(set, mapping, range.bounds.half_area(), params_.top_down.cost);
  }

  Partition partition(const NodeRange& range, const Split& split) {
    const BinMapping mapping(range.centroid_bounds, bins_for_node(params_, range.size()));
    const int axis = static_cast<int>(split.axis);
    auto goes_left = [&](const PrimRef& r) { return mapping.bin(r.centroid()[axis], axis) < split.position; };
    return range.size() >= kParallelThreshold ? partition_parallel(range, goes_left)
                                              : partition_serial(range, goes_left);
  }

  // Object median on the axis of largest centroid extent; ties broken by primitive index so the order
  // is total and the result deterministic.
  Partition partition_median(const NodeRange& range) {
    const int axis = static_cast<int>(largest_axis(range.centroid_bounds.extent()));
    PrimRef* first = refs_.data() + range.begin;
    PrimRef* mid = first + range.size() / 2;
    std::nth_element(first, mid, refs_.data() + range.end, [axis](const PrimRef& a, const PrimRef& b) {
      const float ca = a.centroid()[axis], cb = b.centroid()[axis];
      return ca < cb || (ca == cb && a.id < b.id);
    });
    const uint32_t split = static_cast<uint32_t>(mid - refs_.data());
    SideBounds left, right;
    for (uint32_t i = range.begin; i < split; ++i) left.add(refs_[i]);
    for (uint32_t i = split; i < range.end; ++i) right.add(refs_[i]);
    return {{range.begin, split, left.bounds, left.centroid_bounds},
            {split, range.end, right.bounds, right.centroid_bounds}};
  }

  uint32_t prim_id(uint32_t position) const { return refs_[position].id; }

 private:
  BinSet bin(const NodeRange& range, const BinMapping& mapping) const {
    const uint32_t bins = mapping.bin_count;
    auto bin_chunk = [&](uint32_t begin, uint32_t end) {
      BinSet set(bins);
      for (uint32_t i = begin; i < end; ++i) set.add(mapping, refs_[i]);
      return set;
    };
    if (range.size() < kParallelThreshold) return bin_chunk(range.begin, range.end);
    return tbb::parallel_reduce(
        tbb::blocked_range<uint32_t>(range.begin, range.end, kChunk), bin_chunk(0, 0),
        [&](const tbb::blocked_range<uint32_t>& r, BinSet acc) {
          acc.merge(bin_chunk(r.begin(), r.end()));
          return acc;
        },
        [](BinSet a, const BinSet& b) {
          a.merge(b);
          return a;
        });
  }

  // In-place two-pointer partition (Hoare), accumulating both sides' bounds as it goes.
  template <class Pred>
  Partition partition_serial(const NodeRange& range, Pred goes_left) {
    SideBounds left, right;
    uint32_t i = range.begin, j = range.end;
    while (true) {
      while (i < j && goes_left(refs_[i])) left.add(refs_[i++]);
      while (i < j && !goes_left(refs_[j - 1])) right.add(refs_[--j]);
      if (i >= j) break;
      std::swap(refs_[i], refs_[j - 1]);
    }
    return {{range.begin, i, left.bounds, left.centroid_bounds}, {i, range.end, right.bounds, right.centroid_bounds}};
  }

  // Stable partition in fixed chunks: count each chunk's left side, prefix-sum, scatter into scratch, copy
  // back. The chunking does not depend on the thread count, so neither does the order.
  template <class Pred>
  Partition partition_parallel(const NodeRange& range, Pred goes_left) {
    const uint32_t n = range.size();
    const uint32_t chunks = (n + kChunk - 1) / kChunk;
    std::vector<uint32_t> left_before(chunks + 1, 0);
    std::vector<SideBounds> left(chunks), right(chunks);
    tbb::parallel_for(0u, chunks, [&](uint32_t c) {
      const uint32_t begin = range.begin + c * kChunk, end = std::min(range.end, begin + kChunk);
      uint32_t count = 0;
      for (uint32_t i = begin; i < end; ++i) {
        if (goes_left(refs_[i])) {
          ++count;
          left[c].add(refs_[i]);
        } else {
          right[c].add(refs_[i]);
        }
      }
      left_before[c + 1] = count;
    });
    for (uint32_t c = 0; c < chunks; ++c) left_before[c + 1] += left_before[c];
    const uint32_t left_total = left_before[chunks];
    tbb::parallel_for(0u, chunks, [&](uint32_t c) {
      const uint32_t begin = range.begin + c * kChunk, end = std::min(range.end, begin + kChunk);
      uint32_t l = range.begin + left_before[c];
      uint32_t r = range.begin + left_total + (c * kChunk - left_before[c]);
      for (uint32_t i = begin; i < end; ++i) scratch_[goes_left(refs_[i]) ? l++ : r++] = refs_[i];
    });
    tbb::parallel_for(tbb::blocked_range<uint32_t>(range.begin, range.end, kChunk), [&](const auto& r) {
      std::copy(scratch_.begin() + r.begin(), scratch_.begin() + r.end(), refs_.begin() + r.begin());
    });
    SideBounds l, r;
    for (uint32_t c = 0; c < chunks; ++c) {
      l.merge(left[c]);
      r.merge(right[c]);
    }
    const uint32_t mid = range.begin + left_total;
    return {{range.begin, mid, l.bounds, l.centroid_bounds}, {mid, range.end, r.bounds, r.centroid_bounds}};
  }

  std::span<PrimRef> refs_;
  const BinnedSahParams& params_;
  std::vector<PrimRef> scratch_;  // sized for the whole input; disjoint ranges never overlap in it
};

void check_bins(uint32_t bins) {
  if (bins < kMinBins || bins > kMaxBins)
    throw Error("binned_sah: bins = " + std::to_string(bins) + " is outside [" + std::to_string(kMinBins) + ", " +
                std::to_string(kMaxBins) + "]");
}

// PrimRefs and the root's bounds, in parallel; bounds merge exactly, so the result is deterministic.
std::vector<PrimRef> make_prim_refs(const BuildInput& input, NodeRange& root) {
  const auto n = static_cast<uint32_t>(input.size());
  std::vector<PrimRef> refs(n);
  SideBounds all = tbb::parallel_reduce(
      tbb::blocked_range<uint32_t>(0, n, kChunk), SideBounds{},
      [&](const tbb::blocked_range<uint32_t>& r, SideBounds acc) {
        for (uint32_t i = r.begin(); i < r.end(); ++i) {
          refs[i] = {input.bounds[i], i, 0};
          acc.add(refs[i]);
        }
        return acc;
      },
      [](SideBounds a, const SideBounds& b) {
        a.merge(b);
        return a;
      });
  root = {0, n, all.bounds, all.centroid_bounds};
  return refs;
}

}  // namespace

uint32_t bins_for_node(const BinnedSahParams& params, uint32_t prim_count) {
  if (!params.adaptive_bins) return params.bins;
  return std::min(params.bins, kMinBins + prim_count / 20);
}

Bvh build_binned_sah(const BuildInput& input, const BinnedSahParams& params) {
  check_bins(params.bins);
  check_config(params.top_down, "binned_sah");
  check_prim_count(input.size(), "binned_sah");
  NodeRange root;
  std::vector<PrimRef> refs = make_prim_refs(input, root);
  BinnedSplitter splitter(refs, params);
  return build_top_down(splitter, params.top_down, root);
}

Split find_binned_split(const BuildInput& input, std::span<const uint32_t> prims, const BinnedSahParams& params) {
  check_bins(params.bins);
  std::vector<PrimRef> refs;
  refs.reserve(prims.size());
  SideBounds all;
  for (uint32_t p : prims) {
    refs.push_back({input.bounds[p], p, 0});
    all.add(refs.back());
  }
  BinnedSplitter splitter(refs, params);
  return splitter.find_split({0, static_cast<uint32_t>(refs.size()), all.bounds, all.centroid_bounds});
}

}  // namespace sahbench
