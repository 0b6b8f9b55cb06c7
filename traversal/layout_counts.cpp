// The default per-ray counting of CompiledLayout: every layout has it through count_closest, so that
// images of nodes visited and primitives tested work for each layout without code of its own.

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "traversal/layout.h"

namespace sahbench {

void CompiledLayout::count_closest_per_ray(std::span<const Ray> rays, std::span<TraceCounts> counts) const {
  if (counts.size() != rays.size())
    throw Error("count_closest_per_ray: " + std::to_string(rays.size()) + " rays but " +
                std::to_string(counts.size()) + " count slots");
  // Chunks of rays per task: a single-ray count_closest is far too small a task for TBB on its own.
  constexpr std::size_t kChunk = 64;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), kChunk),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                        counts[i] = count_closest(rays.subspan(i, 1));
                    });
}

}  // namespace sahbench
