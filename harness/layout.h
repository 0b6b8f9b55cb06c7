#pragma once
// Layouts: traversal-specific packings compiled from a common-format Bvh (DESIGN.md). A layout owns
// its compiled data and its kernels; the harness times compile() separately from the build, and
// trace_*() separately from everything else. Kernels are selected at compile time inside each layout;
// the harness calls through this interface once per batch of rays, never per ray or per node.

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/bvh.h"
#include "core/ray.h"
#include "core/triangle.h"

namespace sahbench {

/// Work counted by a layout's statistics kernel, summed over a batch of rays.
struct TraceCounts {
  uint64_t rays = 0;
  uint64_t nodes_visited = 0;  ///< nodes whose box test passed and whose children or primitives were examined
  uint64_t prims_tested = 0;   ///< ray/primitive tests
};

class CompiledLayout {
 public:
  virtual ~CompiledLayout() = default;
  /// Closest hits of `rays` into `hits` (same size), in parallel with TBB under the caller's thread limit.
  virtual void trace_closest(std::span<const Ray> rays, std::span<Hit> hits) const = 0;
  /// Occlusion of `rays` into `occluded` (1 when any hit within [tmin, tmax]).
  virtual void trace_any(std::span<const Ray> rays, std::span<uint8_t> occluded) const = 0;
  /// The same traversals with counters; not timed.
  virtual TraceCounts count_closest(std::span<const Ray> rays) const = 0;
  virtual TraceCounts count_any(std::span<const Ray> rays) const = 0;
  /// Exact bytes of the compiled structure (nodes, references, packed leaves).
  virtual std::size_t bytes() const = 0;
};

struct LayoutInfo {
  std::string name;
  std::string summary;
  /// Compiles `bvh` over `triangles` (which must outlive the result). Throws Error when the tree does
  /// not suit the layout (e.g. arity too large), naming both.
  std::unique_ptr<CompiledLayout> (*compile)(const Bvh& bvh, std::span<const Triangle> triangles);
};

std::span<const LayoutInfo> layouts();
/// The layout called `name`; an unknown name is an error listing the known ones.
const LayoutInfo& find_layout(std::string_view name);

}  // namespace sahbench
