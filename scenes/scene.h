#pragma once
// A loaded scene: world-space float triangles, with the invalid ones removed and counted.

#include <cstdint>
#include <string>
#include <vector>

#include "core/triangle.h"

namespace sahbench {

/// Triangles removed at load time, by reason (DESIGN.md, numerical policy). Never silent: the CLI
/// prints these and the harness records them.
struct RemovedTriangles {
  std::size_t non_finite = 0;    ///< a NaN or infinite coordinate
  std::size_t bad_index = 0;     ///< an index outside the vertex array
  std::size_t zero_area = 0;     ///< zero area (repeated vertices, collinear, or the cross product underflows)
  std::size_t total() const { return non_finite + bad_index + zero_area; }
};

struct Scene {
  std::string name;                 ///< what the user asked for: a path, a shared-scene name or a procedural spec
  std::string source;               ///< the resolved file path, or the normalised procedural spec
  std::vector<Triangle> triangles;  ///< valid triangles only
  RemovedTriangles removed;
};

}  // namespace sahbench
