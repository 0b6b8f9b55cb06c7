#pragma once
// Pieces of `sahbench run` that the static runner (runner.cpp) and the animation runner
// (animation_runner.cpp) share, so that both name runs, pick scenes and layouts, resume and log the same
// way. Internal to the harness.

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <memory>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "builders/registry.h"
#include "core/memory_tracker.h"
#include "harness/config/config.h"
#include "harness/embree/embree_layouts.h"
#include "harness/embree/embree_scene.h"
#include "harness/run/csv.h"
#include "harness/run/environment.h"
#include "harness/run/ray_sets.h"
#include "harness/run/run_session.h"
#include "harness/run/timing.h"
#include "scenes/scene.h"
#include "traversal/layout.h"

namespace sahbench {

/// The time now in UTC as YYYYMMDD-HHMMSS: part of a run id (make_run_id).
std::string now_stamp();

/// Whole seconds as "42s", or "3m07s" from a minute on, for progress lines.
std::string format_duration(double seconds);

/// The scenes a run covers: `cfg.scenes`, then each of `cfg.optional_scenes` found on the scene search
/// path. Required scenes must exist before the first cell runs, not fail hours in: a missing one throws
/// the loader's Error; a missing optional one is skipped with a line on `log`.
std::vector<std::string> scenes_to_run(const ExperimentConfig& cfg, std::ostream& log);

/// One [[builder]] run resolved against the registry: one of our builders with its parameters, or
/// Embree's own BVH at a build quality.
struct ResolvedRun {
  const BuilderInfo* info = nullptr;  // ours; null for Embree
  ParamSet params;                    // ours
  uint32_t arity = 2;                 // ours: of its trees; traced only with layouts of that arity
  EmbreeQuality quality = EmbreeQuality::kMedium;
  std::string params_text;  // the CSV builder_params column
  bool is_embree() const { return info == nullptr; }
};

/// Resolves `run`: Embree's quality ("medium" where the run does not say), or our builder and its
/// parameters. Our builder must build trees of an arity that one of `layouts` traces; else an Error
/// names the builder run and the arity.
ResolvedRun resolve_run(const BuilderRun& run, const std::vector<LayoutSpec>& layouts);

/// A layout a cell is traced with: one of ours, with its spec as the config parsed it, or one of Embree's.
struct CellLayout {
  std::string name;                  ///< the CSV's layout column: LayoutSpec::text() or Embree's name
  const LayoutSpec* ours = nullptr;  ///< into the config's layouts; null for Embree's
};

/// The layouts that trace `b`'s trees: every one of `embree` for Embree, else those of `configured`
/// (which must outlive the result) with the arity of `b`'s trees.
std::vector<CellLayout> layouts_for(const ResolvedRun& b, const std::vector<LayoutSpec>& configured,
                                    std::span<const EmbreeLayout> embree);

/// The columns every row of a cell starts with: the run (run_id, run_fingerprint, fingerprint_parts,
/// config, seed, build_reps, trace_reps),
/// the machine (git_commit, cpu, compiler, embree_version), the scene and `frame`, the builder run
/// (`builder`, its `params_text`) and the thread count. A scene viewed through the config's [[camera]]
/// gets it in `notes` (camera_note), so a row says which view its rays came from.
/// Appends `note` to the row's `notes`, after "; " when it has some already.
void add_note(CsvRow& row, const std::string& note);

/// "camera eye (x, y, z) target (x, y, z) up (x, y, z) fov F": the view of a [[camera]], for `notes`.
std::string camera_note(const CameraConfig& camera);

CsvRow common_row(const RunIdentity& id, const Environment& env, const ExperimentConfig& cfg,
                  const Scene& scene, uint32_t frame, const std::string& builder,
                  const std::string& params_text, int threads);

/// A build's time over its repetitions (ms), and the bytes it allocated at its peak in the first timed one.
struct BuildTiming {
  TimingSummary time;
  int64_t peak_bytes = 0;
};

/// Times a build as every run does: `reps.build_warmup` untimed calls of `step`, then `reps.build` timed
/// ones, each after an untimed `reset` (so that no repetition pays for freeing the last one's result);
/// the peak is the heap's (memory_tracker.h) over the first timed one.
template <class Step, class Reset>
BuildTiming time_builds(const Repetitions& reps, Step step, Reset reset) {
  for (int w = 0; w < reps.build_warmup; ++w) step();
  std::vector<double> ms;
  int64_t peak = 0;
  for (int r = 0; r < reps.build; ++r) {
    reset();
    const int64_t before = heap_bytes();
    reset_heap_peak();
    ms.push_back(time_ms(step));
    if (r == 0) peak = heap_peak_bytes() - before;
  }
  return {summarize(ms), peak};
}

/// Embree's build of `triangles` at `quality`, timed the same way: warm-up builds, then timed ones, each
/// after freeing the last; the time is rtcCommitScene's (EmbreeScene::commit_ms) and the peak the
/// device's over the first timed build. `built` keeps the last build.
BuildTiming time_embree_builds(const Repetitions& reps, EmbreeDevice& device,
                               std::span<const Triangle> triangles, EmbreeQuality quality,
                               std::unique_ptr<EmbreeScene>& built);

/// A layout compiled max(1, reps.build) times, each after freeing the one before: the last compile and
/// the median of their times (ms).
struct TimedCompile {
  std::unique_ptr<CompiledLayout> layout;
  TimingSummary time;  ///< ms of each compile
};
TimedCompile compile_timed(const LayoutSpec& spec, const Bvh& bvh, std::span<const Triangle> triangles,
                           const Repetitions& reps);

/// One pass of `layout` over `rs`: closest hits into `hits`, or for an any-hit set occlusion into
/// `occluded`.
void trace_layout(const CompiledLayout& layout, const RaySet& rs, std::span<Hit> hits,
                  std::span<uint8_t> occluded);

/// The counting pass of `layout` over `rs` (count_closest, or count_any for an any-hit set).
TraceCounts count_layout(const CompiledLayout& layout, const RaySet& rs);

/// One pass of Embree's `layout` over `rs` in `scene` (rtcIntersect1/rtcOccluded1 or packets of its
/// width): closest hits into `hits`, or for an any-hit set occlusion into `occluded`.
void trace_embree(const EmbreeScene& scene, const EmbreeLayout& layout, const RaySet& rs, std::span<Hit> hits,
                  std::span<uint8_t> occluded);

}  // namespace sahbench
