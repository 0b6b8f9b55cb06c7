#include "harness/run/runner.h"

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <ostream>
#include <set>

#include "builders/registry.h"
#include "core/bvh_stats.h"
#include "core/error.h"
#include "core/memory_tracker.h"
#include "core/validate.h"
#include "harness/config/config.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "harness/run/animation_runner.h"
#include "harness/run/cell_pipeline.h"
#include "harness/run/csv.h"
#include "harness/run/environment.h"
#include "harness/run/ray_sets.h"
#include "harness/run/reference.h"
#include "harness/run/result_row.h"
#include "harness/run/round_order.h"
#include "harness/run/run_common.h"
#include "harness/run/run_session.h"
#include "harness/run/shard_plan.h"
#include "harness/run/static_plan.h"
#include "harness/run/timing.h"
#include "harness/run/tree_file_builder.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

class ExperimentRunner {
 public:
  ExperimentRunner(const ExperimentConfig& cfg, const RunOptions& options, std::ostream& log)
      : cfg_(cfg),
        options_(options),
        log_(log),
        env_(current_environment()),
        output_(options.output  ? *options.output
                : options.shard ? shard_output_path(cfg.output, *options.shard)
                                : cfg.output),
        continue_with_(resume_command(options)) {}

  int run() {
    // Every required scene is checked, and the lock taken, before the CSV is touched: the writer then
    // checks the header and removes a row cut off by a crash before anything reads the file.
    warn_oversubscribed(cfg_, log_);
    const std::vector<std::string> scenes = scenes_to_run(cfg_, log_);
    std::vector<std::string> builder_runs;
    for (const auto& b : builders_) builder_runs.push_back(b.name + " " + b.params_text());
    layouts_ = runnable_layouts(cfg_, log_);
    // Plan: the static plan's cells, or one shard's of them; then which of each scene are still to do.
    if (options_.shard) {
      const ShardPlan plan = plan_shards(cfg_, scenes, layouts_, options_.shard->count);
      shard_cells_ = plan.keys_of(options_.shard->index);
      log_ << fmt::format("shard {}: {} of the plan's {} cells (anchors to Embree included)\n",
                          options_.shard->text(), shard_cells_.size(), plan.cells.size());
      cells_ = plan.cells;
    } else {
      cells_ = static_cells(cfg_, scenes, layouts_);
    }
    // A filter that matches nothing is a typo: said before the output is created.
    if (!options_.only.empty() && std::all_of(scenes.begin(), scenes.end(), [&](const std::string& s) {
          return pending_cells(s, {}).empty();
        }))
      throw Error(
          fmt::format("--only '{}' matches no cell of {}{} (cells are named "
                      "scene|builder|builder_params|layout|threads|ray_set|frame)",
                      options_.only, options_.shard ? "shard " + options_.shard->text() + " of " : "",
                      cfg_.path.string()));
    OpenRun open = open_run(cfg_, options_, output_, result_columns(), scenes, builder_runs, env_, log_);
    id_ = open.id;
    const std::set<std::string>& finished = open.finished;
    CsvWriter& csv = *open.csv;
    std::size_t total = 0, scenes_left = 0;
    for (const auto& scene : scenes) {
      const std::size_t pending = pending_cells(scene, finished).size();
      total += pending;
      scenes_left += pending > 0;
    }
    log_ << fmt::format("run {} (fingerprint {}): {} cells to run over {} scene{}; writing {}\n", id_.run_id,
                        id_.fingerprint.hash, total, scenes_left, scenes_left == 1 ? "" : "s",
                        output_.string());
    const InterruptGuard interrupts;
    Progress progress(total, log_);
    for (const auto& scene : scenes) {
      const auto pending = pending_cells(scene, finished);
      if (!pending.empty()) run_scene(scene, pending, csv, progress);
    }
    const double total_s = progress.elapsed_s();
    const double overhead_s = (load_ms_ + rays_ms_ + csv_ms_) / 1e3;
    log_ << fmt::format("done in {}; rows in {}\n", format_duration(total_s), output_.string());
    log_ << fmt::format(
        "harness overhead: loading {:.1f} s, ray generation {:.1f} s, CSV {:.2f} s = {:.1f}% of the run; "
        "reference hits {:.1f} s ({:.1f}%)\n",
        load_ms_ / 1e3, rays_ms_ / 1e3, csv_ms_ / 1e3, 100.0 * overhead_s / std::max(total_s, 1e-9),
        reference_ms_ / 1e3, 100.0 * reference_ms_ / 1e3 / std::max(total_s, 1e-9));
    return exit_code_;
  }

 private:
  std::vector<CellLayout> layouts_for(const BuilderRun& b) const {
    return sahbench::layouts_for(b, layouts_);
  }

  // Keys of the cells of `scene` that are neither finished (resume) nor filtered out (--only, --shard).
  std::set<std::string> pending_cells(const std::string& scene, const std::set<std::string>& finished) const {
    std::set<std::string> out;
    for (const PlannedCell& cell : cells_) {
      if (cell.scene != scene || finished.count(cell.key)) continue;
      if (options_.shard && !shard_cells_.count(cell.key)) continue;
      if (!options_.only.empty() && cell.key.find(options_.only) == std::string::npos) continue;
      out.insert(cell.key);
    }
    return out;
  }

  // Stops between two timed steps once SIGINT or SIGTERM has come: the cells in progress are dropped.
  void check_interrupt(const Progress& progress) const {
    InterruptGuard::check(progress.done(), progress.total(), continue_with_);
  }

  void run_scene(const std::string& scene_name, const std::set<std::string>& pending, CsvWriter& csv,
                 Progress& progress) {
    check_interrupt(progress);
    Scene scene;
    // A malformed file is found only as it is read: its error names the config before the loader's.
    const double load_ms = time_ms([&] {
      try {
        scene = load_scene(scene_name);
      } catch (const Error& e) {
        const auto& optional = cfg_.optional_scenes;
        const bool is_optional = std::find(optional.begin(), optional.end(), scene_name) != optional.end();
        throw Error(
            fmt::format("{}: experiment.{}: {}{}", cfg_.path.string(),
                        is_optional ? "optional_scenes" : "scenes", e.what(),
                        // Not a --resume: the scenes' contents are part of the run's fingerprint, so a fixed
                        // or removed scene is another run.
                        progress.done() > 0
                            ? fmt::format("; the {} cells finished are kept in the output CSV, but a fixed "
                                          "or removed scene makes another run: run again without --resume",
                                          progress.done())
                            : ""));
      }
    });
    load_ms_ += load_ms;
    // A tree file for another scene is refused now, naming the config and the run, not after the builds
    // before it.
    for (const BuilderRun& b : cfg_.builders) {
      try {
        check_tree_file_fits(b, scene.triangles);
      } catch (const Error& e) {
        throw Error(fmt::format("{}: builder run '{}' on scene {}: {}", cfg_.path.string(), b.label(),
                                scene_name, e.what()));
      }
    }
    diagonal_ = scene_diagonal(scene.triangles);
    log_ << fmt::format("scene {}: {} triangles ({} removed), {}, from {} in {:.0f} ms\n", scene_name,
                        scene.triangles.size(), scene.removed.total(), scene.animated ? "animated" : "static",
                        scene.source, load_ms);
    if (const LightsConfig* lights = cfg_.lights_for(scene_name)) {
      scene.lights = to_lights(*lights);
      log_ << fmt::format("scene {}: {} from the config\n", scene_name, lights_note(*lights));
    }
    if (const CameraConfig* view = cfg_.camera_for(scene_name)) {
      scene.camera = to_camera(*view);
      log_ << fmt::format("scene {}: camera from the config: eye ({}), target ({}), fov {} degrees\n",
                          scene_name, fmt::join(view->eye, ", "), fmt::join(view->target, ", "), view->fov);
    }
    GeneratedRaySets generated;
    rays_ms_ += time_ms([&] { generated = generate_ray_sets(scene, cfg_.ray_sets, cfg_.seed); });
    for (const auto& [set, reason] : generated.skipped) {
      std::size_t skipped = 0;
      for (const auto& key : pending)
        if (key.ends_with("|" + set + "|0")) ++skipped;
      log_ << fmt::format("scene {}: skipping ray set '{}' ({} cells): {}\n", scene_name, set, skipped,
                          reason);
      progress.skip(skipped);
    }
    for (const RaySet& set : generated.sets)
      if (!set.note.empty())
        log_ << fmt::format("scene {}: ray set '{}': {}\n", scene_name, set.name, set.note);
    std::vector<Reference> references(generated.sets.size());
    // Brute force over a few hundred thousand triangles takes seconds: said on stderr, and stopped on
    // Ctrl-C between chunks of rays, as the timed cells are between steps.
    const bool brute_force =
        resolved_reference(cfg_.reference, scene.triangles.size(), cfg_.brute_force_max_triangles) ==
        ReferencePolicy::kBruteForce;
    std::size_t reference_rays = 0;
    for (const RaySet& set : generated.sets) reference_rays += set.rays.size();
    if (brute_force && reference_rays > 0)
      log_ << fmt::format("scene {}: reference answers by brute force ({} rays x {} triangles)\n", scene_name,
                          reference_rays, scene.triangles.size());
    const double ms = time_ms([&] {
      for (std::size_t i = 0; i < generated.sets.size(); ++i)
        references[i] = make_reference(scene, generated.sets[i], cfg_.reference,
                                       cfg_.brute_force_max_triangles, [&] { check_interrupt(progress); });
    });
    reference_ms_ += ms;
    if (brute_force && reference_rays > 0)
      log_ << fmt::format("scene {}: reference answers in {:.1f} s\n", scene_name, ms / 1000.0);

    for (int threads : cfg_.threads) {
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                      static_cast<std::size_t>(threads));
      Group group{scene, threads, generated.sets, pending};
      std::vector<const BuilderRun*> runs;
      for (const auto& b : builders_)
        if (group.any_wanted(b, layouts_for(b))) runs.push_back(&b);
      // Interleaved: every builder run's builds in turns, then every cell's traces in turns. Otherwise one
      // builder run at a time, so that one tree is in memory at a time.
      if (cfg_.reps.interleave) {
        measure(group, runs, references, csv, progress);
      } else {
        for (const BuilderRun* b : runs) measure(group, {b}, references, csv, progress);
      }
    }
  }

  // The cells of one scene and thread count.
  struct Group {
    const Scene& scene;
    int threads;
    const std::vector<RaySet>& sets;
    const std::set<std::string>& pending;

    bool wanted(const BuilderRun& b, const std::string& layout, const RaySet& rs) const {
      return pending.count(cell_key(scene.name, b.name, b.params_text(), layout, threads, rs.name, 0)) > 0;
    }
    bool any_wanted(const BuilderRun& b, const std::vector<CellLayout>& layouts) const {
      for (const auto& layout : layouts)
        for (const auto& rs : sets)
          if (wanted(b, layout.name, rs)) return true;
      return false;
    }
  };

  // One builder run's tree source: a tree of ours or an Embree scene, made afresh in every round.
  struct BuildJob {
    const BuilderRun* builder = nullptr;
    std::shared_ptr<Bvh> tree;            // ours
    std::shared_ptr<EmbreeBuild> embree;  // Embree's
    TreeSource source;
  };

  static BuildJob make_job(const BuilderRun& b, const Scene& scene, int threads) {
    BuildJob job;
    job.builder = &b;
    if (b.is_embree()) {
      job.embree = std::make_shared<EmbreeBuild>(threads);
      job.source = embree_build(b.label(), job.embree, scene.triangles, b.quality, b.embree_options());
    } else {
      job.tree = std::make_shared<Bvh>();
      job.source = our_build(b.label(), *b.info, b.values, scene.triangles, job.tree);
    }
    return job;
  }

  // Times the builds of `runs` (time_sources), then queues every wanted cell of them, times their traces
  // (time_cells) and writes their rows.
  void measure(const Group& group, const std::vector<const BuilderRun*>& runs,
               const std::vector<Reference>& references, CsvWriter& csv, Progress& progress) {
    std::vector<BuildJob> jobs;
    for (const BuilderRun* b : runs) jobs.push_back(make_job(*b, group.scene, group.threads));
    std::vector<TreeSource*> sources;
    for (auto& job : jobs) sources.push_back(&job.source);
    const auto interrupt = [&] { check_interrupt(progress); };
    // Builds of a large scene take seconds each: each round says so, as the trace rounds do.
    log_ << fmt::format("{} t={}: building {} trees, {} warm-up and {} timed builds each\n", group.scene.name,
                        group.threads, sources.size(), cfg_.reps.build_warmup, cfg_.reps.build);
    time_sources(sources, cfg_.reps, order_seed(cfg_.seed, group.scene.name, group.threads, "build"),
                 interrupt, [&](int r) {
                   log_ << fmt::format("{} t={}: build repetition {} of {}, {} trees in shuffled turns\n",
                                       group.scene.name, group.threads, r + 1, cfg_.reps.build,
                                       sources.size());
                 });
    std::vector<TraceCell> cells;
    for (auto& job : jobs) {
      check_interrupt(progress);
      if (job.builder->is_embree())
        queue_embree(group, job, cells);
      else
        queue_ours(group, job, csv, progress, cells);
    }
    time_cells(cells, cfg_.reps, order_seed(cfg_.seed, group.scene.name, group.threads, "trace"), interrupt,
               [&](int r) {
                 log_ << fmt::format("{} t={}: trace repetition {} of {}, {} cells in shuffled turns\n",
                                     group.scene.name, group.threads, r + 1, cfg_.reps.trace, cells.size());
               });
    progress.batch(cells.size());
    for (auto& cell : cells) {
      finish_cell(cell, references[cell.set_index], diagonal_);
      csv_ms_ += time_ms([&] { csv.append(cell.row); });
      progress.cell_done(cell_summary(cell.label, cell.row));
    }
  }

  CsvRow base_row(const Group& group, const BuilderRun& b, const std::string& layout,
                  const TimingSummary& build_t) const {
    CsvRow row = common_row(id_, env_, cfg_, group.scene, 0, b.name, b.params_text(), group.threads);
    row["layout"] = layout;
    put_timing(row, "build_ms", build_t);
    return row;
  }

  std::string label(const Group& group, const BuilderRun& b, const std::string& layout,
                    const RaySet& rs) const {
    return fmt::format("{} {} {} t={} {}", group.scene.name, b.label(), layout, group.threads, rs.name);
  }

  // Checks the built tree of one of our builder runs, then compiles it and queues a cell per wanted
  // layout and ray set. An invalid tree's cells are written at once, untraced and without statistics.
  void queue_ours(const Group& group, const BuildJob& job, CsvWriter& csv, Progress& progress,
                  std::vector<TraceCell>& cells) {
    const BuilderRun& b = *job.builder;
    const Scene& scene = group.scene;
    const Bvh& bvh = *job.tree;
    const TimingSummary build_t = job.source.time();
    CheckedTree checked = check_tree(bvh, scene.triangles, b.values, cfg_.epo);
    if (!checked.ok()) {
      exit_code_ = 1;
      log_ << fmt::format("INVALID tree from {} on {}:\n{}", b.label(), scene.name, checked.report.summary());
      for (const CellLayout& layout : layouts_for(b))
        for (const auto& rs : group.sets) {
          if (!group.wanted(b, layout.name, rs)) continue;
          CsvRow row = base_row(group, b, layout.name, build_t);
          row["isa"] = env_.isa;
          put_ray_set(row, rs);
          put_invalid_tree(row, bvh, checked.report);
          csv_ms_ += time_ms([&] { csv.append(row); });
          progress.cell_done(label(group, b, layout.name, rs) + ": INVALID tree, not traced");
        }
      return;
    }
    checked.source_sah = source_sah_cost(scene.triangles, b.values);
    if (checked.epo)
      log_ << fmt::format("{} on {}: EPO cost {:.4f} in {:.0f} ms (untimed)\n", b.label(), scene.name,
                          *checked.epo, checked.epo_ms);
    for (const CellLayout& layout : layouts_for(b)) {
      bool any = false;
      for (const auto& rs : group.sets) any |= group.wanted(b, layout.name, rs);
      if (!any) continue;
      TimedCompile compiled = compile_timed(*layout.ours, bvh, scene.triangles, cfg_.reps);
      // The layout borrows the tree (bvh2 as built): the cells keep both alive.
      auto shared = std::make_shared<std::pair<std::shared_ptr<Bvh>, std::unique_ptr<CompiledLayout>>>(
          job.tree, std::move(compiled.layout));
      const std::shared_ptr<const CompiledLayout> kept(shared, shared->second.get());
      for (std::size_t s = 0; s < group.sets.size(); ++s) {
        const RaySet& rs = group.sets[s];
        if (!group.wanted(b, layout.name, rs)) continue;
        CsvRow row = base_row(group, b, layout.name, build_t);
        row["layout_ms"] = fmt::format("{:.4f}", compiled.time.median);
        put_build_layout_ms(row, build_t, compiled.time);
        put_our_layout(row, *kept, bvh, checked, scene.triangles.size(), job.source.peak);
        cells.push_back(
            our_cell(std::move(row), label(group, b, layout.name, rs), kept, rs, s, checked.cost));
      }
    }
  }

  // Queues a cell per supported Embree layout and wanted ray set of an Embree build.
  void queue_embree(const Group& group, const BuildJob& job, std::vector<TraceCell>& cells) {
    const BuilderRun& b = *job.builder;
    const TimingSummary build_t = job.source.time();
    const EmbreeBuild& embree = *job.embree;
    for (const auto& layout : layouts_.embree) {
      for (std::size_t s = 0; s < group.sets.size(); ++s) {
        const RaySet& rs = group.sets[s];
        if (!group.wanted(b, layout.name, rs)) continue;
        CsvRow row = base_row(group, b, layout.name, build_t);
        put_build_layout_ms(row, build_t, {});  // rtcCommitScene builds and packs in one call
        put_embree_scene(row, *embree.scene, embree.device, group.scene.triangles.size(), job.source.peak);
        cells.push_back(embree_cell(std::move(row), label(group, b, layout.name, rs), *embree.scene, layout,
                                    rs, s, job.embree));
      }
    }
  }

  const ExperimentConfig& cfg_;
  const RunOptions& options_;
  std::ostream& log_;
  Environment env_;
  const std::vector<BuilderRun>& builders_ = cfg_.builders;
  RunLayouts layouts_;
  std::vector<PlannedCell> cells_;     // the static plan (static_plan.h)
  std::set<std::string> shard_cells_;  // with --shard: the keys of that shard's cells
  std::filesystem::path output_;
  std::string continue_with_;  // the command that resumes this run, for the interrupt message
  RunIdentity id_;
  int exit_code_ = 0;
  // Where the run's time goes besides measuring: the harness's own overhead, and the reference checks.
  float diagonal_ = 1.0f;  // of the current scene's box, for the tie tolerance
  double load_ms_ = 0.0, rays_ms_ = 0.0, csv_ms_ = 0.0, reference_ms_ = 0.0;
};

}  // namespace

int run_experiment(const RunOptions& options, std::ostream& log) {
  const ExperimentConfig cfg = load_experiment_config(options.config);
  if (cfg.animation && options.shard)
    throw Error(
        fmt::format("{}: --shard applies to static experiments; an animation's frames build on "
                    "each other and run as one process",
                    cfg.path.string()));
  if (cfg.animation) return run_animation_experiment(cfg, options, log);
  for (const BuilderRun& run : cfg.builders) require_resolved(run);
  return ExperimentRunner(cfg, options, log).run();
}

}  // namespace sahbench
