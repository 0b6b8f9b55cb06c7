#pragma once
// A loaded scene: world-space float triangles, with the invalid ones removed and counted.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/triangle.h"

namespace sahbench {

/// Triangles removed at load time, by reason (DESIGN.md, numerical policy). Never silent: the CLI
/// prints these and the harness records them.
struct RemovedTriangles {
  std::size_t non_finite = 0;  ///< a NaN or infinite coordinate
  std::size_t bad_index = 0;   ///< an index outside the vertex array
  std::size_t zero_area = 0;   ///< zero area (repeated vertices, collinear, or the cross product underflows)
  std::size_t total() const { return non_finite + bad_index + zero_area; }
};

/// A pinhole camera, for primary rays. From the scene file when it has one (glTF), else absent and the
/// harness frames the scene automatically.
struct Camera {
  Vec3 position;
  Vec3 forward{0, 0, -1};  ///< unit view direction
  Vec3 up{0, 1, 0};        ///< unit; primary rays orthogonalise it against forward
  float yfov = 0.785398f;  ///< vertical field of view in radians
};

struct Scene {
  std::string name;    ///< what the user asked for: a path, a shared-scene name or a procedural spec
  std::string source;  ///< the resolved file path, or the normalised procedural spec
  std::vector<Triangle> triangles;  ///< valid triangles only
  RemovedTriangles removed;
  std::optional<Camera> camera;  ///< the file's first perspective camera, if any
  std::vector<Vec3> lights;      ///< positions of the file's point and spot lights (KHR_lights_punctual)
  /// What the scene declares: animated when the file has animations (glTF) or the procedural kind moves
  /// (proc:wave), static otherwise. The triangles are the static pose (node transforms, no skinning or
  /// morphing; proc:wave at t = 0); per-frame positions come from load_animated (scenes/animation.h), with
  /// the same triangles in the same order, and the harness runs frame-dependent cells (refit) only on
  /// animated scenes.
  bool animated = false;
};

}  // namespace sahbench
