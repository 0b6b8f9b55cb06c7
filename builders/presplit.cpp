#include "builders/presplit.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "builders/binned_splitter.h"
#include "core/clip_polygon.h"
#include "core/error.h"

namespace sahbench {
namespace {

constexpr const char* kName = "presplit";
// Triangles per task in the per-triangle loops (the results do not depend on it).
constexpr std::size_t kChunk = 1u << 12;
// Finest level of the dyadic grid searched for a plane: a box narrower than 2^-32 of the scene on every
// axis is not cut (and its triangle gets no priority).
constexpr uint32_t kMaxLevel = 32;
constexpr uint32_t kNoPlane = ~0u;
// Clipped points carry the double rounding of a few crossing computations; their boxes are grown by
// 2^-40 of the triangle's largest coordinate before rounding outward to float (as the SBVH's are).
constexpr double kClipPad = 0x1p-40;
// Priorities in 32-bit fixed point, relative to the largest: their sums are exact integers, whatever the
// order of the sum.
constexpr double kPriorityScale = 0x1p32;

double half_area_in_double(const Aabb& b) {
  const double x = double(b.max.x) - b.min.x, y = double(b.max.y) - b.min.y, z = double(b.max.z) - b.min.z;
  return x * y + y * z + z * x;
}

// The dyadic grid over the scene's box: on each axis, the planes at lo + k E / 2^l for level l >= 1.
class DyadicGrid {
 public:
  explicit DyadicGrid(const Aabb& scene) {
    for (int a = 0; a < 3; ++a) lo_[a] = scene.min[a], extent_[a] = double(scene.max[a]) - scene.min[a];
  }

  struct Plane {
    uint32_t level = kNoPlane;
    int axis = 0;
    double position = 0.0;
  };

  // The coarsest plane strictly inside `box` on some axis; between axes of the same level, the one on
  // which the box is widest (then the lowest axis).
  Plane coarsest(const Aabb& box) const {
    Plane best;
    double best_width = -1.0;
    for (int a = 0; a < 3; ++a) {
      const double min = box.min[a], max = box.max[a];
      const Plane p = coarsest_on(a, min, max);
      if (p.level == kNoPlane) continue;
      if (p.level < best.level || (p.level == best.level && max - min > best_width))
        best = p, best_width = max - min;
    }
    return best;
  }

 private:
  // In fixed point over the scene's extent, with 2^kMaxLevel units, the planes of level l are the
  // multiples of 2^(kMaxLevel - l): the coarsest plane between two points is the multiple of the
  // largest power of two between them, found from the highest bit in which the two differ.
  Plane coarsest_on(int a, double min, double max) const {
    if (!(extent_[a] > 0.0) || !(max > min)) return {};
    constexpr double kUnits = 0x1p32;
    static_assert(kMaxLevel == 32);
    const double u0 = (min - lo_[a]) / extent_[a] * kUnits, u1 = (max - lo_[a]) / extent_[a] * kUnits;
    const auto first = static_cast<uint64_t>(std::max(0.0, std::floor(u0) + 1.0));         // above min
    const auto last = static_cast<uint64_t>(std::min(kUnits - 1.0, std::ceil(u1) - 1.0));  // below max
    if (!(u1 > 0.0) || first > last) return {};
    uint64_t m = first;
    if (first != last) {
      const uint64_t low = (uint64_t{1} << std::bit_width(first ^ last) >> 1) - 1;
      m = last & ~low;
      if (std::countr_zero(first) > std::countr_zero(m)) m = first;
    }
    const double position = lo_[a] + double(m) / kUnits * extent_[a];
    // Rounding may put the plane on min or max: then it does not cut the box.
    if (!(position > min && position < max)) return {};
    return {kMaxLevel - static_cast<uint32_t>(std::countr_zero(m)), a, position};
  }

  std::array<double, 3> lo_, extent_;
};

// Area of a planar convex polygon (a fan of triangles from its first vertex).
double polygon_area(const ClipPolygon& p) {
  double nx = 0.0, ny = 0.0, nz = 0.0;
  for (int i = 1; i + 1 < p.count; ++i) {
    const auto& o = p.v[0];
    const double ax = p.v[i][0] - o[0], ay = p.v[i][1] - o[1], az = p.v[i][2] - o[2];
    const double bx = p.v[i + 1][0] - o[0], by = p.v[i + 1][1] - o[1], bz = p.v[i + 1][2] - o[2];
    nx += ay * bz - az * by;
    ny += az * bx - ax * bz;
    nz += ax * by - ay * bx;
  }
  return 0.5 * std::sqrt(nx * nx + ny * ny + nz * nz);
}

// Floats below (above) x - pad (x + pad): the next float outward where rounding to nearest went inward.
float below(double x, double pad) {
  const double v = x - pad;
  const auto f = static_cast<float>(v);
  return double(f) > v ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}
float above(double x, double pad) {
  const double v = x + pad;
  const auto f = static_cast<float>(v);
  return double(f) < v ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

// A part of a triangle being split: the triangle clipped to it, its box, and the splits still its to make.
struct Piece {
  ClipPolygon polygon;
  Aabb box;
  uint32_t splits;
};

// The splitting of one triangle (Karras and Aila 2013, section 5).
class TriangleSplitter {
 public:
  TriangleSplitter(const Triangle& tri, const DyadicGrid& grid) : tri_(tri), grid_(grid) {
    const Vec3 e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
    const double nx = double(e1.y) * e2.z - double(e1.z) * e2.y;
    const double ny = double(e1.z) * e2.x - double(e1.x) * e2.z;
    const double nz = double(e1.x) * e2.y - double(e1.y) * e2.x;
    area_ = 0.5 * std::sqrt(nx * nx + ny * ny + nz * nz);
    // Infinitely fine pieces' boxes have, per axis, the triangle's projection as their face: half area
    // sum |n_a| / 2.
    ideal_ = 0.5 * (std::fabs(nx) + std::fabs(ny) + std::fabs(nz));
    pad_ = kClipPad * coordinate_scale(tri);
  }

  /// The priority of the triangle with box `box`: (2^-l waste)^(1/3), 0 where no grid plane cuts it.
  double priority(const Aabb& box) const {
    const DyadicGrid::Plane plane = grid_.coarsest(box);
    if (plane.level == kNoPlane) return 0.0;
    return std::cbrt(std::ldexp(waste(box, area_), -int(plane.level)));
  }

  /// Writes at most splits + 1 boxes of pieces that together cover the triangle to `out`; returns how
  /// many. A piece no grid plane cuts, or that a plane misses after rounding, is not split further, so
  /// there may be fewer. `stack` is working space.
  uint32_t split(const Aabb& box, uint32_t splits, Aabb* out, std::vector<Piece>& stack) const {
    // A triangle's pieces may be many: a stack, not recursion. Each split adds one entry, so with this
    // much room the references into it stay valid.
    stack.clear();
    stack.reserve(std::size_t{splits} + 2);
    stack.push_back({ClipPolygon::of(tri_), box, splits});
    uint32_t written = 0;
    while (!stack.empty()) {
      const DyadicGrid::Plane plane =
          stack.back().splits > 0 ? grid_.coarsest(stack.back().box) : DyadicGrid::Plane{};
      if (plane.level == kNoPlane) {
        out[written++] = stack.back().box;
        stack.pop_back();
        continue;
      }
      // The piece becomes its upper half in place, and a copy on top of it the lower half (taken first).
      stack.push_back(stack.back());
      Piece& high = stack[stack.size() - 2];
      Piece& low = stack.back();
      low.polygon.clip(plane.axis, plane.position, true);
      high.polygon.clip(plane.axis, plane.position, false);
      if (low.polygon.empty() || high.polygon.empty()) {
        out[written++] = high.box;
        stack.resize(stack.size() - 2);
        continue;
      }
      const Aabb whole = high.box;
      low.box = bounds(low.polygon, whole);
      high.box = bounds(high.polygon, whole);
      // The remaining splits go to the halves in proportion to the area their boxes waste.
      const uint32_t rest = high.splits - 1;
      const double w_low = waste(low.box, polygon_area(low.polygon));
      const double w_high = waste(high.box, polygon_area(high.polygon));
      const double share = w_low + w_high > 0.0 ? w_low / (w_low + w_high) : 0.5;
      low.splits = std::min(rest, static_cast<uint32_t>(std::floor(double(rest) * share + 0.5)));
      high.splits = rest - low.splits;
    }
    return written;
  }

 private:
  // Area of `box` above the ideal of a piece of the triangle of area `piece_area`.
  double waste(const Aabb& box, double piece_area) const {
    const double ideal = area_ > 0.0 ? ideal_ * (piece_area / area_) : 0.0;
    return std::max(0.0, half_area_in_double(box) - ideal);
  }

  // The box of a piece: its vertices, the triangle's own exact and the crossing points rounded
  // outward, within the box of the piece it was cut from.
  Aabb bounds(const ClipPolygon& p, const Aabb& parent) const {
    Aabb b;
    for (int i = 0; i < p.count; ++i) {
      const auto& v = p.v[i];
      if ((p.original >> i) & 1) {
        b.extend(Vec3{float(v[0]), float(v[1]), float(v[2])});
      } else {
        b.extend(Vec3{below(v[0], pad_), below(v[1], pad_), below(v[2], pad_)});
        b.extend(Vec3{above(v[0], pad_), above(v[1], pad_), above(v[2], pad_)});
      }
    }
    return {max(b.min, parent.min), min(b.max, parent.max)};
  }

  const Triangle& tri_;
  const DyadicGrid& grid_;
  double area_ = 0.0, ideal_ = 0.0, pad_ = 0.0;
};

// Fixed chunks of the triangles, for sums that must not depend on how a reduction splits them.
std::size_t chunk_count(std::size_t n) {
  return (n + kChunk - 1) / kChunk;
}

// Exclusive prefix sums of counts[i], chunk by chunk in parallel; returns the total.
uint64_t exclusive_scan(const std::vector<uint32_t>& counts, std::vector<uint64_t>& offsets) {
  const std::size_t n = counts.size(), chunks = chunk_count(n);
  offsets.resize(n);
  std::vector<uint64_t> chunk_base(chunks + 1, 0);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    uint64_t sum = 0;
    for (std::size_t i = c * kChunk; i < std::min(n, (c + 1) * kChunk); ++i) sum += counts[i];
    chunk_base[c + 1] = sum;
  });
  for (std::size_t c = 0; c < chunks; ++c) chunk_base[c + 1] += chunk_base[c];
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    uint64_t at = chunk_base[c];
    for (std::size_t i = c * kChunk; i < std::min(n, (c + 1) * kChunk); ++i) offsets[i] = at, at += counts[i];
  });
  return chunk_base[chunks];
}

// The references' bounds and centre bounds (min and max are exact in any order).
NodeRange root_range(std::span<const PrimRef> refs) {
  struct Both {
    Aabb bounds, centres;
  };
  const Both all = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, refs.size(), kChunk), Both{},
      [&](const tbb::blocked_range<std::size_t>& r, Both acc) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          acc.bounds.extend(refs[i].bounds);
          acc.centres.extend(refs[i].centroid());
        }
        return acc;
      },
      [](Both a, const Both& b) {
        a.bounds.extend(b.bounds);
        a.centres.extend(b.centres);
        return a;
      });
  return {0, static_cast<uint32_t>(refs.size()), all.bounds, all.centres};
}

// Pieces of one triangle that meet in a leaf need one reference there: drops the repeats, leaf by leaf
// in reference order (the tree's depth-first order), and closes the gaps.
void drop_repeats_in_leaves(Bvh& bvh) {
  // Leaves of more references than this are deduplicated by sorting, smaller ones by search.
  constexpr uint32_t kSearchLimit = 32;
  uint32_t* refs = bvh.prim_refs.data();
  uint32_t out = 0;
  std::vector<uint32_t> stack{0};
  while (!stack.empty()) {
    Node& node = bvh.nodes[stack.back()];
    stack.pop_back();
    if (!node.is_leaf()) {
      for (uint32_t c = node.child_count; c-- > 0;) stack.push_back(node.first + c);
      continue;
    }
    const uint32_t begin = out, first = node.first;
    if (node.prim_count <= kSearchLimit) {
      for (uint32_t r = first; r < first + node.prim_count; ++r)
        if (std::find(refs + begin, refs + out, refs[r]) == refs + out) refs[out++] = refs[r];
    } else {
      std::sort(refs + first, refs + first + node.prim_count);
      for (uint32_t r = first; r < first + node.prim_count; ++r)
        if (out == begin || refs[out - 1] != refs[r]) refs[out++] = refs[r];
    }
    node.first = begin;
    node.prim_count = static_cast<uint16_t>(out - begin);
  }
  bvh.prim_refs.resize(out);
}

}  // namespace

void check_presplit_params(const PresplitParams& params) {
  if (!(params.split_budget >= 0.0f && params.split_budget <= kPresplitMaxBudget))
    throw Error(std::string(kName) + ": split_budget = " + std::to_string(params.split_budget) +
                " is outside [0, " + std::to_string(kPresplitMaxBudget) + "]");
  if (params.binned.bins < kMinBins || params.binned.bins > kMaxBins)
    throw Error(std::string(kName) + ": bins = " + std::to_string(params.binned.bins) + " is outside [" +
                std::to_string(kMinBins) + ", " + std::to_string(kMaxBins) + "]");
  check_config(params.binned.top_down, kName);
}

Bvh build_presplit(const BuildInput& input, const PresplitParams& params) {
  check_presplit_params(params);
  const std::size_t n = input.size();
  if (input.triangles.size() != n)
    throw Error(std::string(kName) + ": needs the triangles in the BuildInput (" +
                std::to_string(input.triangles.size()) + " triangles for " + std::to_string(n) + " bounds)");
  const auto budget = static_cast<uint64_t>(std::floor(double(params.split_budget) * double(n)));
  check_prim_count(n + budget, kName);
  if (n == 0) return Bvh{};

  // Priorities, and each triangle's share of the budget.
  const Aabb scene = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, kChunk), Aabb{},
      [&](const tbb::blocked_range<std::size_t>& r, Aabb acc) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) acc.extend(input.bounds[i]);
        return acc;
      },
      [](Aabb a, const Aabb& b) { return merge(a, b); });
  const DyadicGrid grid(scene);
  std::vector<double> priority(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kChunk), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i)
      priority[i] = TriangleSplitter(input.triangles[i], grid).priority(input.bounds[i]);
  });
  const double top = *std::max_element(priority.begin(), priority.end());
  if (budget == 0 || !(top > 0.0)) {
    // Nothing to split: the binned SAH build itself.
    PrimRefArray refs(n);
    const NodeRange root = make_prim_refs(input, refs.span());
    BinnedSplitter splitter(refs.span(), params.binned);
    return build_top_down(splitter, params.binned.top_down, root);
  }
  std::vector<uint32_t> fixed(n);  // below 2^32, so that their sum fits 64 bits
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kChunk), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i)
      fixed[i] = static_cast<uint32_t>(
          std::min(kPriorityScale - 1.0, std::floor(priority[i] / top * kPriorityScale)));
  });
  // Triangle i gets the whole splits between budget * P_i / P and budget * P_(i+1) / P, with P_i the
  // priorities before i and P their total: shares within one of budget * p_i / P that add up to the
  // budget (less one at most), where rounding each share down would lose most of a small budget. The
  // rounding of the products is monotone, so no share is negative and their sum telescopes.
  std::vector<uint64_t> before;
  const uint64_t total = exclusive_scan(fixed, before);
  const double per_priority = double(budget) / double(total);
  auto splits_up_to = [&](uint64_t p) {
    return std::min(budget, static_cast<uint64_t>(std::floor(double(p) * per_priority)));
  };
  std::vector<uint32_t> splits(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kChunk), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i)
      splits[i] = static_cast<uint32_t>(splits_up_to(before[i] + fixed[i]) - splits_up_to(before[i]));
  });

  // Pieces: each triangle writes into the places reserved for splits + 1 of them, and the places a
  // triangle leaves unused are closed up afterwards.
  std::vector<uint32_t> reserved(n), written(n);
  for (std::size_t i = 0; i < n; ++i) reserved[i] = splits[i] + 1;
  std::vector<uint64_t> offset;
  const uint64_t capacity = exclusive_scan(reserved, offset);
  HugePageArray<Aabb> boxes(capacity);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kChunk), [&](const auto& r) {
    std::vector<Piece> stack;
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      if (splits[i] == 0) {
        boxes[offset[i]] = input.bounds[i];
        written[i] = 1;
      } else {
        written[i] = TriangleSplitter(input.triangles[i], grid)
                         .split(input.bounds[i], splits[i], &boxes[offset[i]], stack);
      }
    }
  });
  std::vector<uint64_t> position;
  const uint64_t count = exclusive_scan(written, position);
  PrimRefArray refs(count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kChunk), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i)
      for (uint32_t k = 0; k < written[i]; ++k)
        std::construct_at(&refs[position[i] + k], PrimRef{boxes[offset[i] + k], static_cast<uint32_t>(i), 0});
  });

  const NodeRange root = root_range(refs.span());
  BinnedSplitter splitter(refs.span(), params.binned);
  Bvh bvh = build_top_down(splitter, params.binned.top_down, root);
  drop_repeats_in_leaves(bvh);
  return bvh;
}

}  // namespace sahbench
