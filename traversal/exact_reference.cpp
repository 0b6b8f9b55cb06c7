#include "traversal/exact_reference.h"

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <optional>

namespace sahbench {
namespace {

using Kernel = CGAL::Exact_predicates_exact_constructions_kernel;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
using Number = Kernel::FT;

// Relative widening of every slab distance in the bounding-box cull. The distances are computed in
// double from float inputs with three roundings (subtraction, reciprocal, product), each of relative
// error at most 2^-53 (no double overflows or underflows from float operands), so a margin of 1e-9
// makes the cull conservative with room to spare; it only lets a few more triangles reach the exact test.
constexpr double kCullMargin = 1e-9;

Point to_point(Vec3 p) {
  return {p.x, p.y, p.z};
}

// A triangle's bounds in double, as min x y z, max x y z.
using Box = std::array<double, 6>;

Box box_of(const Triangle& t) {
  const Aabb b = t.bounds();
  return {b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z};
}

// The slab test in double, widened by kCullMargin: never rejects a box the exact segment meets. A zero
// direction component gives an infinite reciprocal; the NaN of 0 * inf (origin on the slab's plane)
// leaves the interval unchanged, like traversal/ray_box.h, and an infinite distance is not widened.
class ConservativeCull {
 public:
  explicit ConservativeCull(const Ray& ray) : tmin_(ray.tmin), tmax_(far_limit(ray)) {
    for (int axis = 0; axis < 3; ++axis) {
      org_[axis] = ray.org[static_cast<std::size_t>(axis)];
      inv_[axis] = 1.0 / static_cast<double>(ray.dir[static_cast<std::size_t>(axis)]);
    }
  }

  bool may_hit(const Box& box) const {
    double lo = tmin_, hi = tmax_;
    for (int axis = 0; axis < 3; ++axis) {
      // The near plane by the sign bit, so that -0 counts as negative (a swap on t0 > t1 would not
      // happen when one of the two is NaN).
      const bool negative = std::signbit(inv_[axis]);
      double t0 = (box[negative ? axis + 3 : axis] - org_[axis]) * inv_[axis];
      double t1 = (box[negative ? axis : axis + 3] - org_[axis]) * inv_[axis];
      if (std::isfinite(t0)) t0 -= std::abs(t0) * kCullMargin;
      if (std::isfinite(t1)) t1 += std::abs(t1) * kCullMargin;
      if (t0 > lo) lo = t0;
      if (t1 < hi) hi = t1;
    }
    return lo <= hi;
  }

 private:
  double org_[3], inv_[3];
  double tmin_, tmax_;
};

// The nearest float to `t` (ties to even), or +-inf beyond the float range. The exact value's double
// conversion is within one double ulp, so the nearest float is the float conversion of that double
// or one of its neighbours; the three are compared exactly.
float round_to_float(const Number& t) {
  const float guess = static_cast<float>(CGAL::to_double(t.exact()));
  if (!std::isfinite(guess)) return guess;
  float best = guess;
  Number best_error = CGAL::abs(Number(guess) - t);
  for (const float candidate : {std::nextafter(guess, -INFINITY), std::nextafter(guess, INFINITY)}) {
    if (!std::isfinite(candidate)) continue;
    const Number error = CGAL::abs(Number(candidate) - t);
    const CGAL::Comparison_result c = CGAL::compare(error, best_error);
    const bool even = (std::bit_cast<uint32_t>(candidate) & 1u) == 0;
    if (c == CGAL::SMALLER || (c == CGAL::EQUAL && even)) {
      best = candidate;
      best_error = error;
    }
  }
  return best;
}

// The exact crossing of the line org + t dir with triangle (a, b, c). With q = org + dir, the three
// orientations of (org, q, edge) are the signed volumes det(a - org, b - org, dir) and so on, whose sum
// is dir . n for the normal n = (b - a) x (c - a). The line crosses the closed triangle at a single
// point exactly when no two of them have opposite signs and not all are zero (then dir . n, their sum,
// is not zero: the line is not in the plane and the triangle has area). Only then is the distance
// n . (a - org) / n . dir constructed.
std::optional<Number> line_crossing(const Point& org, const Point& q, const Vector& dir, const Point& a,
                                    const Point& b, const Point& c) {
  const int s0 = CGAL::orientation(org, q, a, b);
  const int s1 = CGAL::orientation(org, q, b, c);
  if (s0 * s1 < 0) return std::nullopt;
  const int s2 = CGAL::orientation(org, q, c, a);
  if (s0 * s2 < 0 || s1 * s2 < 0) return std::nullopt;
  if (s0 == 0 && s1 == 0 && s2 == 0) return std::nullopt;
  const Vector n = CGAL::cross_product(b - a, c - a);
  return (n * (a - org)) / (n * dir);
}

bool is_finite_ray(const Ray& ray) {
  return is_finite(ray.org) && is_finite(ray.dir) && ray.dir != Vec3{0.0f};
}

}  // namespace

bool ExactHit::accepts(uint32_t prim) const {
  return std::binary_search(tied.begin(), tied.end(), prim);
}

struct ExactReference::Impl {
  std::span<const Triangle> triangles;
  // Distinct triangles: their bounds, exact vertices, and the primitives that share them.
  std::vector<Box> boxes;
  std::vector<std::array<Point, 3>> vertices;
  std::vector<uint32_t> member_begin;  // size + 1 offsets into members
  std::vector<uint32_t> members;       // ascending within each distinct triangle
};

ExactReference::ExactReference(std::span<const Triangle> triangles) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.triangles = triangles;
  // Group bitwise-identical triangles: sort indices by their 36 bytes, index breaking ties.
  using Key = std::array<uint32_t, 9>;
  auto key = [&](uint32_t i) { return std::bit_cast<Key>(triangles[i]); };
  std::vector<uint32_t> order(triangles.size());
  for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const Key ka = key(a), kb = key(b);
    return ka != kb ? ka < kb : a < b;
  });
  for (std::size_t i = 0; i < order.size(); ++i) {
    if (i == 0 || key(order[i]) != key(order[i - 1])) {
      const Triangle& t = triangles[order[i]];
      m.member_begin.push_back(static_cast<uint32_t>(m.members.size()));
      m.boxes.push_back(box_of(t));
      m.vertices.push_back({to_point(t.v0), to_point(t.v1), to_point(t.v2)});
    }
    m.members.push_back(order[i]);
  }
  m.member_begin.push_back(static_cast<uint32_t>(m.members.size()));
}

ExactReference::~ExactReference() = default;

std::size_t ExactReference::unique_triangles() const {
  return impl_->boxes.size();
}

ExactHit ExactReference::closest(const Ray& ray) const {
  const Impl& m = *impl_;
  ExactHit hit;
  if (!is_finite_ray(ray) || std::isnan(ray.tmin) || std::isnan(ray.tmax) || ray.tmin > ray.tmax) return hit;
  const ConservativeCull cull(ray);
  const Point org = to_point(ray.org);
  const Vector dir(ray.dir.x, ray.dir.y, ray.dir.z);
  const Point q = org + dir;
  // tmax at most the largest float (far_limit): a crossing beyond it has no float t.
  const bool has_min = std::isfinite(ray.tmin), has_max = true;
  const Number tmin(has_min ? ray.tmin : 0.0f), tmax(far_limit(ray));

  std::optional<Number> best;
  std::vector<uint32_t> best_groups;
  for (uint32_t g = 0; g < m.boxes.size(); ++g) {
    if (!cull.may_hit(m.boxes[g])) continue;
    const auto& [a, b, c] = m.vertices[g];
    const std::optional<Number> t = line_crossing(org, q, dir, a, b, c);
    if (!t) continue;
    if ((has_min && *t < tmin) || (has_max && *t > tmax)) continue;
    if (best) {
      const CGAL::Comparison_result order = CGAL::compare(*t, *best);
      if (order == CGAL::LARGER) continue;
      if (order == CGAL::SMALLER) best_groups.clear();
    }
    best = *t;
    best_groups.push_back(g);
  }
  if (!best) return hit;
  for (const uint32_t g : best_groups)
    hit.tied.insert(hit.tied.end(), m.members.begin() + m.member_begin[g],
                    m.members.begin() + m.member_begin[g + 1]);
  std::sort(hit.tied.begin(), hit.tied.end());
  hit.t = round_to_float(*best);
  return hit;
}

std::vector<ExactHit> ExactReference::closest(std::span<const Ray> rays) const {
  std::vector<ExactHit> hits(rays.size());
  // A few rays per task: an exact test costs microseconds, and rays aimed at edges cost far more.
  constexpr std::size_t kGrain = 16;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), kGrain), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) hits[i] = closest(rays[i]);
  });
  return hits;
}

bool exact_line_hit(const Triangle& triangle, const Ray& ray, float& t) {
  if (!is_finite_ray(ray) || !is_finite(triangle.v0) || !is_finite(triangle.v1) || !is_finite(triangle.v2))
    return false;
  const Point org = to_point(ray.org);
  const Vector dir(ray.dir.x, ray.dir.y, ray.dir.z);
  const std::optional<Number> crossing =
      line_crossing(org, org + dir, dir, to_point(triangle.v0), to_point(triangle.v1), to_point(triangle.v2));
  if (!crossing) return false;
  t = round_to_float(*crossing);
  return true;
}

}  // namespace sahbench
