#pragma once
// Axis-aligned bounding box. An empty box has min = +inf and max = -inf, so that extending it by
// any point gives that point's box and its area is zero.

#include <limits>

#include "core/vec3.h"

namespace sahbench {

struct Aabb {
  Vec3 min{std::numeric_limits<float>::infinity()};
  Vec3 max{-std::numeric_limits<float>::infinity()};

  static constexpr Aabb empty() { return {}; }
  static constexpr Aabb from_point(Vec3 p) { return {p, p}; }

  constexpr bool is_empty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }

  constexpr Aabb& extend(Vec3 p) {
    min = sahbench::min(min, p);
    max = sahbench::max(max, p);
    return *this;
  }
  constexpr Aabb& extend(const Aabb& b) {
    min = sahbench::min(min, b.min);
    max = sahbench::max(max, b.max);
    return *this;
  }

  constexpr Vec3 extent() const { return max - min; }
  constexpr Vec3 center() const { return (min + max) * 0.5f; }

  /// Half the surface area. The SAH only ever uses ratios of areas, so the factor 2 is dropped.
  /// An empty box has zero area (its negative extents would otherwise give a positive product).
  constexpr float half_area() const {
    if (is_empty()) return 0.0f;
    const Vec3 e = extent();
    return e.x * e.y + e.y * e.z + e.z * e.x;
  }

  constexpr bool contains(const Aabb& b) const {
    return min.x <= b.min.x && min.y <= b.min.y && min.z <= b.min.z && max.x >= b.max.x && max.y >= b.max.y &&
           max.z >= b.max.z;
  }

  friend constexpr bool operator==(const Aabb&, const Aabb&) = default;
};

constexpr Aabb merge(Aabb a, const Aabb& b) {
  return a.extend(b);
}

}  // namespace sahbench
