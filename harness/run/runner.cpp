#include "harness/run/runner.h"

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tbb/global_control.h>

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
#include "harness/run/csv.h"
#include "harness/run/environment.h"
#include "harness/run/ray_sets.h"
#include "harness/run/reference.h"
#include "harness/run/result_row.h"
#include "harness/run/round_order.h"
#include "harness/run/run_common.h"
#include "harness/run/run_session.h"
#include "harness/run/timing.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

class Progress {
 public:
  Progress(std::size_t total, std::ostream& log)
      : total_(total), log_(log), start_(std::chrono::steady_clock::now()) {}
  /// Interleaved cells finish together: announcing the batch first makes the time left reckon with all
  /// of it from its first line on, rather than with one cell for the whole batch's time.
  void batch(std::size_t cells) { batch_end_ = std::min(total_, done_ + cells); }
  void cell_done(const std::string& what) {
    ++done_;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const std::size_t counted = std::max(done_, batch_end_);
    const double left = elapsed / static_cast<double>(counted) * static_cast<double>(total_ - counted);
    log_ << fmt::format("[{}/{}] {} | elapsed {}, left ~{}\n", done_, total_, what, format_duration(elapsed),
                        format_duration(left));
  }
  void skip(std::size_t cells) { total_ -= std::min(total_, cells); }
  std::size_t done() const { return done_; }
  std::size_t total() const { return total_; }
  double elapsed_s() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::size_t total_, done_ = 0, batch_end_ = 0;
  std::ostream& log_;
  std::chrono::steady_clock::time_point start_;
};

// One builder run of the config, resolved against the registry.
struct ResolvedBuilder : ResolvedRun {
  BuilderRun run;
};

std::vector<ResolvedBuilder> resolve_builders(const ExperimentConfig& cfg) {
  std::vector<ResolvedBuilder> out;
  for (const auto& run : cfg.builders) out.push_back({resolve_run(run, cfg.layouts), run});
  return out;
}

class ExperimentRunner {
 public:
  ExperimentRunner(const ExperimentConfig& cfg, const RunOptions& options, std::ostream& log)
      : cfg_(cfg),
        options_(options),
        log_(log),
        env_(current_environment()),
        builders_(resolve_builders(cfg)),
        output_(options.output ? *options.output : cfg.output),
        continue_with_(resume_command(options)) {}

  int run() {
    // Every required scene is checked, and the lock taken, before the CSV is touched: the writer then
    // checks the header and removes a row cut off by a crash before anything reads the file.
    const std::vector<std::string> scenes = scenes_to_run(cfg_, log_);
    const OutputLock lock(output_);
    CsvWriter csv(output_, result_columns());
    if (csv.dropped_partial_row())
      log_ << fmt::format("{}: removed a partial last row (an interrupted write)\n", output_.string());
    std::vector<std::string> builder_runs;
    for (const auto& b : builders_) builder_runs.push_back(b.run.name + " " + b.params_text);
    id_.fingerprint = fingerprint_of(cfg_, scenes, builder_runs, env_);
    id_.run_id = make_run_id(cfg_.name);
    std::set<std::string> finished;
    if (options_.resume) {
      ResumePoint point = find_resume_point(output_, id_.fingerprint, log_);
      if (!point.run_id.empty()) id_.run_id = point.run_id;
      finished = std::move(point.finished);
    }

    supported_embree_layouts_ = supported_embree_layouts(log_);
    // Plan: which cells of each scene are still to do.
    std::size_t total = 0;
    for (const auto& scene : scenes) total += pending_cells(scene, finished).size();
    if (total == 0 && !options_.only.empty() && finished.empty())
      throw Error(
          fmt::format("--only '{}' matches no cell of {} (cells are named "
                      "scene|builder|builder_params|layout|threads|ray_set|frame)",
                      options_.only, cfg_.path.string()));
    log_ << fmt::format("run {} (fingerprint {}): {} cells to run over {} scenes; writing {}\n", id_.run_id,
                        id_.fingerprint.hash, total, scenes.size(), output_.string());
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
  std::vector<CellLayout> layouts_for(const ResolvedBuilder& b) const {
    return sahbench::layouts_for(b, cfg_.layouts, supported_embree_layouts_);
  }

  // Keys of the cells of `scene` that are neither finished (resume) nor filtered out (--only).
  std::set<std::string> pending_cells(const std::string& scene, const std::set<std::string>& finished) const {
    std::set<std::string> out;
    for (const auto& b : builders_)
      for (const auto& layout : layouts_for(b))
        for (int threads : cfg_.threads)
          for (const auto& rs : cfg_.ray_sets) {
            const std::string key =
                cell_key(scene, b.run.name, b.params_text, layout.name, threads, rs.name, 0);
            if (finished.count(key)) continue;
            if (!options_.only.empty() && key.find(options_.only) == std::string::npos) continue;
            out.insert(key);
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
    const double load_ms = time_ms([&] { scene = load_scene(scene_name); });
    load_ms_ += load_ms;
    diagonal_ = scene_diagonal(scene.triangles);
    log_ << fmt::format("scene {}: {} triangles ({} removed), {}, from {} in {:.0f} ms\n", scene_name,
                        scene.triangles.size(), scene.removed.total(), scene.animated ? "animated" : "static",
                        scene.source, load_ms);
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
    std::vector<Reference> references(generated.sets.size());
    reference_ms_ += time_ms([&] {
      for (std::size_t i = 0; i < generated.sets.size(); ++i)
        references[i] =
            make_reference(scene, generated.sets[i], cfg_.reference, cfg_.brute_force_max_triangles);
    });

    for (int threads : cfg_.threads) {
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                      static_cast<std::size_t>(threads));
      Group group{scene, threads, generated.sets, pending};
      std::vector<const ResolvedBuilder*> runs;
      for (const auto& b : builders_)
        if (group.any_wanted(b, layouts_for(b))) runs.push_back(&b);
      // Interleaved: every builder run's builds in turns, then every cell's traces in turns. Otherwise one
      // builder run at a time, so that one tree is in memory at a time.
      if (cfg_.reps.interleave) {
        measure(group, runs, references, csv, progress);
      } else {
        for (const ResolvedBuilder* b : runs) measure(group, {b}, references, csv, progress);
      }
    }
  }

  // The cells of one scene and thread count.
  struct Group {
    const Scene& scene;
    int threads;
    const std::vector<RaySet>& sets;
    const std::set<std::string>& pending;

    bool wanted(const ResolvedBuilder& b, const std::string& layout, const RaySet& rs) const {
      return pending.count(cell_key(scene.name, b.run.name, b.params_text, layout, threads, rs.name, 0)) > 0;
    }
    bool any_wanted(const ResolvedBuilder& b, const std::vector<CellLayout>& layouts) const {
      for (const auto& layout : layouts)
        for (const auto& rs : sets)
          if (wanted(b, layout.name, rs)) return true;
      return false;
    }
  };

  // An Embree build and the device it lives in, kept together for its cells.
  struct EmbreeBuild {
    explicit EmbreeBuild(int threads) : device(threads) {}
    EmbreeDevice device;
    std::unique_ptr<EmbreeScene> scene;
  };

  // One builder run's builds: a tree of ours or an Embree scene, rebuilt once per round.
  struct BuildJob {
    const ResolvedBuilder* builder = nullptr;
    std::shared_ptr<Bvh> tree;            // ours
    std::shared_ptr<EmbreeBuild> embree;  // Embree's
    std::vector<double> ms;
    int64_t peak = 0;  // bytes allocated at the peak of the first timed build

    // One build after freeing the last, so that no repetition pays for freeing the one before; `timed`:
    // its milliseconds go into `ms` (rtcCommitScene's for Embree), the first one's peak into `peak`.
    void build(const Scene& scene, bool timed) {
      const ResolvedBuilder& b = *builder;
      if (b.is_embree()) {
        embree->scene.reset();
        const int64_t before = embree->device.bytes();
        embree->device.reset_peak();
        embree->scene = std::make_unique<EmbreeScene>(embree->device, scene.triangles, b.quality);
        if (!timed) return;
        if (ms.empty()) peak = embree->device.peak_bytes() - before;
        ms.push_back(embree->scene->commit_ms());
        return;
      }
      *tree = Bvh{};
      const int64_t before = heap_bytes();
      reset_heap_peak();
      const double t =
          time_ms([&] { *tree = b.info->build(BuildInput::from_triangles(scene.triangles), b.params); });
      if (!timed) return;
      if (ms.empty()) peak = heap_peak_bytes() - before;
      ms.push_back(t);
    }
  };

  // Times the builds of `runs` (warm-ups, then the timed rounds, each in its own shuffle), then traces
  // every wanted cell of them (trace_cells) and writes their rows.
  void measure(const Group& group, const std::vector<const ResolvedBuilder*>& runs,
               const std::vector<Reference>& references, CsvWriter& csv, Progress& progress) {
    std::vector<BuildJob> jobs;
    for (const ResolvedBuilder* b : runs) {
      BuildJob job;
      job.builder = b;
      if (b->is_embree())
        job.embree = std::make_shared<EmbreeBuild>(group.threads);
      else
        job.tree = std::make_shared<Bvh>();
      jobs.push_back(std::move(job));
    }
    for (int w = 0; w < cfg_.reps.build_warmup; ++w)
      for (auto& job : jobs) job.build(group.scene, false);
    const uint64_t seed = order_seed(cfg_.seed, group.scene.name, group.threads, "build");
    for (int r = 0; r < cfg_.reps.build; ++r) {
      for (const std::size_t k : round_order(seed, jobs.size(), r)) {
        check_interrupt(progress);
        jobs[k].build(group.scene, true);
      }
    }
    std::vector<TraceCell> cells;
    for (auto& job : jobs) {
      check_interrupt(progress);
      if (job.builder->is_embree())
        queue_embree(group, job, cells);
      else
        queue_ours(group, job, csv, progress, cells);
    }
    time_cells(cells, group, progress);
    finish_cells(cells, group.sets, references, csv, progress);
  }

  // A cell built and compiled, waiting for its trace timing: its row so far, one pass of its kernel over
  // its ray set (writing `hits` or `occluded`), the counting pass, and what keeps its structures alive.
  struct TraceCell {
    CsvRow row;
    std::string label;  // builder, layout, threads and ray set, for the log
    double build_ms = 0.0;
    std::size_t set = 0, rays = 0;
    std::function<void()> trace;
    std::function<TraceCounts()> count;  // empty for Embree, which has no counting kernel
    // Where the passes write: the mismatch count reads the last one's. Shared with `trace`.
    std::shared_ptr<std::vector<Hit>> hits;
    std::shared_ptr<std::vector<uint8_t>> occluded;
    std::shared_ptr<const void> keep_alive;
    std::vector<double> mrays;
  };

  // The ray set's columns of a cell's row, its log label, and the buffers its passes write.
  static void set_up_cell(TraceCell& cell, const Group& group, const ResolvedBuilder& b,
                          const std::string& layout, std::size_t set, double build_ms,
                          std::shared_ptr<const void> keep_alive) {
    const RaySet& rs = group.sets[set];
    put_ray_set(cell.row, rs);
    cell.label =
        fmt::format("{} {} {} t={} {}", group.scene.name, b.run.label(), layout, group.threads, rs.name);
    cell.build_ms = build_ms;
    cell.set = set;
    cell.rays = rs.rays.size();
    cell.keep_alive = std::move(keep_alive);
    cell.hits = std::make_shared<std::vector<Hit>>(rs.occlusion ? 0 : rs.rays.size());
    cell.occluded = std::make_shared<std::vector<uint8_t>>(rs.occlusion ? rs.rays.size() : 0);
  }

  // Trace repetitions. Interleaved: every cell's warm-ups, then round r of every cell, in the round's own
  // shuffle (round_order). Otherwise each cell's warm-ups and repetitions back to back.
  void time_cells(std::vector<TraceCell>& cells, const Group& group, const Progress& progress) {
    auto time_once = [&](TraceCell& cell) {
      check_interrupt(progress);
      cell.mrays.push_back(static_cast<double>(cell.rays) / (time_ms(cell.trace) * 1e3));
    };
    if (!cfg_.reps.interleave) {
      for (auto& cell : cells) {
        for (int w = 0; w < cfg_.reps.trace_warmup; ++w) cell.trace();
        for (int r = 0; r < cfg_.reps.trace; ++r) time_once(cell);
      }
      return;
    }
    for (auto& cell : cells)
      for (int w = 0; w < cfg_.reps.trace_warmup; ++w) cell.trace();
    const uint64_t seed = order_seed(cfg_.seed, group.scene.name, group.threads, "trace");
    for (int r = 0; r < cfg_.reps.trace && !cells.empty(); ++r) {
      log_ << fmt::format("{} t={}: trace repetition {} of {}, {} cells in shuffled turns\n",
                          group.scene.name, group.threads, r + 1, cfg_.reps.trace, cells.size());
      for (const std::size_t k : round_order(seed, cells.size(), r)) time_once(cells[k]);
    }
  }

  // Completes each timed cell's row (timings, counts, hits and mismatches from its last pass) and
  // writes it.
  void finish_cells(std::vector<TraceCell>& cells, const std::vector<RaySet>& sets,
                    const std::vector<Reference>& refs, CsvWriter& csv, Progress& progress) {
    progress.batch(cells.size());
    for (auto& cell : cells) {
      const RaySet& rs = sets[cell.set];
      const Reference& ref = refs[cell.set];
      CsvRow& row = cell.row;
      const TimingSummary trace_t = summarize(cell.mrays);
      put_timing(row, "trace_mrays", trace_t);
      if (cell.count) put_per_ray_counts(row, cell.count());
      put_hit_fraction(row, *cell.hits, *cell.occluded);
      put_mismatches(row, ref, rs, diagonal_, *cell.hits, *cell.occluded);
      csv_ms_ += time_ms([&] { csv.append(row); });
      progress.cell_done(fmt::format("{}: build {:.1f} ms, {:.2f} Mrays/s, {} mismatches", cell.label,
                                     cell.build_ms, trace_t.median, row["mismatches"]));
    }
  }

  CsvRow base_row(const Group& group, const ResolvedBuilder& b) const {
    return common_row(id_, env_, cfg_, group.scene, 0, b.run.name, b.params_text, group.threads);
  }

  // Checks the built tree of one of our builder runs, then compiles it and queues a cell per wanted
  // layout and ray set. The validator runs before anything else walks the tree: an invalid tree's cells
  // are written at once, untraced and without statistics.
  void queue_ours(const Group& group, const BuildJob& job, CsvWriter& csv, Progress& progress,
                  std::vector<TraceCell>& cells) {
    const ResolvedBuilder& b = *job.builder;
    const Scene& scene = group.scene;
    const Bvh& bvh = *job.tree;
    const TimingSummary build_t = summarize(job.ms);
    const ValidationReport report = validate(bvh, std::span<const Triangle>(scene.triangles));
    if (!report.ok()) {
      // Tracing a broken tree can read out of bounds: its cells get rows that say why, and no timings.
      exit_code_ = 1;
      log_ << fmt::format("INVALID tree from {} on {}:\n{}", b.run.label(), scene.name, report.summary());
      for (const CellLayout& layout : layouts_for(b))
        for (const auto& rs : group.sets) {
          if (!group.wanted(b, layout.name, rs)) continue;
          CsvRow row = base_row(group, b);
          row["isa"] = env_.isa;
          row["layout"] = layout.name;
          put_timing(row, "build_ms", build_t);
          row["nodes"] = std::to_string(bvh.nodes.size());
          row["arity"] = std::to_string(bvh.arity);
          put_ray_set(row, rs);
          add_note(row, "invalid tree, not traced: " + report.errors.front());
          csv_ms_ += time_ms([&] { csv.append(row); });
          progress.cell_done(fmt::format("{} {} {} t={} {}: INVALID tree, not traced", scene.name,
                                         b.run.label(), layout.name, group.threads, rs.name));
        }
      return;
    }
    const SahCost cost = sah_cost_of(b.params);
    const BvhStats stats = compute_stats(bvh, scene.triangles.size(), cost);

    for (const CellLayout& layout : layouts_for(b)) {
      const std::string& layout_name = layout.name;
      bool any = false;
      for (const auto& rs : group.sets) any |= group.wanted(b, layout_name, rs);
      if (!any) continue;
      TimedCompile compiled = compile_timed(*layout.ours, bvh, scene.triangles, cfg_.reps);
      // The layout borrows the tree (bvh2 as built): both stay alive with the cells.
      std::shared_ptr<const CompiledLayout> shared_layout(std::move(compiled.layout));
      auto keep = std::make_shared<std::pair<std::shared_ptr<Bvh>, std::shared_ptr<const CompiledLayout>>>(
          job.tree, shared_layout);
      for (std::size_t s = 0; s < group.sets.size(); ++s) {
        const RaySet& rs = group.sets[s];
        if (!group.wanted(b, layout_name, rs)) continue;
        TraceCell cell;
        CsvRow& row = cell.row;
        row = base_row(group, b);
        row["isa"] = shared_layout->isa();
        row["layout"] = layout_name;
        put_timing(row, "build_ms", build_t);
        row["layout_ms"] = fmt::format("{:.4f}", compiled.time.median);
        put_build_layout_ms(row, build_t, compiled.time);
        row["mem_bytes"] = std::to_string(shared_layout->bytes());
        row["bytes_per_tri"] = bytes_per_triangle(shared_layout->bytes(), scene.triangles.size());
        row["mem_peak_bytes"] = tracking_enabled() ? std::to_string(job.peak) : "";
        put_tree_stats(row, stats, cost);
        row["arity"] = std::to_string(bvh.arity);
        set_up_cell(cell, group, b, layout_name, s, build_t.median, keep);
        const CompiledLayout* layout_ptr = shared_layout.get();
        const RaySet* set_ptr = &rs;
        cell.trace = [layout_ptr, set_ptr, hits = cell.hits, occluded = cell.occluded] {
          trace_layout(*layout_ptr, *set_ptr, *hits, *occluded);
        };
        cell.count = [layout_ptr, set_ptr] { return count_layout(*layout_ptr, *set_ptr); };
        cells.push_back(std::move(cell));
      }
    }
  }

  // Queues a cell per supported Embree layout and wanted ray set of an Embree build.
  void queue_embree(const Group& group, const BuildJob& job, std::vector<TraceCell>& cells) {
    const ResolvedBuilder& b = *job.builder;
    const TimingSummary build_t = summarize(job.ms);
    const EmbreeScene* embree = job.embree->scene.get();
    for (const auto& layout : supported_embree_layouts_) {
      for (std::size_t s = 0; s < group.sets.size(); ++s) {
        const RaySet& rs = group.sets[s];
        if (!group.wanted(b, layout.name, rs)) continue;
        TraceCell cell;
        CsvRow& row = cell.row;
        row = base_row(group, b);
        row["isa"] = "embree:" + embree_isa(job.embree->device);
        row["layout"] = layout.name;
        put_timing(row, "build_ms", build_t);
        put_build_layout_ms(row, build_t, {});  // rtcCommitScene builds and packs in one call
        row["mem_bytes"] = std::to_string(embree->bytes());
        row["bytes_per_tri"] = bytes_per_triangle(embree->bytes(), group.scene.triangles.size());
        row["mem_peak_bytes"] = std::to_string(job.peak);
        set_up_cell(cell, group, b, layout.name, s, build_t.median, job.embree);
        const RaySet* set_ptr = &rs;
        cell.trace = [embree, layout, set_ptr, hits = cell.hits, occluded = cell.occluded] {
          trace_embree(*embree, layout, *set_ptr, *hits, *occluded);
        };
        cells.push_back(std::move(cell));
      }
    }
  }

  const ExperimentConfig& cfg_;
  const RunOptions& options_;
  std::ostream& log_;
  Environment env_;
  std::vector<ResolvedBuilder> builders_;
  std::vector<EmbreeLayout> supported_embree_layouts_;
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
  if (cfg.animation) return run_animation_experiment(cfg, options, log);
  return ExperimentRunner(cfg, options, log).run();
}

}  // namespace sahbench
