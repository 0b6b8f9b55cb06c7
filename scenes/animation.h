#pragma once
// Animated scenes: a scene's triangles as a function of time, for frame-by-frame experiments (refit
// against rebuild). The triangles of every frame correspond one to one, in order, to those of the static
// load (load_scene), so a triangle index means the same triangle in every frame and a tree built on one
// frame can be refitted to another.

#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "core/triangle.h"
#include "scenes/scene.h"

namespace sahbench {

/// Something that places a scene's triangles at a time (glTF animation, procedural deformation).
class Animation {
 public:
  virtual ~Animation() = default;
  /// The triangles at time `t` seconds into `out` (resized to the static scene's triangle count).
  virtual void positions_at(double t, std::vector<Triangle>& out) const = 0;
};

struct AnimatedScene {
  /// The static load (load_scene): name, source, removed counts, camera and lights; its triangles are
  /// the rest pose (glTF: node transforms without skin or morph; proc:wave: t = 0).
  Scene scene;
  /// The animation's time range in seconds (both 0 for a static scene).
  double start = 0.0, end = 0.0;
  /// Null when the scene is static (scene.animated is false).
  std::shared_ptr<const Animation> animation;

  bool animated() const { return animation != nullptr; }

  /// `frames` times evenly spaced over [start, end], both ends included (just start for one frame).
  std::vector<double> frame_times(uint32_t frames) const;

  /// The triangles at time `t`, one per triangle of `scene` in the same order. A static scene gives its
  /// triangles at every t.
  void positions_at(double t, std::vector<Triangle>& out) const;
};

/// Loads `spec` (a file, shared-scene name or procedural spec, as load_scene) with its animation: a glTF
/// file's first animation (skinning, morph targets, node TRS; see gltf_animation.h) or an animated
/// procedural kind (proc:wave). A static scene loads with `animation` null rather than failing, so that
/// callers can skip it with a message. Throws Error for what load_scene rejects and for a malformed
/// animation.
AnimatedScene load_animated(std::string_view spec);

}  // namespace sahbench
