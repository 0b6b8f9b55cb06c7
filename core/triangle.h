#pragma once
// A world-space triangle. Scenes store triangles by value (three float vertices, 36 bytes), so that
// builders and kernels never chase an index buffer.

#include "core/aabb.h"

namespace sahbench {

struct Triangle {
  Vec3 v0, v1, v2;

  constexpr Aabb bounds() const { return Aabb::from_point(v0).extend(v1).extend(v2); }
  constexpr Vec3 centroid() const { return (v0 + v1 + v2) * (1.0f / 3.0f); }
  /// Geometric normal, not normalised: its length is twice the area.
  constexpr Vec3 normal() const { return cross(v1 - v0, v2 - v0); }
  float area() const { return 0.5f * length(normal()); }

  friend constexpr bool operator==(const Triangle&, const Triangle&) = default;
};

}  // namespace sahbench
