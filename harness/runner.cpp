#include "harness/runner.h"

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
#include "harness/animation_runner.h"
#include "harness/config.h"
#include "harness/csv.h"
#include "harness/embree_scene.h"
#include "harness/embree_trace.h"
#include "harness/environment.h"
#include "harness/layout.h"
#include "harness/ray_sets.h"
#include "harness/reference.h"
#include "harness/result_row.h"
#include "harness/run_common.h"
#include "harness/timing.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"

namespace sahbench {
namespace {

// Columns written after DESIGN.md's (never renamed; these may grow).
const std::vector<std::string>& extra_columns() {
  static const std::vector<std::string> columns = {
      "config",         "seed",  "scene_source", "scene_removed", "query",
      "embree_version", "notes", "build_isa",    "bytes_per_tri", "sah_block"};
  return columns;
}

std::vector<std::string> all_columns() {
  std::vector<std::string> c = design_columns();
  c.insert(c.end(), extra_columns().begin(), extra_columns().end());
  return c;
}

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
        run_id_(cfg.name + "-" + now_stamp()) {}

  int run() {
    // The writer first: it checks the header and removes a row cut off by a crash before anything reads.
    CsvWriter csv(output_, all_columns());
    if (csv.dropped_partial_row())
      log_ << fmt::format("{}: removed a partial last row (an interrupted write)\n", output_.string());
    std::set<std::string> finished;
    if (options_.resume) finished = finished_cells(output_, cfg_, run_id_, log_);

    supported_embree_layouts_ = supported_embree_layouts(log_);
    const std::vector<std::string> scenes = scenes_to_run(cfg_, log_);
    // Plan: which cells of each scene are still to do.
    std::size_t total = 0;
    for (const auto& scene : scenes) total += pending_cells(scene, finished).size();
    log_ << fmt::format("run {}: {} cells to run over {} scenes; writing {}\n", run_id_, total, scenes.size(),
                        output_.string());
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
  std::vector<std::string> layouts_for(const ResolvedBuilder& b) const {
    return sahbench::layouts_for(b, cfg_.layouts, supported_embree_layouts_);
  }

  // Keys of the cells of `scene` that are neither finished (resume) nor filtered out (--only).
  std::set<std::string> pending_cells(const std::string& scene, const std::set<std::string>& finished) const {
    std::set<std::string> out;
    for (const auto& b : builders_)
      for (const auto& layout : layouts_for(b))
        for (int threads : cfg_.threads)
          for (const auto& rs : cfg_.ray_sets) {
            const std::string key = cell_key(scene, b.run.name, b.params_text, layout, threads, rs.name, 0);
            if (finished.count(key)) continue;
            if (!options_.only.empty() && key.find(options_.only) == std::string::npos) continue;
            out.insert(key);
          }
    return out;
  }

  void run_scene(const std::string& scene_name, const std::set<std::string>& pending, CsvWriter& csv,
                 Progress& progress) {
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
      std::vector<TraceCell> cells;
      for (const auto& b : builders_) {
        auto wanted = [&](const std::string& layout, const RaySet& rs) {
          return pending.count(cell_key(scene_name, b.run.name, b.params_text, layout, threads, rs.name, 0)) >
                 0;
        };
        bool any = false;
        for (const auto& layout : layouts_for(b))
          for (const auto& rs : generated.sets) any |= wanted(layout, rs);
        if (!any) continue;
        if (b.is_embree()) {
          prepare_embree(scene, b, threads, generated.sets, wanted, cells);
        } else {
          prepare_ours(scene, b, threads, generated.sets, wanted, csv, progress, cells);
        }
        if (!cfg_.reps.interleave) {
          time_cells(cells, scene_name, threads);
          finish_cells(cells, generated.sets, references, csv, progress);
          cells.clear();
        }
      }
      time_cells(cells, scene_name, threads);
      finish_cells(cells, generated.sets, references, csv, progress);
    }
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
  static void set_up_cell(TraceCell& cell, const Scene& scene, const ResolvedBuilder& b,
                          const std::string& layout, int threads, const RaySet& rs, std::size_t set,
                          double build_ms, std::shared_ptr<const void> keep_alive) {
    put_ray_set(cell.row, rs);
    cell.label = fmt::format("{} {} {} t={} {}", scene.name, b.run.label(), layout, threads, rs.name);
    cell.build_ms = build_ms;
    cell.set = set;
    cell.rays = rs.rays.size();
    cell.keep_alive = std::move(keep_alive);
    cell.hits = std::make_shared<std::vector<Hit>>(rs.occlusion ? 0 : rs.rays.size());
    cell.occluded = std::make_shared<std::vector<uint8_t>>(rs.occlusion ? rs.rays.size() : 0);
  }

  // Trace repetitions. Interleaved: every cell's warm-ups, then repetition r of every cell in turn, each
  // round starting one cell later so that no cell always follows the same one. Otherwise each cell's
  // warm-ups and repetitions back to back.
  void time_cells(std::vector<TraceCell>& cells, const std::string& scene_name, int threads) {
    auto time_once = [](TraceCell& cell) {
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
    const std::size_t n = cells.size();
    for (int r = 0; r < cfg_.reps.trace && n > 0; ++r) {
      log_ << fmt::format("{} t={}: trace repetition {} of {}, {} cells in turn\n", scene_name, threads,
                          r + 1, cfg_.reps.trace, n);
      for (std::size_t k = 0; k < n; ++k) time_once(cells[(k + static_cast<std::size_t>(r)) % n]);
    }
  }

  // Completes each timed cell's row (timings, counts, mismatches from its last pass) and writes it.
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
      put_mismatches(row, ref, rs, diagonal_, *cell.hits, *cell.occluded);
      csv_ms_ += time_ms([&] { csv.append(row); });
      progress.cell_done(fmt::format("{}: build {:.1f} ms, {:.2f} Mrays/s, {} mismatches", cell.label,
                                     cell.build_ms, trace_t.median, row["mismatches"]));
    }
  }

  CsvRow base_row(const Scene& scene, const ResolvedBuilder& b, int threads) const {
    return common_row(run_id_, env_, cfg_, scene, 0, b.run.name, b.params_text, threads);
  }

  template <class Wanted>
  // Builds (timed), checks and compiles one of our builder runs, and queues a cell per wanted layout and
  // ray set; an invalid tree's cells are written at once, untraced.
  void prepare_ours(const Scene& scene, const ResolvedBuilder& b, int threads,
                    const std::vector<RaySet>& sets, Wanted wanted, CsvWriter& csv, Progress& progress,
                    std::vector<TraceCell>& cells) {
    // Build: warm-up, then timed repetitions. The peak heap is taken over the first timed build.
    auto tree = std::make_shared<Bvh>();
    Bvh& bvh = *tree;
    const auto [build_t, peak] = time_builds(
        cfg_.reps, [&] { bvh = b.info->build(BuildInput::from_triangles(scene.triangles), b.params); },
        [&] { bvh = Bvh{}; });
    const SahCost cost = sah_cost_of(b.params);
    const BvhStats stats = compute_stats(bvh, scene.triangles.size(), cost);
    const ValidationReport report = validate(bvh, std::span<const Triangle>(scene.triangles));
    if (!report.ok()) {
      // Tracing a broken tree can read out of bounds: its cells get rows that say why, and no timings.
      exit_code_ = 1;
      log_ << fmt::format("INVALID tree from {} on {}:\n{}", b.run.label(), scene.name, report.summary());
      for (const auto& layout_name : layouts_for(b))
        for (const auto& rs : sets) {
          if (!wanted(layout_name, rs)) continue;
          CsvRow row = base_row(scene, b, threads);
          row["isa"] = env_.isa;
          row["layout"] = layout_name;
          put_timing(row, "build_ms", build_t);
          row["nodes"] = std::to_string(stats.nodes);
          row["arity"] = std::to_string(bvh.arity);
          put_ray_set(row, rs);
          add_note(row, "invalid tree, not traced: " + report.errors.front());
          csv_ms_ += time_ms([&] { csv.append(row); });
          progress.cell_done(fmt::format("{} {} {} t={} {}: INVALID tree, not traced", scene.name,
                                         b.run.label(), layout_name, threads, rs.name));
        }
      return;
    }

    for (const auto& layout_name : layouts_for(b)) {
      bool any = false;
      for (const auto& rs : sets) any |= wanted(layout_name, rs);
      if (!any) continue;
      TimedCompile compiled = compile_timed(parse_layout_spec(layout_name), bvh, scene.triangles, cfg_.reps);
      // The layout borrows the tree (bvh2 as built): both stay alive with the cells.
      std::shared_ptr<const CompiledLayout> shared_layout(std::move(compiled.layout));
      auto keep = std::make_shared<std::pair<std::shared_ptr<Bvh>, std::shared_ptr<const CompiledLayout>>>(
          tree, shared_layout);
      const double compile_median = compiled.median_ms;
      for (std::size_t s = 0; s < sets.size(); ++s) {
        const RaySet& rs = sets[s];
        if (!wanted(layout_name, rs)) continue;
        TraceCell cell;
        CsvRow& row = cell.row;
        row = base_row(scene, b, threads);
        row["isa"] = shared_layout->isa();
        row["layout"] = layout_name;
        put_timing(row, "build_ms", build_t);
        row["layout_ms"] = fmt::format("{:.4f}", compile_median);
        row["mem_bytes"] = std::to_string(shared_layout->bytes());
        row["bytes_per_tri"] = bytes_per_triangle(shared_layout->bytes(), scene.triangles.size());
        row["mem_peak_bytes"] = tracking_enabled() ? std::to_string(peak) : "";
        put_tree_stats(row, stats, cost);
        row["arity"] = std::to_string(bvh.arity);
        set_up_cell(cell, scene, b, layout_name, threads, rs, s, build_t.median, keep);
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

  // An Embree build and the device it lives in, kept together for its cells.
  struct EmbreeBuild {
    explicit EmbreeBuild(int threads) : device(threads) {}
    EmbreeDevice device;
    std::unique_ptr<EmbreeScene> scene;
  };

  // Builds (timed) an Embree scene and queues a cell per supported Embree layout and wanted ray set.
  template <class Wanted>
  void prepare_embree(const Scene& scene, const ResolvedBuilder& b, int threads,
                      const std::vector<RaySet>& sets, Wanted wanted, std::vector<TraceCell>& cells) {
    auto held = std::make_shared<EmbreeBuild>(threads);
    EmbreeDevice& device = held->device;
    std::unique_ptr<EmbreeScene>& built = held->scene;
    const auto [build_t, peak] = time_embree_builds(cfg_.reps, device, scene.triangles, b.quality, built);
    for (const auto& layout : supported_embree_layouts_) {
      for (std::size_t s = 0; s < sets.size(); ++s) {
        const RaySet& rs = sets[s];
        if (!wanted(layout.name, rs)) continue;
        TraceCell cell;
        CsvRow& row = cell.row;
        row = base_row(scene, b, threads);
        row["isa"] = "embree:" + embree_isa(device);
        row["layout"] = layout.name;
        put_timing(row, "build_ms", build_t);
        row["mem_bytes"] = std::to_string(built->bytes());
        row["bytes_per_tri"] = bytes_per_triangle(built->bytes(), scene.triangles.size());
        row["mem_peak_bytes"] = std::to_string(peak);
        set_up_cell(cell, scene, b, layout.name, threads, rs, s, build_t.median, held);
        const EmbreeScene* embree = built.get();
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
  std::string run_id_;
  int exit_code_ = 0;
  // Where the run's time goes besides measuring: the harness's own overhead, and the reference checks.
  float diagonal_ = 1.0f;  // of the current scene's box, for the tie tolerance
  double load_ms_ = 0.0, rays_ms_ = 0.0, csv_ms_ = 0.0, reference_ms_ = 0.0;
};

}  // namespace

std::string cell_key(const std::string& scene, const std::string& builder, const std::string& params,
                     const std::string& layout, int threads, const std::string& ray_set, int frame) {
  return fmt::format("{}|{}|{}|{}|{}|{}|{}", scene, builder, params, layout, threads, ray_set, frame);
}

std::vector<std::string> result_columns() {
  return all_columns();
}

int run_experiment(const RunOptions& options, std::ostream& log) {
  const ExperimentConfig cfg = load_experiment_config(options.config);
  if (cfg.animation) return run_animation_experiment(cfg, options, log);
  return ExperimentRunner(cfg, options, log).run();
}

}  // namespace sahbench
