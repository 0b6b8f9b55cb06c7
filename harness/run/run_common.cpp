#include "harness/run/run_common.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <ostream>

#include "core/error.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "harness/run/csv.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "scenes/scene_path.h"
#include "traversal/layout.h"

namespace sahbench {

std::string now_stamp() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", &tm);
  return buf;
}

std::string format_duration(double seconds) {
  const auto s = static_cast<long>(std::lround(seconds));
  return s >= 60 ? fmt::format("{}m{:02}s", s / 60, s % 60) : fmt::format("{}s", s);
}

std::vector<std::string> scenes_to_run(const ExperimentConfig& cfg, std::ostream& log) {
  for (const auto& name : cfg.scenes) {
    if (is_procedural_spec(name)) {
      parse_proc_spec(name, procedural_kinds());
    } else if (!std::filesystem::is_regular_file(name) && !find_scene_file(name)) {
      load_scene(name);  // throws the loader's error, which names the scene and the search path
    }
  }
  std::vector<std::string> out = cfg.scenes;
  for (const auto& name : cfg.optional_scenes) {
    if (find_scene_file(name)) {
      out.push_back(name);
    } else {
      log << fmt::format("skipping optional scene '{}': not found on the scene search path\n", name);
    }
  }
  return out;
}

ResolvedRun resolve_run(const BuilderRun& run, const std::vector<LayoutSpec>& layouts) {
  ResolvedRun b;
  if (run.is_embree()) {
    std::string quality = "medium";
    for (const auto& [k, v] : run.params)
      if (k == "quality") quality = v;
    b.quality = parse_embree_quality(quality);
    b.params_text = "quality=" + quality;
    return b;
  }
  b.info = &find_builder(run.name);
  b.params = resolve_params(b.info->name, b.info->params, run.params);
  b.params_text = b.params.to_string();
  b.arity = b.info->arity ? b.info->arity(b.params) : 2;
  const bool traceable = std::any_of(layouts.begin(), layouts.end(), [&](const LayoutSpec& l) {
    return find_layout(l.name).arity == b.arity;
  });
  if (!traceable)
    throw Error("builder '" + run.label() + "' builds " + std::to_string(b.arity) +
                "-wide trees, but experiment.layouts has no layout for that arity (see `sahbench list`)");
  return b;
}

std::vector<CellLayout> layouts_for(const ResolvedRun& b, const std::vector<LayoutSpec>& configured,
                                    std::span<const EmbreeLayout> embree) {
  std::vector<CellLayout> out;
  if (b.is_embree()) {
    for (const auto& l : embree) out.push_back({l.name, nullptr});
  } else {
    for (const auto& l : configured)
      if (find_layout(l.name).arity == b.arity) out.push_back({l.text(), &l});
  }
  return out;
}

void add_note(CsvRow& row, const std::string& note) {
  std::string& notes = row["notes"];
  notes += (notes.empty() ? "" : "; ") + note;
}

std::string camera_note(const CameraConfig& camera) {
  return fmt::format("camera eye ({}) target ({}) up ({}) fov {}", fmt::join(camera.eye, ", "),
                     fmt::join(camera.target, ", "), fmt::join(camera.up, ", "), camera.fov);
}

CsvRow common_row(const RunIdentity& id, const Environment& env, const ExperimentConfig& cfg,
                  const Scene& scene, uint32_t frame, const std::string& builder,
                  const std::string& params_text, int threads) {
  CsvRow row;
  row["run_id"] = id.run_id;
  row["run_fingerprint"] = id.fingerprint.hash;
  row["fingerprint_parts"] = id.fingerprint.parts_text();
  row["git_commit"] = env.git_commit;
  row["cpu"] = env.cpu;
  row["compiler"] = env.compiler;
  // What the code was compiled for; `isa` is each row's kernel (report captions name both).
  row["build_isa"] = env.isa;
  row["threads"] = std::to_string(threads);
  row["scene"] = scene.name;
  row["scene_triangles"] = std::to_string(scene.triangles.size());
  row["frame"] = std::to_string(frame);
  row["builder"] = builder;
  row["builder_params"] = params_text;
  row["build_reps"] = std::to_string(cfg.reps.build);
  row["trace_reps"] = std::to_string(cfg.reps.trace);
  row["config"] = cfg.path.string();
  row["seed"] = std::to_string(cfg.seed);
  row["scene_source"] = scene.source;
  row["scene_removed"] = std::to_string(scene.removed.total());
  row["embree_version"] = env.embree;
  if (const CameraConfig* camera = cfg.camera_for(scene.name)) add_note(row, camera_note(*camera));
  return row;
}

BuildTiming time_embree_builds(const Repetitions& reps, EmbreeDevice& device,
                               std::span<const Triangle> triangles, EmbreeQuality quality,
                               std::unique_ptr<EmbreeScene>& built) {
  for (int w = 0; w < reps.build_warmup; ++w)
    built = std::make_unique<EmbreeScene>(device, triangles, quality);
  std::vector<double> build_ms;
  int64_t peak = 0;
  for (int r = 0; r < reps.build; ++r) {
    built.reset();
    const int64_t before = device.bytes();
    device.reset_peak();
    built = std::make_unique<EmbreeScene>(device, triangles, quality);
    build_ms.push_back(built->commit_ms());
    if (r == 0) peak = device.peak_bytes() - before;
  }
  return {summarize(build_ms), peak};
}

TimedCompile compile_timed(const LayoutSpec& spec, const Bvh& bvh, std::span<const Triangle> triangles,
                           const Repetitions& reps) {
  TimedCompile out;
  std::vector<double> compile_ms;
  for (int r = 0; r < std::max(1, reps.build); ++r) {
    out.layout.reset();
    compile_ms.push_back(time_ms([&] { out.layout = compile_layout(spec, bvh, triangles); }));
  }
  out.time = summarize(std::move(compile_ms));
  return out;
}

void trace_layout(const CompiledLayout& layout, const RaySet& rs, std::span<Hit> hits,
                  std::span<uint8_t> occluded) {
  if (rs.occlusion)
    layout.trace_any(rs.rays, occluded);
  else
    layout.trace_closest(rs.rays, hits);
}

TraceCounts count_layout(const CompiledLayout& layout, const RaySet& rs) {
  return rs.occlusion ? layout.count_any(rs.rays) : layout.count_closest(rs.rays);
}

void trace_embree(const EmbreeScene& scene, const EmbreeLayout& layout, const RaySet& rs, std::span<Hit> hits,
                  std::span<uint8_t> occluded) {
  if (layout.packet_width == 1) {
    if (rs.occlusion)
      embree_occluded1(scene, rs.rays, occluded);
    else
      embree_intersect1(scene, rs.rays, hits);
  } else {
    if (rs.occlusion)
      embree_occluded_packets(scene, rs.rays, occluded, layout.packet_width);
    else
      embree_intersect_packets(scene, rs.rays, hits, layout.packet_width);
  }
}

}  // namespace sahbench
