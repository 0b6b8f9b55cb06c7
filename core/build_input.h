#pragma once
// What a builder gets: per-primitive bounds and centroids, plus the triangles for builders that clip
// them (spatial splits). Computed once per scene and shared by every builder of a run.

#include <span>
#include <vector>

#include "core/aabb.h"
#include "core/triangle.h"

namespace sahbench {

struct BuildInput {
  std::vector<Aabb> bounds;
  std::vector<Vec3> centroids;
  std::span<const Triangle> triangles;

  std::size_t size() const { return bounds.size(); }

  /// Bounds and centroids of each triangle (in parallel for large inputs).
  static BuildInput from_triangles(std::span<const Triangle> triangles);
};

}  // namespace sahbench
