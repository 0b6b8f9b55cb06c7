#include "scenes/animation.h"

#include "core/error.h"
#include "scenes/gltf_animation.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "scenes/scene_path.h"
#include "scenes/triangle_filter.h"
#include "scenes/wave.h"

namespace sahbench {

namespace {

class GltfSceneAnimation final : public Animation {
 public:
  explicit GltfSceneAnimation(GltfAnimation animation) : animation_(std::move(animation)) {}
  void positions_at(double t, std::vector<Triangle>& out) const override { animation_.positions_at(t, out); }

 private:
  GltfAnimation animation_;
};

/// proc:wave: the generator at time t, less the triangles the static load (t = 0) removed.
class WaveAnimation final : public Animation {
 public:
  WaveAnimation(const WaveParams& params, const Scene& static_scene) : params_(params) {
    // Which raw triangles the filter kept at t = 0; usually all, then no index list is needed.
    const std::vector<Triangle> raw = generate_wave(params_, 0.0);
    if (static_scene.removed.total() != 0) {
      Scene check;
      TriangleFilter filter(check);
      for (uint32_t i = 0; i < raw.size(); ++i) {
        const std::size_t before = check.triangles.size();
        filter.add(raw[i]);
        if (check.triangles.size() != before) kept_.push_back(i);
      }
    }
    if ((kept_.empty() ? raw.size() : kept_.size()) != static_scene.triangles.size())
      throw Error(static_scene.source + ": the wave generator does not reproduce the static scene");
  }

  void positions_at(double t, std::vector<Triangle>& out) const override {
    out = generate_wave(params_, t);
    if (kept_.empty()) return;
    for (std::size_t i = 0; i < kept_.size(); ++i) out[i] = out[kept_[i]];  // kept_ is increasing
    out.resize(kept_.size());
  }

 private:
  WaveParams params_;
  std::vector<uint32_t> kept_;  // raw indices kept at t = 0; empty when none was removed
};

}  // namespace

std::vector<double> AnimatedScene::frame_times(uint32_t frames) const {
  std::vector<double> times;
  for (uint32_t i = 0; i < frames; ++i)
    times.push_back(frames == 1
                        ? start
                        : start + (end - start) * static_cast<double>(i) / static_cast<double>(frames - 1));
  return times;
}

void AnimatedScene::positions_at(double t, std::vector<Triangle>& out) const {
  if (animation) {
    animation->positions_at(t, out);
  } else {
    out = scene.triangles;
  }
}

AnimatedScene load_animated(std::string_view spec) {
  AnimatedScene out;
  out.scene = load_scene(spec);
  if (!out.scene.animated) return out;
  if (is_procedural_spec(spec)) {
    const ProcSpec parsed = parse_proc_spec(spec, procedural_kinds());
    out.animation = std::make_shared<WaveAnimation>(wave_params(parsed), out.scene);
    out.start = 0.0;
    out.end = kWavePeriod;
    return out;
  }
  // Only the glTF loader marks a file animated; Scene::source is the file it read.
  const std::filesystem::path file(out.scene.source);
  const std::string ext = lower_extension(file);
  if (ext != ".gltf" && ext != ".glb") throw Error(out.scene.source + ": animated, but not a glTF file");
  GltfAnimation animation(file, ext == ".glb", out.scene);
  out.start = animation.start();
  out.end = animation.end();
  out.animation = std::make_shared<GltfSceneAnimation>(std::move(animation));
  return out;
}

}  // namespace sahbench
