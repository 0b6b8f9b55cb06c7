#include "core/build_input.h"

#include <tbb/parallel_for.h>

#include <memory>

namespace sahbench {

BuildInput BuildInput::from_triangles(std::span<const Triangle> triangles) {
  BuildInput input;
  input.triangles = triangles;
  input.bounds = HugePageArray<Aabb>(triangles.size());
  // Grain chosen so a chunk is a few microseconds of work; results do not depend on it.
  constexpr std::size_t kGrain = 4096;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size(), kGrain), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      std::construct_at(&input.bounds[i], triangles[i].bounds());
  });
  return input;
}

}  // namespace sahbench
