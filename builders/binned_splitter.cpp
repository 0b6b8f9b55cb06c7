#include "builders/binned_splitter.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "builders/size_split.h"
#include "core/simd.h"

namespace sahbench {
namespace {

// Nodes with at least this many primitives are binned and partitioned by several tasks. Below it, one
// task is faster than the coordination. The value only affects speed and the order of primitives within
// each side, never the sides themselves (binning merges with min/max and integer sums, which are exact in
// any order), and it does not depend on the thread count.
constexpr uint32_t kParallelThreshold = 1u << 16;
// Chunk of primitives handled by one task in the parallel passes. Fixed, so that the parallel partition's
// output order does not depend on the thread count.
constexpr uint32_t kChunk = 1u << 12;
// Nodes with at least this many primitives are binned into four interleaved bin sets (add_interleaved);
// below it, resetting and merging the extra sets costs more than it saves (measured on Sponza).
constexpr uint32_t kInterleaveThreshold = 128;

using simd::Vec4f;
using simd::Vec4i;

// A box as two 4-lane vectors (lane 3 unused), the form the per-primitive loops work on: extending it,
// taking its centre and binning that centre treat the three axes at once.
struct PackedBox {
  Vec4f lo, hi;

  static PackedBox empty() {
    return {simd::splat(std::numeric_limits<float>::infinity()),
            simd::splat(-std::numeric_limits<float>::infinity())};
  }

  // Two unaligned loads straight from the record: bytes [0, 16) hold (min.x, min.y, min.z, max.x) and
  // bytes [12, 28) hold (max.x, max.y, max.z, id), both inside the 32 bytes; the extra lanes are unused.
  static PackedBox of(const PrimRef& ref) {
    const auto* bytes = reinterpret_cast<const std::byte*>(&ref);
    return {simd::load4(bytes + kMinOffset), simd::load4(bytes + kMaxOffset)};
  }

  // The same operations as Aabb::center, so binning sees the centroids that PrimRef::centroid gives.
  Vec4f center() const { return (lo + hi) * simd::splat(0.5f); }

  // Operands in this order reproduce Aabb::extend bit for bit: minps returns its second operand when
  // the comparison fails, as std::min(acc, x) returns its first (NaN and signed zeros included).
  void extend(const PackedBox& b) {
    lo = simd::min(b.lo, lo);
    hi = simd::max(b.hi, hi);
  }
  void extend(Vec4f p) {
    lo = simd::min(p, lo);
    hi = simd::max(p, hi);
  }

  Aabb aabb() const {
    float l[4], h[4];
    simd::store4(l, lo);
    simd::store4(h, hi);
    return {{l[0], l[1], l[2]}, {h[0], h[1], h[2]}};
  }

  static constexpr std::size_t kMinOffset = offsetof(PrimRef, bounds) + offsetof(Aabb, min);
  static constexpr std::size_t kMaxOffset = offsetof(PrimRef, bounds) + offsetof(Aabb, max);
};
static_assert(PackedBox::kMinOffset + sizeof(Vec4f) <= sizeof(PrimRef) &&
                  PackedBox::kMaxOffset + sizeof(Vec4f) <= sizeof(PrimRef),
              "PackedBox::of reads 16 bytes at each corner, which must stay inside the PrimRef");

// Maps a centroid coordinate to a bin: bin = floor((c - min) * bins / extent), clamped to the last bin.
// Rounding is monotone, so bins are ordered by centroid and every binned split is a prefix of the
// sorted order (which is why a full sweep can never do worse). Binning and partitioning both call
// bins(), so they agree on every primitive's bin.
struct BinMapping {
  uint32_t bin_count;
  Vec4f offset;  // the centroid bounds' min; lane 3 = 0
  Vec4f scale;   // bins / extent; 0 on an axis with no centroid extent (all in bin 0) and in lane 3
  Vec4i last_bin;

  BinMapping(const Aabb& centroid_bounds, uint32_t bins) : bin_count(bins), last_bin(simd::splat(bins - 1)) {
    const Vec3 lo = centroid_bounds.min, hi = centroid_bounds.max;
    offset = simd::make4(lo.x, lo.y, lo.z, 0.0f);
    // Lane 3 gets extent 0 and so scale 0.
    const Vec4f extent = simd::make4(hi.x, hi.y, hi.z, 0.0f) - offset;
    const Vec4f q = simd::splat(static_cast<float>(bins)) / extent;
    // No extent, or one so small that bins / extent overflows (denormals), gives scale 0, so that
    // (c - min) * scale is always finite and the bin index well defined.
    const Vec4f usable = simd::greater(extent, simd::splat(0.0f)) &
                         simd::less(q, simd::splat(std::numeric_limits<float>::infinity()));
    scale = usable & q;
  }

  // The bin on each axis (lanes 0 to 2). (c - min) * scale is at least 0 (min is the smallest centroid)
  // and about `bins` at most, so truncating to int32 is exact and the unsigned clamp only has to catch
  // the rounding up to `bins`.
  Vec4i bins(Vec4f center) const {
    return simd::min_u32(simd::truncate((center - offset) * scale), last_bin);
  }
};

// A bin's box as (min, -max) in one 8-lane vector (lanes 3 and 7 unused): -max(a, b) = min(-a, -b), so
// one min extends both corners and adding a primitive to a bin is a single 32-byte read-modify-write.
// Negation is exact, and min(-x, -acc) = -max(x, acc) bit for bit (NaN and signed zeros included, as
// both pick their second operand when the comparison fails). Trivially constructible, so that a BinSet
// costs nothing until its `bin_count` bins per axis are reset: nodes are small on average and
// initialising all kMaxBins bins would dominate their binning.
struct Bin {
  simd::Vec8f corners;

  static Bin empty() { return {simd::splat8(std::numeric_limits<float>::infinity())}; }
  static Bin of(const PackedBox& box) { return {simd::join(box.lo, -box.hi)}; }

  void extend(const Bin& b) { corners = simd::min(b.corners, corners); }
  PackedBox box() const { return {simd::low_half(corners), -simd::high_half(corners)}; }
};

// Bins of all three axes. Counts are stored by bin, with lane 3 always 0, so that the SAH sweep loads
// one bin's counts on every axis as a vector.
struct BinSet {
  Bin bins[3][kMaxBins];         // [axis][bin]
  uint32_t counts[kMaxBins][4];  // [bin][axis]
  uint32_t bin_count;

  explicit BinSet(uint32_t count) : bin_count(count) {
    for (int a = 0; a < 3; ++a) std::fill_n(bins[a], count, Bin::empty());
    std::fill_n(&counts[0][0], 4 * count, 0u);
  }

  void add(const BinMapping& mapping, const PackedBox& box) {
    const Vec4i b = mapping.bins(box.center());
    const Bin corners = Bin::of(box);
    add_to(0, simd::lane<0>(b), corners);
    add_to(1, simd::lane<1>(b), corners);
    add_to(2, simd::lane<2>(b), corners);
  }

  void merge(const BinSet& other) {
    for (int a = 0; a < 3; ++a)
      for (uint32_t b = 0; b < bin_count; ++b) bins[a][b].extend(other.bins[a][b]);
    for (uint32_t b = 0; b < bin_count; ++b)
      simd::store4i(counts[b], simd::load4i(counts[b]) + simd::load4i(other.counts[b]));
  }

  Vec4i counts_of(uint32_t bin) const { return simd::load4i(counts[bin]); }

 private:
  void add_to(int axis, uint32_t bin, const Bin& corners) {
    bins[axis][bin].extend(corners);
    ++counts[bin][axis];
  }
};

// One side of the planes of all three axes, swept together: lane a of every result belongs to axis a.
struct SweepSide {
  Bin axis[3] = {Bin::empty(), Bin::empty(), Bin::empty()};
  Vec4i count = simd::splat(0u);

  void add_bin(const BinSet& set, uint32_t bin) {
    for (int a = 0; a < 3; ++a) axis[a].extend(set.bins[a][bin]);
    count = count + set.counts_of(bin);
  }

  // half_area() * count, with Aabb::half_area's operations in its order, bit for bit, and 0 for an empty
  // box. A box is empty exactly where some max - min is negative (subtraction of finite floats keeps
  // the sign of the comparison; infinities and NaN agree with is_empty too).
  Vec4f weighted_areas(uint32_t block_shift) const {
    Vec4f ex, ey, ez;
    simd::transpose3(extent(0), extent(1), extent(2), ex, ey, ez);
    const Vec4f zero = simd::splat(0.0f);
    const Vec4f empty = simd::less(ex, zero) | simd::less(ey, zero) | simd::less(ez, zero);
    // SahCost::blocks: ceil(count / block) for a power-of-two block.
    const Vec4i blocks = block_shift == 0
                             ? count
                             : simd::shift_right(count + simd::splat((1u << block_shift) - 1), block_shift);
    return simd::and_not(empty, ex * ey + ey * ez + ez * ex) * simd::to_float(blocks);
  }

 private:
  Vec4f extent(int a) const {
    const PackedBox box = axis[a].box();
    return box.hi - box.lo;
  }
};

// The best of the three axes' candidates: the lowest axis among those of least weighted area, as a scan
// in axis order with a strict comparison keeps. Written with conditional moves: which axis wins is
// unpredictable, and most nodes are small enough for a mispredicted branch to matter.
Split pick_axis(Vec4f best_weighted, Vec4i best_position, float parent_area, const SahCost& cost) {
  float weighted[4];
  uint32_t position[4];
  simd::store4(weighted, best_weighted);
  simd::store4i(position, best_position);
  uint32_t axis = 0;
  for (uint32_t a = 1; a < 3; ++a) axis = weighted[a] < weighted[axis] ? a : axis;
  Split best;
  if (!(weighted[axis] < std::numeric_limits<float>::infinity())) return best;
  best.axis = axis;
  best.position = position[axis];
  best.cost = cost.split_cost_from_weighted(parent_area, weighted[axis]);
  return best;
}

// SAH sweep over the bins of all three axes at once, one axis per lane: right-to-left accumulates the
// right side's weighted areas, left-to-right evaluates the plane before each bin. Candidates are
// compared by weighted area and only the winner is converted to a cost (SahCost explains why that picks
// the same split). Ties keep the first candidate (lowest axis, lowest bin).
//
// Empty bins are swept too, which keeps the loop free of branches: a plane next to an empty bin gives the
// same partition, bounds and weighted area (bit for bit, as extending by an empty box changes nothing) as
// the plane at the next non-empty bin, and the split is reported at that bin, so it is the one a sweep
// over the non-empty bins alone finds. Planes with an empty side are not candidates.
template <uint32_t kFixedBins>
Split best_split(const BinSet& set, uint32_t prim_count, float parent_area, const SahCost& cost) {
  const uint32_t bins = kFixedBins ? kFixedBins : set.bin_count;
  const auto block_shift = static_cast<uint32_t>(std::countr_zero(cost.block));
  std::array<Vec4f, kMaxBins> right_weighted;  // [plane]: weighted area of bins [plane, bins)
  std::array<Vec4i, kMaxBins> next_used;       // [plane]: first non-empty bin at or after the plane
  SweepSide right;
  Vec4i used = simd::splat(bins);
  for (uint32_t b = bins; b-- > 1;) {
    right.add_bin(set, b);
    right_weighted[b] = right.weighted_areas(block_shift);
    used = simd::select(simd::greater(set.counts_of(b), simd::splat(0u)), used, simd::splat(b));
    next_used[b] = used;
  }
  SweepSide left;
  const Vec4i all = simd::splat(prim_count);
  Vec4f best_weighted = simd::splat(std::numeric_limits<float>::infinity());
  Vec4i best_position = simd::splat(0u);
  for (uint32_t b = 1; b < bins; ++b) {
    left.add_bin(set, b - 1);
    const Vec4f weighted = left.weighted_areas(block_shift) + right_weighted[b];
    // Lane 3 counts nothing, so it is never a candidate.
    const Vec4f both_sides = simd::greater(left.count, simd::splat(0u)) & simd::greater(all, left.count);
    const Vec4f better = both_sides & simd::less(weighted, best_weighted);
    best_weighted = simd::select(better, best_weighted, weighted);
    best_position = simd::select(better, best_position, next_used[b]);
  }
  return pick_axis(best_weighted, best_position, parent_area, cost);
}

// Most nodes are small and get kMinBins bins: for them the sweep is compiled with that count fixed, so
// that its loops unroll and its arrays stay in registers.
Split best_split(const BinSet& set, uint32_t prim_count, float parent_area, const SahCost& cost) {
  if (set.bin_count == kMinBins) return best_split<kMinBins>(set, prim_count, parent_area, cost);
  return best_split<0>(set, prim_count, parent_area, cost);
}

// Accumulates the bounds of one side of a partition.
struct SideBounds {
  PackedBox bounds = PackedBox::empty(), centroid_bounds = PackedBox::empty();

  void add(const PackedBox& box) {
    bounds.extend(box);
    centroid_bounds.extend(box.center());
  }
  void merge(const SideBounds& o) {
    bounds.extend(o.bounds);
    centroid_bounds.extend(o.centroid_bounds);
  }
  NodeRange range(uint32_t begin, uint32_t end) const {
    return {begin, end, bounds.aabb(), centroid_bounds.aabb()};
  }
};

// Disjoint position ranges in increasing order, addressed as one sequence of positions.
class Runs {
 public:
  struct Cursor {
    uint32_t run, position;
  };

  void add(uint32_t begin, uint32_t end) {
    if (begin >= end) return;
    runs_.push_back({begin, end});
    starts_.push_back(total_);
    total_ += end - begin;
  }
  uint32_t total() const { return total_; }

  // The cursor at the k-th position of the sequence.
  Cursor at(uint32_t k) const {
    if (k >= total_) return {0, 0};
    const auto run =
        static_cast<uint32_t>(std::upper_bound(starts_.begin(), starts_.end(), k) - starts_.begin() - 1);
    return {run, runs_[run].first + (k - starts_[run])};
  }
  // The position under the cursor, then advances it.
  uint32_t next(Cursor& c) const {
    const uint32_t position = c.position++;
    if (c.position == runs_[c.run].second && c.run + 1 < runs_.size()) c.position = runs_[++c.run].first;
    return position;
  }

 private:
  std::vector<std::pair<uint32_t, uint32_t>> runs_;
  std::vector<uint32_t> starts_;  // index in the sequence of each run's first position
  uint32_t total_ = 0;
};

class SplitterImpl {
 public:
  SplitterImpl(std::span<PrimRef> refs, const BinnedSahParams& params) : refs_(refs), params_(params) {}

  // `sides`, when given, receives the boxes of the two sides of the split found.
  Split find_split(const NodeRange& range, SplitBounds* sides) const {
    const float parent_area = range.bounds.half_area();
    if (!(parent_area > 0.0f)) return {};  // a point-sized node: areas carry no information
    const BinMapping mapping(range.centroid_bounds, bins_for_node(params_, range.size()));
    if (range.size() == 2) return split_pair(range, mapping, parent_area, sides);
    const BinSet set = bin(range, mapping);
    const Split split = best_split(set, range.size(), parent_area, params_.top_down.cost);
    if (params_.top_down.size_split && range.size() >= kSizeSplitMinPrims) {
      const SizeSplit by_size =
          best_size_split(bin_sizes(range, parent_area), range.size(), parent_area, params_.top_down.cost);
      if (by_size.split.cost < split.cost) {  // ties keep the plane
        if (sides) *sides = {by_size.large, by_size.rest};
        return by_size.split;
      }
    }
    if (sides && split.valid()) *sides = side_bounds(set, split);
    return split;
  }

  Partition partition(const NodeRange& range, const Split& split) {
    if (split.axis == kSizeSplitAxis) {
      const float node_area = range.bounds.half_area();
      auto goes_left = [&](const PackedBox& box) {
        return goes_left_of_size_split(split, box.aabb().half_area(), node_area);
      };
      return range.size() >= kParallelThreshold ? partition_parallel(range, goes_left)
                                                : partition_serial(range, goes_left);
    }
    const BinMapping mapping(range.centroid_bounds, bins_for_node(params_, range.size()));
    // Compares the bins of all three axes with the split position and keeps the split axis's bit.
    const Vec4i position = simd::splat(split.position);
    const int axis_bit = 1 << split.axis;
    auto goes_left = [&](const PackedBox& box) {
      return (simd::less_mask(mapping.bins(box.center()), position) & axis_bit) != 0;
    };
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
    for (uint32_t i = range.begin; i < split; ++i) left.add(PackedBox::of(refs_[i]));
    for (uint32_t i = split; i < range.end; ++i) right.add(PackedBox::of(refs_[i]));
    return {left.range(range.begin, split), right.range(split, range.end)};
  }

  uint32_t prim_id(uint32_t position) const { return refs_[position].id; }

 private:
  // Two primitives, the most common node (every leaf of two is one): the only binned split separates
  // them, and it is a candidate on every axis where they fall into different bins, always at the same
  // weighted area, half_area(a) * 1 + half_area(b) * 1 (float addition commutes). The sweep would keep
  // the lowest such axis and report the upper primitive's bin; this gives the same Split without bins.
  Split split_pair(const NodeRange& range, const BinMapping& mapping, float parent_area,
                   SplitBounds* sides) const {
    const PrimRef& a = refs_[range.begin];
    const PrimRef& b = refs_[range.begin + 1];
    const Vec4i bin_a = mapping.bins(PackedBox::of(a).center());
    const Vec4i bin_b = mapping.bins(PackedBox::of(b).center());
    const float weighted = a.bounds.half_area() + b.bounds.half_area();
    const Vec4f candidates = simd::select(simd::equal(bin_a, bin_b), simd::splat(weighted),
                                          simd::splat(std::numeric_limits<float>::infinity()));
    const Split split =
        pick_axis(candidates, simd::max_u32(bin_a, bin_b), parent_area, params_.top_down.cost);
    if (sides && split.valid()) {
      // The primitive in the lower bin on the split axis is the left side.
      uint32_t ba[4];
      simd::store4i(ba, bin_a);
      const bool a_left = ba[split.axis] < split.position;
      *sides = {(a_left ? a : b).bounds, (a_left ? b : a).bounds};
    }
    return split;
  }

  // size_split.h's bin_sizes on the packed records: each class's box one 8-lane Bin, in two sets used in
  // turn so that consecutive references of one class (most are in the smallest classes) do not wait for
  // each other's update; the same boxes and counts, as min and max merge exactly.
  SizeBins bin_sizes(const NodeRange& range, float node_area) const {
    auto run = [&](uint32_t begin, uint32_t end) {
      Bin boxes[2][kSizeClasses];
      for (auto& set : boxes) std::fill_n(set, kSizeClasses, Bin::empty());
      SizeBins bins;
      for (uint32_t i = begin; i < end; ++i) {
        const PrimRef& ref = refs_[i];
        const uint32_t k = size_class(ref.bounds.half_area(), node_area);
        boxes[i & 1][k].extend(Bin::of(PackedBox::of(ref)));
        ++bins.counts[k];
      }
      for (uint32_t k = 0; k < kSizeClasses; ++k) {
        boxes[0][k].extend(boxes[1][k]);
        if (bins.counts[k] != 0) bins.bounds[k] = boxes[0][k].box().aabb();
      }
      return bins;
    };
    if (range.size() < kParallelThreshold) return run(range.begin, range.end);
    return tbb::parallel_reduce(
        tbb::blocked_range<uint32_t>(range.begin, range.end, kChunk), SizeBins{},
        [&](const tbb::blocked_range<uint32_t>& r, SizeBins acc) {
          acc.merge(run(r.begin(), r.end()));
          return acc;
        },
        [](SizeBins a, const SizeBins& b) {
          a.merge(b);
          return a;
        });
  }

  // The boxes of both sides of a split found in `set`: its bins below and from the split position.
  static SplitBounds side_bounds(const BinSet& set, const Split& split) {
    Bin left = Bin::empty(), right = Bin::empty();
    for (uint32_t b = 0; b < set.bin_count; ++b)
      (b < split.position ? left : right).extend(set.bins[split.axis][b]);
    return {left.box().aabb(), right.box().aabb()};
  }

  BinSet bin_serial(uint32_t begin, uint32_t end, const BinMapping& mapping) const {
    BinSet set(mapping.bin_count);
    if (end - begin >= kInterleaveThreshold) {
      add_interleaved(set, begin, end, mapping);
    } else {
      for (uint32_t i = begin; i < end; ++i) set.add(mapping, PackedBox::of(refs_[i]));
    }
    return set;
  }

  // Neighbouring primitives often fall into the same bin, and each update then waits for the previous
  // one's store to reach its load; four sets used in turn break that chain (min, max and sums merge
  // exactly). Out of line, so that the extra sets (kMaxBins bins each) stay out of the stack frame of the
  // small nodes' path.
  [[gnu::noinline]] void add_interleaved(BinSet& set, uint32_t begin, uint32_t end,
                                         const BinMapping& mapping) const {
    BinSet second(mapping.bin_count), third(mapping.bin_count), fourth(mapping.bin_count);
    uint32_t i = begin;
    for (; i + 4 <= end; i += 4) {
      set.add(mapping, PackedBox::of(refs_[i]));
      second.add(mapping, PackedBox::of(refs_[i + 1]));
      third.add(mapping, PackedBox::of(refs_[i + 2]));
      fourth.add(mapping, PackedBox::of(refs_[i + 3]));
    }
    for (; i < end; ++i) set.add(mapping, PackedBox::of(refs_[i]));
    set.merge(second);
    set.merge(third);
    set.merge(fourth);
  }

  // Reduction body for tbb::parallel_reduce: each body bins into its own BinSet and joins merge them,
  // which avoids copying a whole BinSet (kMaxBins bins per axis) per chunk as the functional form does.
  struct BinBody {
    const SplitterImpl& splitter;
    const BinMapping& mapping;
    BinSet set;

    BinBody(const SplitterImpl& s, const BinMapping& m) : splitter(s), mapping(m), set(m.bin_count) {}
    BinBody(BinBody& other, tbb::split) : BinBody(other.splitter, other.mapping) {}
    void operator()(const tbb::blocked_range<uint32_t>& r) {
      set.merge(splitter.bin_serial(r.begin(), r.end(), mapping));
    }
    void join(const BinBody& other) { set.merge(other.set); }
  };

  BinSet bin(const NodeRange& range, const BinMapping& mapping) const {
    if (range.size() < kParallelThreshold) return bin_serial(range.begin, range.end, mapping);
    BinBody body(*this, mapping);
    tbb::parallel_reduce(tbb::blocked_range<uint32_t>(range.begin, range.end, kChunk), body);
    return body.set;
  }

  template <class Pred>
  Partition partition_serial(const NodeRange& range, Pred goes_left) {
    const SplitSides sides = partition_in_place(range.begin, range.end, goes_left);
    return {sides.left.range(range.begin, sides.mid), sides.right.range(sides.mid, range.end)};
  }

  struct SplitSides {
    uint32_t mid;  // where the right side starts
    SideBounds left, right;
  };

  // Branch-free Lomuto partition of [begin, end): [begin, mid) holds the left side and [mid, i) the right
  // side; primitive i is swapped to `mid`, which advances if it goes left (a right-side primitive swapped
  // with another keeps the invariant). Which side a primitive goes to is unpredictable, and a mispredicted
  // branch costs more than the unconditional swap. The sides' bounds are accumulated afterwards.
  template <class Pred>
  SplitSides partition_in_place(uint32_t begin, uint32_t end, Pred goes_left) {
    uint32_t mid = begin;
    for (uint32_t i = begin; i < end; ++i) {
      const bool left = goes_left(PackedBox::of(refs_[i]));
      std::swap(refs_[mid], refs_[i]);
      mid += left;
    }
    return {mid, bounds_of(begin, mid), bounds_of(mid, end)};
  }

  SideBounds bounds_of(uint32_t begin, uint32_t end) const {
    // Two accumulators, so that consecutive primitives do not wait for each other's min and max.
    SideBounds even, odd;
    uint32_t i = begin;
    for (; i + 1 < end; i += 2) {
      even.add(PackedBox::of(refs_[i]));
      odd.add(PackedBox::of(refs_[i + 1]));
    }
    if (i < end) even.add(PackedBox::of(refs_[i]));
    even.merge(odd);
    return even;
  }

  // In place in two parallel passes, without scratch memory (whose first touch costs a page fault per
  // 4 KiB): each fixed chunk is partitioned on its own, then the right-side primitives that lie before
  // the split point are swapped with the left-side ones after it, the k-th of one kind with the k-th of
  // the other. The chunking does not depend on the thread count, so neither does the order.
  template <class Pred>
  Partition partition_parallel(const NodeRange& range, Pred goes_left) {
    const uint32_t chunks = (range.size() + kChunk - 1) / kChunk;
    std::vector<SplitSides> parts(chunks);
    tbb::parallel_for(0u, chunks, [&](uint32_t c) {
      const uint32_t begin = range.begin + c * kChunk, end = std::min(range.end, begin + kChunk);
      parts[c] = partition_in_place(begin, end, goes_left);
    });
    SideBounds l, r;
    uint32_t mid = range.begin;
    for (uint32_t c = 0; c < chunks; ++c) {
      l.merge(parts[c].left);
      r.merge(parts[c].right);
      mid += parts[c].mid - (range.begin + c * kChunk);
    }
    swap_misplaced(range, parts, mid);
    return {l.range(range.begin, mid), r.range(mid, range.end)};
  }

  // After partition_parallel's first pass: chunk c holds left-side primitives in [its begin, parts[c].mid)
  // and right-side ones after. Swaps the right-side ones before `mid` with the left-side ones from `mid`
  // on; there are as many of each.
  void swap_misplaced(const NodeRange& range, const std::vector<SplitSides>& parts, uint32_t mid) {
    Runs before, after;  // right-side runs before mid, left-side runs from mid on, in position order
    for (uint32_t c = 0; c < parts.size(); ++c) {
      const uint32_t begin = range.begin + c * kChunk, end = std::min(range.end, begin + kChunk);
      before.add(parts[c].mid, std::min(end, mid));
      after.add(std::max(begin, mid), parts[c].mid);
    }
    const uint32_t misplaced = before.total();
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, misplaced, kChunk), [&](const auto& r) {
      Runs::Cursor a = before.at(r.begin()), b = after.at(r.begin());
      for (uint32_t k = r.begin(); k < r.end(); ++k) std::swap(refs_[before.next(a)], refs_[after.next(b)]);
    });
  }

  std::span<PrimRef> refs_;
  const BinnedSahParams& params_;
};

}  // namespace

Split BinnedSplitter::find_split(const NodeRange& range) const {
  return SplitterImpl(refs_, params_).find_split(range, nullptr);
}

Split BinnedSplitter::find_split(const NodeRange& range, SplitBounds& sides) const {
  return SplitterImpl(refs_, params_).find_split(range, &sides);
}

Partition BinnedSplitter::partition(const NodeRange& range, const Split& split) {
  return SplitterImpl(refs_, params_).partition(range, split);
}

Partition BinnedSplitter::partition_median(const NodeRange& range) {
  return SplitterImpl(refs_, params_).partition_median(range);
}

// PrimRefs and the root's bounds, in parallel; bounds merge exactly, so the result is deterministic.
NodeRange make_prim_refs(const BuildInput& input, std::span<PrimRef> refs) {
  const auto n = static_cast<uint32_t>(input.size());
  SideBounds all = tbb::parallel_reduce(
      tbb::blocked_range<uint32_t>(0, n, kChunk), SideBounds{},
      [&](const tbb::blocked_range<uint32_t>& r, SideBounds acc) {
        for (uint32_t i = r.begin(); i < r.end(); ++i) {
          std::construct_at(&refs[i], PrimRef{input.bounds[i], i, 0});
          acc.add(PackedBox::of(refs[i]));
        }
        return acc;
      },
      [](SideBounds a, const SideBounds& b) {
        a.merge(b);
        return a;
      });
  return all.range(0, n);
}

NodeRange bounds_of(std::span<const PrimRef> refs, uint32_t begin, uint32_t end) {
  SideBounds all;
  for (uint32_t i = begin; i < end; ++i) all.add(PackedBox::of(refs[i]));
  return all.range(begin, end);
}

uint32_t bins_for_node(const BinnedSahParams& params, uint32_t prim_count) {
  if (!params.adaptive_bins) return params.bins;
  return std::min(params.bins, kMinBins + prim_count / 20);
}

}  // namespace sahbench
