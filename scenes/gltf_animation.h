#pragma once
// Per-frame triangles of an animated glTF file: node TRS animation (translation, rotation, scale;
// STEP, LINEAR and CUBICSPLINE samplers), skinning (JOINTS_n / WEIGHTS_n, inverse bind matrices, joint
// world transforms) and morph targets (POSITION targets, mesh/node default weights and animated
// weights), as the glTF 2.0 specification defines them (sections 3.7.2.2 morph targets, 3.7.3 skins,
// 3.11 animations).

#include <filesystem>
#include <memory>
#include <span>
#include <vector>

#include "core/triangle.h"
#include "scenes/scene.h"

namespace sahbench {

class GltfAnimation {
 public:
  /// Reads `path` (binary: GLB) and its first animation. `static_scene` must be load_gltf's result for
  /// the same file: its triangles are the candidates that the static load kept, and the frames this
  /// produces have the same triangles in the same order. That correspondence is checked here: the
  /// rest pose (node transforms, no skin, no morph) must reproduce static_scene.triangles exactly,
  /// else an Error says so. A file without animations is an Error, as is a malformed skin, morph target
  /// or animation channel (naming the file and the part).
  GltfAnimation(const std::filesystem::path& path, bool binary, const Scene& static_scene);
  ~GltfAnimation();
  GltfAnimation(GltfAnimation&&) noexcept;
  GltfAnimation& operator=(GltfAnimation&&) noexcept;

  /// The animation's time range in seconds: the earliest and latest keyframe of its channels.
  double start() const;
  double end() const;

  /// The world-space triangles at time `t` (clamped to the keyframes as glTF prescribes), one per
  /// triangle of the static scene in the same order; `out` is resized. Runs in parallel (TBB).
  void positions_at(double t, std::vector<Triangle>& out) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sahbench
