#include "builders/sbvh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "builders/binned_splitter.h"
#include "core/clip_polygon.h"
#include "core/error.h"
#include "core/simd.h"

namespace sahbench {
namespace {

constexpr const char* kName = "sbvh";
constexpr float kInf = std::numeric_limits<float>::infinity();
// Nodes with at least this many references clip and bin them in parallel, in fixed chunks. Boxes merge
// with min/max and counts are integer sums, so neither the threshold nor the chunking changes the result.
constexpr uint32_t kParallelThreshold = 1u << 14;
constexpr uint32_t kChunk = 1u << 10;
// Clipped points carry the double rounding of a few crossing computations, each a few 2^-53 of the
// triangle's largest coordinate. Bounds made from them are grown by 2^-40 of it before they are rounded
// outward to float: hundreds of times the error, and still 2^17 times below a float's resolution.
constexpr double kClipPad = 0x1p-40;
// Reference positions are uint32 and the recursion reserves 2 * capacity - 1 node slots.
constexpr uint64_t kMaxCapacity = (uint64_t{1} << 31) - 1;

uint32_t bins_for(uint32_t bins, bool adaptive, uint32_t refs) {
  return adaptive ? std::min(bins, kMinBins + refs / 20) : bins;
}

// ---------------------------------------------------------------------------------------------------
// Slabs: the spatial bins of a node

// The planes between one axis's slabs: plane j = lo + j * step for j = 1..count-1, with plane 0 = -inf
// and plane count = +inf, so that the outer slabs reach past the node. Rounding is monotone, so the
// planes never decrease with j; slabs between equal planes are empty.
class SlabGrid {
 public:
  SlabGrid(const Aabb& bounds, uint32_t count) : count_(count) {
    for (int a = 0; a < 3; ++a) {
      Axis& ax = axis_[a];
      const float extent = bounds.max[a] - bounds.min[a];
      const float step = extent / static_cast<float>(count);
      ax.lo = bounds.min[a];
      ax.scale = static_cast<float>(count) / extent;
      // No extent (nothing to separate), or one whose step underflows or whose scale overflows.
      ax.usable = extent > 0.0f && std::isfinite(extent) && step > 0.0f && std::isfinite(ax.scale);
      ax.plane[0] = -kInf;
      for (uint32_t j = 1; j < count; ++j) ax.plane[j] = ax.lo + static_cast<float>(j) * step;
      ax.plane[count] = kInf;
    }
  }

  uint32_t count() const { return count_; }
  bool usable(int a) const { return axis_[a].usable; }
  float plane(int a, uint32_t j) const { return axis_[a].plane[j]; }

  /// The slab whose lower plane is the last at or below x.
  uint32_t slab_from_below(int a, double x) const {
    const Axis& ax = axis_[a];
    uint32_t j = estimate(ax, x);
    while (j > 0 && ax.plane[j] > x) --j;
    while (j + 1 < count_ && ax.plane[j + 1] <= x) ++j;
    return j;
  }
  /// The slab whose upper plane is the first at or above x.
  uint32_t slab_from_above(int a, double x) const {
    const Axis& ax = axis_[a];
    uint32_t j = estimate(ax, x);
    while (j > 0 && ax.plane[j] >= x) --j;
    while (j + 1 < count_ && ax.plane[j + 1] < x) ++j;
    return j;
  }

 private:
  struct Axis {
    bool usable = false;
    float lo = 0.0f, scale = 0.0f;
    std::array<float, kMaxBins + 1> plane;
  };

  // A first guess for the searches, right or one off; NaN and values outside give an end slab.
  uint32_t estimate(const Axis& ax, double x) const {
    const float t = (static_cast<float>(x) - ax.lo) * ax.scale;
    return t >= 1.0f ? (t < static_cast<float>(count_) ? static_cast<uint32_t>(t) : count_ - 1) : 0;
  }

  uint32_t count_;
  std::array<Axis, 3> axis_;
};

using simd::Vec4d;
using simd::Vec4f;

// A box as two 4-lane vectors, x, y, z in lanes 0 to 2 (lane 3 is 0 for any box holding a point):
// clipping extends and clamps parts with one instruction for all three axes.
struct Box4 {
  Vec4f lo, hi;

  static Box4 empty() { return {simd::splat(kInf), simd::splat(-kInf)}; }
  static Box4 of(const Aabb& b) {
    return {simd::make4(b.min.x, b.min.y, b.min.z, 0.0f), simd::make4(b.max.x, b.max.y, b.max.z, 0.0f)};
  }
  // Operands in this order reproduce Aabb::extend (minps returns its second operand on ties and NaN).
  void extend(const Box4& b) {
    lo = simd::min(b.lo, lo);
    hi = simd::max(b.hi, hi);
  }
  void clamp(const Box4& b) {
    lo = simd::max(lo, b.lo);
    hi = simd::min(hi, b.hi);
  }
  bool is_empty() const { return (simd::mask_bits(simd::less(hi, lo)) & 0b111) != 0; }
  Aabb aabb() const {
    float l[4], h[4];
    simd::store4(l, lo);
    simd::store4(h, hi);
    return {{l[0], l[1], l[2]}, {h[0], h[1], h[2]}};
  }
};

// Outward rounding of computed coordinates x, each known to within `pad` of its exact value: floats at or
// below x - pad (at or above x + pad). Moving y by 2^-23 |y| (at least half a float ulp of y, which is at
// most 2^-24 |y| in the normal range) plus FLT_MIN (the subnormal range) before rounding to nearest lands
// on the far side of y; branch-free, and at most two ulps loose.
constexpr double kUlp = 0x1p-23;
constexpr double kSmallest = std::numeric_limits<float>::min();
inline Box4 outward(Vec4d lo, Vec4d hi, Vec4d pad) {
  const Vec4d step_ulp = simd::splat4d(kUlp), smallest = simd::splat4d(kSmallest);
  const Vec4d below = lo - pad, above = hi + pad;
  return {simd::to_float(below - (simd::abs(below) * step_ulp + smallest)),
          simd::to_float(above + (simd::abs(above) * step_ulp + smallest))};
}
inline Box4 outward(Vec4d x, Vec4d pad) {
  return outward(x, x, pad);
}

inline Vec4d to_vec4d(const ClipPolygon::Point& p) {
  return simd::make4d(p[0], p[1], p[2], 0.0);
}

// The parts of one reference's triangle: the triangle clipped to the reference's box (the box bounds
// the part the reference stands for), then cut by slab planes. The clipped polygon and its vertices'
// boxes are made on first use and kept for the other axes.
class RefClipper {
 public:
  RefClipper(const Triangle& tri, const Aabb& box) : tri_(tri), box_(box) {}

  /// Writes parts[j] for j = first..last: the box of the polygon's part in slab j on `axis`, clipped to
  /// the slab and to the reference's box, or an empty box. The part of a convex polygon in a slab is
  /// bounded by its vertices inside the slab and the points where its edges cross the slab's two planes.
  /// Exact up to the outward rounding of computed points.
  void slab_parts(const SlabGrid& grid, int axis, uint32_t first, uint32_t last, Box4* parts) {
    prepare();
    for (uint32_t j = first; j <= last; ++j) parts[j] = Box4::empty();
    if (polygon_.count == 3) {
      triangle_parts(grid, axis, first, last, parts);
    } else {
      polygon_parts(grid, axis, first, last, parts);
    }
    // Each part within the reference's box and its slab.
    const Box4 box = Box4::of(box_);
    const Vec4f on_axis = axis_mask(axis);
    for (uint32_t j = first; j <= last; ++j) {
      Box4 slab{simd::select(on_axis, simd::splat(-kInf), simd::splat(grid.plane(axis, j))),
                simd::select(on_axis, simd::splat(kInf), simd::splat(grid.plane(axis, j + 1)))};
      slab.clamp(box);
      Box4& part = parts[j];
      part.clamp(slab);
      if (part.is_empty()) part = Box4::empty();
    }
  }

 private:
  uint32_t slab_of(const SlabGrid& grid, int axis, uint32_t first, uint32_t last, double x) const {
    return std::clamp(grid.slab_from_below(axis, x), first, last);
  }

  // Adds vertex i to its slab, and to every slab below whose upper plane it lies on: where float
  // rounding made several planes equal, the slabs between them are empty and the vertex is a corner of
  // the part in the slab below all of them (it was left out of that part once, and the leaves of a
  // spatial split then missed a sliver of the triangle). Returns its slab.
  uint32_t add_vertex(const SlabGrid& grid, int axis, uint32_t first, uint32_t last, int i,
                      Box4* parts) const {
    const double x = polygon_.v[i][axis];
    const uint32_t s = slab_of(grid, axis, first, last, x);
    parts[s].extend(point_[i]);
    for (uint32_t below = s; below > first && grid.plane(axis, below) == x; --below)
      parts[below - 1].extend(point_[i]);
    return s;
  }

  // The crossing of the edge from `origin` with direction `slope` (per unit along `axis`) and plane p.
  static Vec4d crossing(Vec4d origin, Vec4d slope, double start, double p) {
    return origin + simd::splat4d(p - start) * slope;
  }

  // A triangle (or a part with three corners): with its corners sorted along the axis, every plane
  // strictly between the lowest and highest corner crosses the long edge and one of the two short ones
  // (the lower short edge below the middle corner, the upper one from it on; at the middle corner the
  // upper one gives the corner itself). Two crossings per plane, found without searching the edges.
  void triangle_parts(const SlabGrid& grid, int axis, uint32_t first, uint32_t last, Box4* parts) const {
    const auto& v = polygon_.v;
    // A sorting network of selects on the coordinates and indices in registers: which corner is lowest
    // is a coin flip to the branch predictor.
    int lo = 0, mid = 1, hi = 2;
    double x0 = v[0][axis], x1 = v[1][axis], x2 = v[2][axis];
    auto order = [](double& xa, int& a, double& xb, int& b) {
      const bool swap = xb < xa;
      const double low = swap ? xb : xa, high = swap ? xa : xb;
      const int low_index = swap ? b : a, high_index = swap ? a : b;
      xa = low, xb = high, a = low_index, b = high_index;
    };
    order(x0, lo, x1, mid);
    order(x1, mid, x2, hi);
    order(x0, lo, x1, mid);
    const uint32_t start = add_vertex(grid, axis, first, last, lo, parts);
    add_vertex(grid, axis, first, last, mid, parts);
    const uint32_t end = add_vertex(grid, axis, first, last, hi, parts);
    if (!(x0 < x2)) return;  // flat along the axis: its corners bound it
    uint32_t j = start + 1;
    const Vec4d p0 = vertex_[lo], p1 = vertex_[mid], p2 = vertex_[hi];
    const Vec4d long_slope = (p2 - p0) * simd::splat4d(1.0 / (x2 - x0));
    const Vec4d low_slope = x1 > x0 ? (p1 - p0) * simd::splat4d(1.0 / (x1 - x0)) : simd::splat4d(0.0);
    const Vec4d high_slope = x2 > x1 ? (p2 - p1) * simd::splat4d(1.0 / (x2 - x1)) : simd::splat4d(0.0);
    const Vec4d pad = simd::splat4d(pad_);
    for (; j <= end; ++j) {
      const double p = grid.plane(axis, j);
      if (!(p < x2)) break;
      // Both crossings bounded in double and rounded outward once.
      const Vec4d a = crossing(p0, long_slope, x0, p);
      const Vec4d b = p < x1 ? crossing(p0, low_slope, x0, p) : crossing(p1, high_slope, x1, p);
      const Box4 c = outward(simd::min(a, b), simd::max(a, b), pad);
      parts[j - 1].extend(c);
      parts[j].extend(c);
    }
  }

  // Any convex polygon: every edge's crossings with the planes strictly inside its extent.
  void polygon_parts(const SlabGrid& grid, int axis, uint32_t first, uint32_t last, Box4* parts) const {
    const ClipPolygon& p = polygon_;
    for (int i = 0; i < p.count; ++i) add_vertex(grid, axis, first, last, i, parts);
    for (int i = 0; i < p.count; ++i) {
      const int next = i + 1 == p.count ? 0 : i + 1;
      const double xa = p.v[i][axis], xb = p.v[next][axis];
      if (xa == xb) continue;
      const double lo = std::min(xa, xb), hi = std::max(xa, xb);
      uint32_t j = slab_of(grid, axis, first, last, lo) + 1;
      const uint32_t end = slab_of(grid, axis, first, last, hi);
      if (j > end) continue;
      const Vec4d slope = (vertex_[next] - vertex_[i]) * simd::splat4d(1.0 / (xb - xa));
      for (; j <= end; ++j) {
        const double plane = grid.plane(axis, j);
        if (!(plane < hi)) break;
        const Box4 c = outward(crossing(vertex_[i], slope, xa, plane), simd::splat4d(pad_));
        parts[j - 1].extend(c);
        parts[j].extend(c);
      }
    }
  }

  // All bits set in lane `axis`.
  static Vec4f axis_mask(int axis) {
    const float set = std::bit_cast<float>(~0u);
    return simd::make4(axis == 0 ? set : 0.0f, axis == 1 ? set : 0.0f, axis == 2 ? set : 0.0f, 0.0f);
  }

  void prepare() {
    if (prepared_) return;
    prepared_ = true;
    polygon_.reset(tri_);
    const Aabb tb = tri_.bounds();
    for (int a = 0; a < 3; ++a) {
      if (tb.min[a] < box_.min[a]) polygon_.clip(a, box_.min[a], false);
      if (tb.max[a] > box_.max[a]) polygon_.clip(a, box_.max[a], true);
    }
    // The box bounds a part of the triangle, so the clipped polygon is never empty; should rounding
    // ever make it so, the triangle itself is a valid (looser) stand-in.
    if (polygon_.count == 0) polygon_.reset(tri_);
    pad_ = kClipPad * coordinate_scale(tri_);
    const Vec4d pad = simd::splat4d(pad_);
    for (int i = 0; i < polygon_.count; ++i) {
      const auto& v = polygon_.v[i];
      vertex_[i] = to_vec4d(v);
      // The triangle's own vertices are floats, exact; the others are crossing points.
      if ((polygon_.original >> i) & 1) {
        const Vec4f exact = simd::make4(float(v[0]), float(v[1]), float(v[2]), 0.0f);
        point_[i] = {exact, exact};
      } else {
        point_[i] = outward(vertex_[i], pad);
      }
    }
  }

  const Triangle& tri_;
  const Aabb& box_;
  bool prepared_ = false;
  ClipPolygon polygon_;
  double pad_ = 0.0;
  std::array<Vec4d, ClipPolygon::kMaxVertices> vertex_;  // the polygon's vertices
  std::array<Box4, ClipPolygon::kMaxVertices> point_;    // their boxes
};

// Where a reference lies on one axis's slabs: slabs first..last. `clipped`: it spans several slabs and
// parts[first..last] hold its clipped parts (some may be empty); otherwise its whole box is in `first`.
struct SlabRange {
  uint32_t first, last;
  uint32_t clipped;  // a bool, widened: the struct is returned in registers, without a partial write
};

// The one classification that binning and partitioning share, so that the counts and boxes the sweep
// evaluates are exactly those the partition produces. A reference spanning several slabs by its box is
// narrowed to the slabs its clipped parts reach.
[[gnu::noinline]] SlabRange clipped_range(const SlabGrid& grid, int axis, uint32_t first, uint32_t last,
                                          RefClipper& clipper, Box4* parts) {
  clipper.slab_parts(grid, axis, first, last, parts);
  uint32_t f = first, l = last;
  while (f <= last && parts[f].is_empty()) ++f;
  if (f > last) return {first, first, false};
  while (parts[l].is_empty()) --l;
  return {f, l, true};
}

inline SlabRange slab_range(const SlabGrid& grid, int axis, const Aabb& box, RefClipper& clipper,
                            Box4* parts) {
  const uint32_t first = grid.slab_from_below(axis, box.min[axis]);
  const uint32_t last = grid.slab_from_above(axis, box.max[axis]);
  // last < first: a box flat on a plane, held by the slab above it.
  if (last <= first) return {first, first, false};
  return clipped_range(grid, axis, first, last, clipper, parts);
}

Aabb union_of(const Box4* parts, uint32_t first, uint32_t last) {
  Box4 box = Box4::empty();
  for (uint32_t j = first; j <= last; ++j) box.extend(parts[j]);
  return box.aabb();
}

struct SlabBin {
  Box4 bounds;
  uint32_t enter;  // references whose first slab this is
  uint32_t exit;   // references whose last slab this is
};

// The slab bins of all three axes; only the first `count` per axis are used (and reset).
struct SlabBins {
  uint32_t count;
  SlabBin bin[3][kMaxBins];

  explicit SlabBins(uint32_t c) : count(c) {
    for (auto& axis : bin) std::fill_n(axis, c, SlabBin{Box4::empty(), 0, 0});
  }
  void merge(const SlabBins& o) {
    for (int a = 0; a < 3; ++a)
      for (uint32_t j = 0; j < count; ++j) {
        bin[a][j].bounds.extend(o.bin[a][j].bounds);
        bin[a][j].enter += o.bin[a][j].enter;
        bin[a][j].exit += o.bin[a][j].exit;
      }
  }
};

// ---------------------------------------------------------------------------------------------------
// The splitter

enum class Side : uint8_t { kLeft, kRight, kBoth };

/// What find_split proposes: the object split, or a spatial split at plane `plane` of axis `axis` with
/// the boxes and counts of its children as the sweep saw them (unsplitting weighs references by them).
struct SbvhSplit {
  float cost = kInf;
  bool spatial = false;
  Split object;
  uint32_t axis = 0, plane = 0;
  Aabb left, right;
  uint32_t left_count = 0, right_count = 0;

  bool valid() const { return cost < kInf; }
};

class SbvhSplitter {
 public:
  SbvhSplitter(std::span<PrimRef> refs, std::span<const Triangle> triangles, const SbvhParams& params,
               float root_area)
      : refs_(refs),
        triangles_(triangles),
        params_(params),
        object_params_{params.bins, params.adaptive_bins, params.top_down},
        object_(refs, object_params_),
        min_overlap_(params.alpha * root_area) {}

  SbvhSplit find_split(const NodeRange& range) const {
    SbvhSplit best;
    const float parent_area = range.bounds.half_area();
    if (!(parent_area > 0.0f)) return best;
    SplitBounds sides;
    best.object = object_.find_split(range, sides);
    if (best.object.valid()) best.cost = best.object.cost;
    if (range.spare > 0 && worth_spatial(best.object, sides, parent_area)) {
      const SbvhSplit spatial = find_spatial_split(range, parent_area);
      if (spatial.cost < best.cost) best = spatial;
    }
    return best;
  }

  Partition partition(const NodeRange& range, const SbvhSplit& split) {
    if (split.spatial) return partition_spatial(range, split);
    return place(range, object_.partition(range, split.object));
  }

  Partition partition_median(const NodeRange& range) { return place(range, object_.partition_median(range)); }

  uint32_t prim_id(uint32_t position) const { return refs_[position].id; }

 private:
  // Section 4.3: spatial splits pay off where object splits leave children that overlap; the overlap is
  // measured against the root, so that small nodes deep in the tree are left to object splits. Embree
  // also asks for an overlap that is a share of the node itself (node_overlap). Where no object split
  // exists (all centres equal) the children would coincide with the node.
  bool worth_spatial(const Split& object, const SplitBounds& sides, float parent_area) const {
    float overlap = parent_area;
    if (object.valid()) {
      const Aabb both{max(sides.left.min, sides.right.min), min(sides.left.max, sides.right.max)};
      overlap = both.half_area();
    }
    return overlap > min_overlap_ && overlap >= params_.node_overlap * parent_area;
  }

  uint32_t slab_count(uint32_t refs) const {
    return bins_for(params_.spatial_bins, params_.adaptive_bins, refs);
  }

  void bin_refs(const SlabGrid& grid, uint32_t begin, uint32_t end, SlabBins& bins) const {
    std::array<Box4, kMaxBins> parts;
    for (uint32_t i = begin; i < end; ++i) {
      const PrimRef& ref = refs_[i];
      RefClipper clipper(triangles_[ref.id], ref.bounds);
      for (int a = 0; a < 3; ++a) {
        if (!grid.usable(a)) continue;
        const SlabRange r = slab_range(grid, a, ref.bounds, clipper, parts.data());
        SlabBin* axis = bins.bin[a];
        if (r.clipped) {
          for (uint32_t j = r.first; j <= r.last; ++j) axis[j].bounds.extend(parts[j]);
        } else {
          axis[r.first].bounds.extend(Box4::of(ref.bounds));
        }
        ++axis[r.first].enter;
        ++axis[r.last].exit;
      }
    }
  }

  struct BinBody {
    const SbvhSplitter& splitter;
    const SlabGrid& grid;
    SlabBins bins;

    BinBody(const SbvhSplitter& s, const SlabGrid& g) : splitter(s), grid(g), bins(g.count()) {}
    BinBody(BinBody& other, tbb::split) : BinBody(other.splitter, other.grid) {}
    void operator()(const tbb::blocked_range<uint32_t>& r) {
      splitter.bin_refs(grid, r.begin(), r.end(), bins);
    }
    void join(const BinBody& other) { bins.merge(other.bins); }
  };

  // Section 4.2: the SAH over the planes between slabs, each reference counted in the slab where its
  // parts begin (left of every later plane) and the one where they end (right of every earlier plane),
  // and each slab bounded by the parts that fall into it. Planes that would duplicate more references
  // than the node has spare positions are not candidates.
  SbvhSplit find_spatial_split(const NodeRange& range, float parent_area) const {
    const SlabGrid grid(range.bounds, slab_count(range.size()));
    // On the heap: the bins of three axes are tens of kilobytes.
    const auto body = std::make_unique<BinBody>(*this, grid);
    if (range.size() >= kParallelThreshold) {
      tbb::parallel_reduce(tbb::blocked_range<uint32_t>(range.begin, range.end, kChunk), *body);
    } else {
      bin_refs(grid, range.begin, range.end, body->bins);
    }
    const SlabBins& bins = body->bins;
    const uint32_t count = grid.count(), n = range.size();

    SbvhSplit best;
    best.spatial = true;
    float best_weighted = kInf;
    std::array<Box4, kMaxBins> right_box;
    std::array<float, kMaxBins> right_area;
    std::array<uint32_t, kMaxBins> right_count;
    const SahCost& cost = params_.top_down.cost;
    for (int a = 0; a < 3; ++a) {
      if (!grid.usable(a)) continue;
      const SlabBin* axis = bins.bin[a];
      Box4 box = Box4::empty();
      uint32_t refs = 0;
      for (uint32_t j = count; j-- > 1;) {
        box.extend(axis[j].bounds);
        refs += axis[j].exit;
        right_box[j] = box;
        right_area[j] = box.aabb().half_area();
        right_count[j] = refs;
      }
      Box4 left = Box4::empty();
      uint32_t left_count = 0;
      for (uint32_t j = 1; j < count; ++j) {
        left.extend(axis[j - 1].bounds);
        left_count += axis[j - 1].enter;
        const uint32_t rc = right_count[j];
        // Every reference is counted on at least one side, so the duplicates are left + right - n.
        if (left_count == 0 || rc == 0 || uint64_t{left_count} + rc - n > range.spare) continue;
        // Counted in leaf blocks (SahCost::block), as the object splits are, so that a source for the wide
        // collapse fills its blocks.
        const float weighted = left.aabb().half_area() * static_cast<float>(cost.blocks(left_count)) +
                               right_area[j] * static_cast<float>(cost.blocks(rc));
        if (weighted < best_weighted) {
          best_weighted = weighted;
          best.axis = static_cast<uint32_t>(a);
          best.plane = j;
          best.left = left.aabb();
          best.right = right_box[j].aabb();
          best.left_count = left_count;
          best.right_count = rc;
        }
      }
    }
    if (best_weighted < kInf)
      best.cost = params_.top_down.cost.split_cost_from_weighted(parent_area, best_weighted);
    return best;
  }

  // The side of one reference for a spatial split, and the boxes it takes there.
  struct Placement {
    Side side;
    Aabb left, right;
  };

  // `parts` is scratch space for kMaxBins boxes.
  Placement place_ref(const SlabGrid& grid, const SbvhSplit& split, const PrimRef& ref, Box4* parts) const {
    RefClipper clipper(triangles_[ref.id], ref.bounds);
    const auto axis = static_cast<int>(split.axis);
    const SlabRange r = slab_range(grid, axis, ref.bounds, clipper, parts);
    const Aabb whole = r.clipped ? union_of(parts, r.first, r.last) : ref.bounds;
    if (r.last < split.plane) return {Side::kLeft, whole, {}};
    if (r.first >= split.plane) return {Side::kRight, {}, whole};
    return {Side::kBoth, union_of(parts, r.first, split.plane - 1), union_of(parts, split.plane, r.last)};
  }

  // Section 4.4: a reference the plane cuts may instead go whole to one side, where that costs less than
  // the split with the children's boxes and counts fixed at the sweep's. Decided in reference order, and
  // never leaving a side empty.
  void unsplit(const SbvhSplit& split, std::vector<Placement>& placed) const {
    const float left_area = split.left.half_area(), right_area = split.right.half_area();
    const auto nl = static_cast<float>(split.left_count), nr = static_cast<float>(split.right_count);
    const float split_cost = left_area * nl + right_area * nr;
    uint32_t left_refs = split.left_count, right_refs = split.right_count;
    for (Placement& p : placed) {
      if (p.side != Side::kBoth) continue;
      const Aabb whole = merge(p.left, p.right);
      const float to_left = merge(split.left, whole).half_area() * nl + right_area * (nr - 1.0f);
      const float to_right = left_area * (nl - 1.0f) + merge(split.right, whole).half_area() * nr;
      if (to_left < split_cost && to_left <= to_right && right_refs > 1) {
        p = {Side::kLeft, whole, {}};
        --right_refs;
      } else if (to_right < split_cost && left_refs > 1) {
        p = {Side::kRight, {}, whole};
        --left_refs;
      }
    }
  }

  Partition partition_spatial(const NodeRange& range, const SbvhSplit& split) {
    const SlabGrid grid(range.bounds, slab_count(range.size()));
    const uint32_t n = range.size();
    std::vector<Placement> placed(n);
    auto classify = [&](uint32_t begin, uint32_t end) {
      std::array<Box4, kMaxBins> parts;
      for (uint32_t i = begin; i < end; ++i)
        placed[i] = place_ref(grid, split, refs_[range.begin + i], parts.data());
    };
    if (n >= kParallelThreshold) {
      tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, kChunk),
                        [&](const auto& r) { classify(r.begin(), r.end()); });
    } else {
      classify(0, n);
    }
    if (params_.unsplit) unsplit(split, placed);

    uint32_t left_count = 0, right_count = 0;
    for (const Placement& p : placed) {
      left_count += p.side != Side::kRight;
      right_count += p.side != Side::kLeft;
    }
    const uint32_t duplicates = left_count + right_count - n;
    if (duplicates > range.spare || left_count == 0 || right_count == 0)
      throw Error(std::string(kName) + ": internal error: a spatial split of " + std::to_string(n) +
                  " references gave " + std::to_string(left_count) + " + " + std::to_string(right_count) +
                  " with " + std::to_string(range.spare) + " spare");
    const auto [left_spare, right_spare] = share_spare(range.spare - duplicates, left_count, right_count);

    // Written from a copy: the right side's new positions overlap the node's old ones.
    const std::vector<PrimRef> old(refs_.begin() + range.begin, refs_.begin() + range.end);
    uint32_t l = range.begin, r = range.begin + left_count + left_spare;
    Aabb left_bounds, right_bounds, left_centroids, right_centroids;
    for (uint32_t i = 0; i < n; ++i) {
      const Placement& p = placed[i];
      if (p.side != Side::kRight) {
        std::construct_at(&refs_[l++], PrimRef{p.left, old[i].id, 0});
        left_bounds.extend(p.left);
        left_centroids.extend(p.left.center());
      }
      if (p.side != Side::kLeft) {
        std::construct_at(&refs_[r++], PrimRef{p.right, old[i].id, 0});
        right_bounds.extend(p.right);
        right_centroids.extend(p.right.center());
      }
    }
    const uint32_t right_begin = range.begin + left_count + left_spare;
    return {{range.begin, range.begin + left_count, left_bounds, left_centroids, left_spare},
            {right_begin, right_begin + right_count, right_bounds, right_centroids, right_spare}};
  }

  // Spare positions go to the children in proportion to their references (Embree's rule for its
  // extended ranges): deterministic, and each child gets its share of the budget.
  static std::pair<uint32_t, uint32_t> share_spare(uint32_t spare, uint32_t left, uint32_t right) {
    const auto to_left = static_cast<uint32_t>(uint64_t{spare} * left / (uint64_t{left} + right));
    return {to_left, spare - to_left};
  }

  // Moves an in-place partition's right side behind the left side's share of the spare positions.
  Partition place(const NodeRange& range, Partition halves) {
    const auto [left_spare, right_spare] = share_spare(range.spare, halves.left.size(), halves.right.size());
    const uint32_t right_begin = halves.left.end + left_spare;
    if (right_begin != halves.right.begin)
      std::memmove(static_cast<void*>(refs_.data() + right_begin), refs_.data() + halves.right.begin,
                   std::size_t{halves.right.size()} * sizeof(PrimRef));
    halves.left.spare = left_spare;
    halves.right.end = right_begin + halves.right.size();
    halves.right.begin = right_begin;
    halves.right.spare = right_spare;
    return halves;
  }

  std::span<PrimRef> refs_;
  std::span<const Triangle> triangles_;
  const SbvhParams& params_;
  BinnedSahParams object_params_;
  BinnedSplitter object_;
  float min_overlap_;
};

}  // namespace

void check_sbvh_params(const SbvhParams& params, std::string_view builder) {
  const std::string name(builder);
  auto check_bins = [&](const char* key, uint32_t bins) {
    if (bins < kMinBins || bins > kMaxBins)
      throw Error(name + ": " + key + " = " + std::to_string(bins) + " is outside [" +
                  std::to_string(kMinBins) + ", " + std::to_string(kMaxBins) + "]");
  };
  check_bins("bins", params.bins);
  check_bins("spatial_bins", params.spatial_bins);
  if (!(params.alpha >= 0.0f && params.alpha <= 1.0f))
    throw Error(name + ": alpha = " + std::to_string(params.alpha) + " is outside [0, 1]");
  if (!(params.node_overlap >= 0.0f && params.node_overlap <= 1.0f))
    throw Error(name + ": node_overlap = " + std::to_string(params.node_overlap) + " is outside [0, 1]");
  if (!(params.max_dup >= 0.0f && params.max_dup <= kSbvhMaxDup))
    throw Error(name + ": max_dup = " + std::to_string(params.max_dup) + " is outside [0, " +
                std::to_string(kSbvhMaxDup) + "]");
  check_config(params.top_down, builder);
}

Bvh build_sbvh(const BuildInput& input, const SbvhParams& params, std::string_view builder) {
  check_sbvh_params(params, builder);
  check_prim_count(input.size(), builder);
  const std::string name(builder);
  const std::size_t n = input.size();
  if (input.triangles.size() != n)
    throw Error(name + ": needs the triangles in the BuildInput (" + std::to_string(input.triangles.size()) +
                " triangles for " + std::to_string(n) + " bounds)");
  if (n == 0) return Bvh{};
  const auto spare = static_cast<uint64_t>(std::floor(double(params.max_dup) * double(n)));
  if (n + spare > kMaxCapacity)
    throw Error(name + ": " + std::to_string(n) +
                " primitives with max_dup = " + std::to_string(params.max_dup) + " exceed the limit of " +
                std::to_string(kMaxCapacity) + " references");
  PrimRefArray refs(n + spare);
  NodeRange root = make_prim_refs(input, refs.span().first(n));
  root.spare = static_cast<uint32_t>(spare);
  SbvhSplitter splitter(refs.span(), input.triangles, params, root.bounds.half_area());
  return build_top_down(splitter, params.top_down, root);
}

}  // namespace sahbench
