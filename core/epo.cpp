#include "core/epo.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/clip_polygon.h"
#include "core/error.h"

namespace sahbench {
namespace {

// Triangles per parallel block. The blocks' sums are added in block order, so the total does not depend
// on how TBB spreads them over threads; the size only trades scheduling overhead against balance.
constexpr std::size_t kBlockTriangles = 256;

// Area of a convex planar polygon: half the length of the sum of its fan's cross products, in double.
double polygon_area(const ClipPolygon::Point* v, int count) {
  double sx = 0.0, sy = 0.0, sz = 0.0;
  for (int i = 1; i + 1 < count; ++i) {
    const double ax = v[i][0] - v[0][0], ay = v[i][1] - v[0][1], az = v[i][2] - v[0][2];
    const double bx = v[i + 1][0] - v[0][0], by = v[i + 1][1] - v[0][1], bz = v[i + 1][2] - v[0][2];
    sx += ay * bz - az * by;
    sy += az * bx - ax * bz;
    sz += ax * by - ay * bx;
  }
  return 0.5 * std::sqrt(sx * sx + sy * sy + sz * sz);
}

double triangle_area(const Triangle& t) {
  const ClipPolygon::Point v[3] = {
      {t.v0.x, t.v0.y, t.v0.z}, {t.v1.x, t.v1.y, t.v1.z}, {t.v2.x, t.v2.y, t.v2.z}};
  return polygon_area(v, 3);
}

// Closed boxes: a triangle touching a box's face overlaps it.
bool overlaps(const Aabb& a, const Aabb& b) {
  return a.min.x <= b.max.x && b.min.x <= a.max.x && a.min.y <= b.max.y && b.min.y <= a.max.y &&
         a.min.z <= b.max.z && b.min.z <= a.max.z;
}

// The float box around double coordinates, rounded outward so that it holds every one of them.
float round_down(double x) {
  const auto f = static_cast<float>(x);
  return static_cast<double>(f) > x ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}
float round_up(double x) {
  const auto f = static_cast<float>(x);
  return static_cast<double>(f) < x ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

// Area of the part of `t` (bounds `tb`, area `full`) inside the closed box `box`: clipped only by the
// planes of the box that cut the triangle's bounds (Sutherland and Hodgman 1974, in ClipPolygon). `reach`
// becomes the bounds of that part, within `box`: the children of the box can hold no more of the
// triangle than their overlap with it.
double clipped_area(const Triangle& t, const Aabb& tb, double full, const Aabb& box, ClipPolygon& poly,
                    Aabb& reach) {
  if (box.contains(tb)) {
    reach = tb;
    return full;
  }
  poly.reset(t);
  for (int k = 0; k < 3; ++k) {
    const auto axis = static_cast<std::size_t>(k);
    if (tb.min[axis] < box.min[axis]) poly.clip(k, box.min[axis], /*keep_below=*/false);
    if (tb.max[axis] > box.max[axis]) poly.clip(k, box.max[axis], /*keep_below=*/true);
    if (poly.count < 3) return 0.0;
  }
  reach = Aabb::empty();
  for (int i = 0; i < poly.count; ++i)
    for (std::size_t k = 0; k < 3; ++k) {
      reach.min[k] = std::min(reach.min[k], round_down(poly.v[i][k]));
      reach.max[k] = std::max(reach.max[k], round_up(poly.v[i][k]));
    }
  reach = Aabb{max(reach.min, box.min), min(reach.max, box.max)};
  return polygon_area(poly.v.data(), poly.count);
}

// Where every node lies in a depth-first (pre-order) walk, and where its subtree's range ends, so that
// node m is in n's subtree when pre[n] <= pre[m] < end[n].
struct DepthFirstOrder {
  std::vector<uint32_t> pre, end;
};

DepthFirstOrder depth_first_order(const Bvh& bvh) {
  const std::size_t n = bvh.nodes.size();
  DepthFirstOrder out{std::vector<uint32_t>(n), std::vector<uint32_t>(n)};
  std::vector<uint32_t> order;  // node indices in pre-order
  order.reserve(n);
  std::vector<uint32_t> stack{0};
  while (!stack.empty()) {
    const uint32_t index = stack.back();
    stack.pop_back();
    out.pre[index] = static_cast<uint32_t>(order.size());
    order.push_back(index);
    const Node& node = bvh.nodes[index];
    if (node.is_leaf()) continue;
    // Children pushed last-first, so the first child is numbered next.
    for (uint32_t c = node.child_count; c-- > 0;) stack.push_back(node.first + c);
  }
  // Subtree sizes bottom-up: in reverse pre-order every child comes before its parent.
  std::vector<uint32_t> size(n, 1);
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    const Node& node = bvh.nodes[*it];
    if (!node.is_leaf())
      for (uint32_t c = 0; c < node.child_count; ++c) size[*it] += size[node.first + c];
    out.end[*it] = out.pre[*it] + size[*it];
  }
  return out;
}

// For each triangle, the pre-order positions of the leaves that reference it (compressed rows:
// positions[first[t] .. first[t + 1])). A spatial-split tree references a triangle from several leaves.
struct LeafPositions {
  std::vector<uint32_t> first, positions;
};

LeafPositions leaf_positions(const Bvh& bvh, const DepthFirstOrder& order, std::size_t triangles) {
  LeafPositions out;
  out.first.assign(triangles + 1, 0);
  for (const Node& node : bvh.nodes) {
    if (!node.is_leaf()) continue;
    for (uint32_t r = node.first; r < node.first + node.prim_count; ++r) {
      const uint32_t prim = bvh.prim_refs.at(r);
      if (prim >= triangles)
        throw Error("epo_cost: reference " + std::to_string(r) + " names triangle " + std::to_string(prim) +
                    " of " + std::to_string(triangles));
      ++out.first[prim + 1];
    }
  }
  for (std::size_t t = 0; t < triangles; ++t) out.first[t + 1] += out.first[t];
  out.positions.resize(out.first[triangles]);
  std::vector<uint32_t> next(out.first.begin(), out.first.end() - 1);
  for (std::size_t i = 0; i < bvh.nodes.size(); ++i) {
    const Node& node = bvh.nodes[i];
    if (!node.is_leaf()) continue;
    for (uint32_t r = node.first; r < node.first + node.prim_count; ++r)
      out.positions[next[bvh.prim_refs[r]]++] = order.pre[i];
  }
  return out;
}

// A node to visit, and the bounds of the part of the triangle that its parent holds.
struct Visit {
  uint32_t node;
  Aabb reach;
};

}  // namespace

double epo_cost(const Bvh& bvh, std::span<const Triangle> triangles, const SahCost& cost) {
  if (bvh.nodes.empty() || triangles.empty()) return 0.0;
  const DepthFirstOrder order = depth_first_order(bvh);
  const LeafPositions leaves = leaf_positions(bvh, order, triangles.size());

  // One triangle's share: the sum over the nodes outside its leaves' paths of C(n) * its area in n. Each
  // node on the stack comes with the bounds of the part of the triangle its parent holds.
  auto contribution = [&](std::size_t t, std::vector<Visit>& stack, ClipPolygon& poly) {
    const Triangle& tri = triangles[t];
    const double full = triangle_area(tri);
    if (!(full > 0.0)) return 0.0;
    const Aabb tb = tri.bounds();
    const uint32_t* own = leaves.positions.data() + leaves.first[t];
    const uint32_t own_count = leaves.first[t + 1] - leaves.first[t];
    double sum = 0.0;
    stack.assign(1, Visit{0u, tb});
    while (!stack.empty()) {
      auto [index, reach] = stack.back();
      stack.pop_back();
      const Node& node = bvh.nodes[index];
      if (!overlaps(node.bounds, reach)) continue;
      const uint32_t lo = order.pre[index], hi = order.end[index];
      const bool holds = std::any_of(own, own + own_count, [&](uint32_t p) { return lo <= p && p < hi; });
      if (!holds) {
        const double area = clipped_area(tri, tb, full, node.bounds, poly, reach);
        // The children's boxes lie inside this one: none of them holds any of the triangle either.
        if (!(area > 0.0)) continue;
        sum += area * (node.is_leaf() ? static_cast<double>(cost.leaf_cost(node.prim_count))
                                      : static_cast<double>(cost.c_trav));
      }
      if (!node.is_leaf())
        for (uint32_t c = node.child_count; c-- > 0;) stack.push_back({node.first + c, reach});
    }
    return sum;
  };

  const std::size_t blocks = (triangles.size() + kBlockTriangles - 1) / kBlockTriangles;
  std::vector<double> overlap(blocks, 0.0), area(blocks, 0.0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      std::vector<Visit> stack;
                      ClipPolygon poly;
                      for (std::size_t b = r.begin(); b != r.end(); ++b) {
                        const std::size_t end = std::min(triangles.size(), (b + 1) * kBlockTriangles);
                        for (std::size_t t = b * kBlockTriangles; t < end; ++t) {
                          overlap[b] += contribution(t, stack, poly);
                          area[b] += triangle_area(triangles[t]);
                        }
                      }
                    });
  double total_overlap = 0.0, total_area = 0.0;
  for (std::size_t b = 0; b < blocks; ++b) {
    total_overlap += overlap[b];
    total_area += area[b];
  }
  return total_area > 0.0 ? total_overlap / total_area : 0.0;
}

}  // namespace sahbench
