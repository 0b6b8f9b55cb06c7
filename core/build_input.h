#pragma once
// What a builder gets: per-primitive bounds, plus the triangles for builders that clip
// them (spatial splits). Computed once per scene and shared by every builder of a run.

#include <span>

#include "core/aabb.h"
#include "core/huge_pages.h"
#include "core/triangle.h"

namespace sahbench {

struct BuildInput {
  /// Written once, in parallel, by from_triangles; on huge pages from 2 MiB (core/huge_pages.h).
  HugePageArray<Aabb> bounds;
  std::span<const Triangle> triangles;

  std::size_t size() const { return bounds.size(); }

  /// Bounds of each triangle (in parallel for large inputs). Builders bin the centres of these boxes,
  /// not the triangles' centroids, as Wald 2007 and Embree do.
  static BuildInput from_triangles(std::span<const Triangle> triangles);
};

}  // namespace sahbench
