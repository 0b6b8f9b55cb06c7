#include "core/build_input.h"

#include <tbb/parallel_for.h>

namespace sahbench {

BuildInput BuildInput::from_triangles(std::span<const Triangle> triangles) {
  BuildInput input;
  input.triangles = triangles;
  input.bounds.resize(triangles.size());
  input.centroids.resize(triangles.size());
  // Grain chosen so a chunk is a few microseconds of work; results do not depend on it.
  constexpr std::size_t kGrain = 4096;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size(), kGrain), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      input.bounds[i] = triangles[i].bounds();
      // The centroid of the box, not of the triangle: binning then splits boxes the way the SAH sees
      // them, as in Wald 2007 and Embree.
      input.centroids[i] = input.bounds[i].center();
    }
  });
  return input;
}

}  // namespace sahbench
