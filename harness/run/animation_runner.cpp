#include "harness/run/animation_runner.h"

#include <fmt/format.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <ostream>
#include <set>

#include "builders/registry.h"
#include "core/bvh_stats.h"
#include "core/error.h"
#include "core/memory_tracker.h"
#include "core/refit.h"
#include "core/validate.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "harness/run/cell_pipeline.h"
#include "harness/run/csv.h"
#include "harness/run/environment.h"
#include "harness/run/ray_sets.h"
#include "harness/run/reference.h"
#include "harness/run/result_row.h"
#include "harness/run/round_order.h"
#include "harness/run/run_common.h"
#include "harness/run/run_session.h"
#include "harness/run/timing.h"
#include "scenes/animation.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "scenes/scene_path.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

// A tree whose references repeat (spatial splits, in sbvh or a pass over it) has leaf boxes clipped to
// parts of its triangles; core/refit.h can only give a leaf its triangles' whole boxes, which keeps every
// hit but not the clipping the build chose.
constexpr const char* kRefitOfSplitsNote =
    "references repeat (spatial splits): refitted leaves take their triangles' whole boxes, not the "
    "build's clipped ones";

// What a cell's tree is.
enum class Variant {
  kRebuild,        // one of our builders, built on this frame
  kRefit,          // one of our builders, built on the first frame and refitted to this one
  kEmbreeRebuild,  // rtcCommitScene on this frame
  kEmbreeRefit,    // Embree's refit of its first-frame build
};

// A builder run of the config as an animation runs it: rebuilt on every frame, or refitted.
struct AnimatedBuilder {
  const BuilderRun* run = nullptr;  // into the config
  Variant variant = Variant::kRebuild;
  std::string name;   // the CSV builder column: "binned_sah", "refit(binned_sah)", "embree"
  std::string label;  // for the log: the config's label, "refit(...)" around it for refits
  std::string params_text() const { return run->params_text(); }
};

// Each of our builder runs becomes a rebuild and a refit; Embree runs stay one (refit by quality).
std::vector<AnimatedBuilder> expand_builders(const ExperimentConfig& cfg) {
  std::vector<AnimatedBuilder> out;
  for (const auto& run : cfg.builders) {
    AnimatedBuilder b;
    b.run = &run;
    b.label = run.label();
    if (run.is_embree()) {
      b.variant = run.quality == EmbreeQuality::kRefit ? Variant::kEmbreeRefit : Variant::kEmbreeRebuild;
      b.name = "embree";
      out.push_back(std::move(b));
      continue;
    }
    b.variant = Variant::kRebuild;
    b.name = run.name;
    out.push_back(b);
    b.variant = Variant::kRefit;
    b.name = "refit(" + run.name + ")";
    b.label = "refit(" + run.label() + ")";
    out.push_back(std::move(b));
  }
  return out;
}

// One of our builders' refit cells in one scene: its tree of the first frame and that tree compiled into
// each layout that traces it, both refitted in place to every frame (the tree for its SAH cost and the
// build_ms column, each layout for tracing and layout_refit_ms). One per builder run serves every
// thread count, since trees and layouts are the same for any.
struct RefitState {
  Bvh tree;
  std::map<std::string, std::unique_ptr<CompiledLayout>> layouts;  // by the configured layout text
};

// One frame's triangles, rays and reference answers, shared by every cell of the frame.
struct FrameData {
  uint32_t index = 0;
  double time = 0.0;
  Scene scene;  // the frame's triangles, with the camera fixed for the whole animation
  float diagonal = 1.0f;
  std::vector<RaySet> sets;
  std::vector<std::pair<std::string, std::string>> skipped;  // ray sets that do not apply, with why
  std::vector<Reference> references;
};

Aabb bounds_of(std::span<const Triangle> triangles) {
  Aabb box;
  for (const auto& t : triangles) box.extend(t.bounds());
  return box;
}

class AnimationRunner {
 public:
  AnimationRunner(const ExperimentConfig& cfg, const RunOptions& options, std::ostream& log)
      : cfg_(cfg),
        options_(options),
        log_(log),
        env_(current_environment()),
        builders_(expand_builders(cfg)),
        output_(options.output ? *options.output : cfg.output),
        continue_with_(resume_command(options)) {}

  int run() {
    // As a static run: scenes checked and the lock taken before the CSV is touched.
    const std::vector<std::string> scenes = scenes_to_run(cfg_, log_);
    std::vector<std::string> builder_runs;
    for (const auto& b : builders_) builder_runs.push_back(b.name + " " + b.params_text());
    warn_oversubscribed(cfg_, log_);
    layouts_ = runnable_layouts(cfg_, log_);
    // A filter that matches nothing is a typo: said before the output is created.
    if (!options_.only.empty() && !any_cell_matches(scenes))
      throw Error(
          fmt::format("--only '{}' matches no cell of {} (cells are named "
                      "scene|builder|builder_params|layout|threads|ray_set|frame)",
                      options_.only, cfg_.path.string()));
    OpenRun open = open_run(cfg_, options_, output_, animation_columns(), scenes, builder_runs, env_, log_);
    id_ = open.id;
    finished_ = std::move(open.finished);
    CsvWriter& csv = *open.csv;

    // Scenes are loaded one at a time; the plan counts cells as each scene's frames become known.
    log_ << fmt::format("run {} (fingerprint {}): animation experiment, {} frames per scene; writing {}\n",
                        id_.run_id, id_.fingerprint.hash, cfg_.animation->frames, output_.string());
    const InterruptGuard interrupts;
    for (const auto& name : scenes) run_scene(name, csv);
    log_ << fmt::format("done in {}; rows in {}\n", format_duration(progress_.elapsed_s()), output_.string());
    print_summary();
    return exit_code_;
  }

 private:
  std::vector<CellLayout> layouts_for(const AnimatedBuilder& b) const {
    return sahbench::layouts_for(*b.run, layouts_);
  }

  bool wanted(const std::string& scene, const AnimatedBuilder& b, const std::string& layout, int threads,
              const std::string& ray_set, uint32_t frame) const {
    const std::string key =
        cell_key(scene, b.name, b.params_text(), layout, threads, ray_set, static_cast<int>(frame));
    if (finished_.count(key)) return false;
    return options_.only.empty() || key.find(options_.only) != std::string::npos;
  }

  // Whether --only matches a cell of any of `scenes` in any of the config's frames.
  bool any_cell_matches(const std::vector<std::string>& scenes) const {
    const std::size_t frames =
        cfg_.animation->times.empty() ? cfg_.animation->frames : cfg_.animation->times.size();
    for (const auto& scene : scenes)
      for (const auto& b : builders_)
        for (const auto& layout : layouts_for(b))
          for (int threads : cfg_.threads)
            for (const auto& rs : cfg_.ray_sets)
              for (std::size_t f = 0; f < frames; ++f)
                if (cell_key(scene, b.name, b.params_text(), layout.name, threads, rs.name,
                             static_cast<int>(f))
                        .find(options_.only) != std::string::npos)
                  return true;
    return false;
  }

  // Cells of `frame` still to run, over every builder, layout, thread count and configured ray set.
  std::size_t pending_in_frame(const std::string& scene, uint32_t frame) const {
    std::size_t n = 0;
    for (const auto& b : builders_)
      for (const auto& layout : layouts_for(b))
        for (int threads : cfg_.threads)
          for (const auto& rs : cfg_.ray_sets) n += wanted(scene, b, layout.name, threads, rs.name, frame);
    return n;
  }

  void run_scene(const std::string& name, CsvWriter& csv) {
    AnimatedScene animated;
    const double load_ms = time_ms([&] { animated = load_animated(name); });
    if (!animated.animated()) {
      log_ << fmt::format("skipping scene {}: static (animation experiments run only on animated scenes)\n",
                          name);
      return;
    }
    const std::vector<double> times =
        cfg_.animation->times.empty() ? animated.frame_times(cfg_.animation->frames) : cfg_.animation->times;
    log_ << fmt::format(
        "scene {}: {} triangles ({} removed), animated over [{:.4g}, {:.4g}] s, {} frames, from {} in "
        "{:.0f} ms\n",
        name, animated.scene.triangles.size(), animated.scene.removed.total(), animated.start, animated.end,
        times.size(), animated.scene.source, load_ms);

    std::vector<std::size_t> pending(times.size());
    std::size_t total = 0;
    for (uint32_t f = 0; f < times.size(); ++f) total += pending[f] = pending_in_frame(name, f);
    progress_.plan(total);
    if (total == 0) return;

    // One camera for every frame: the config's [[camera]], else the file's, else the automatic framing of
    // all frames together.
    std::vector<Triangle> triangles;
    std::optional<Camera> camera = animated.scene.camera;
    if (const CameraConfig* view = cfg_.camera_for(name)) camera = to_camera(*view);
    if (!camera) {
      Aabb all;
      for (double t : times) {
        animated.positions_at(t, triangles);
        all.extend(bounds_of(triangles));
      }
      camera = automatic_camera(all);
    }

    // Our trees of the first frame, refitted in place to every later frame (their layouts are compiled
    // when first traced, see trace_ours).
    std::vector<Triangle> first;
    animated.positions_at(times.front(), first);
    std::map<std::size_t, RefitState> refits;
    for (std::size_t i = 0; i < builders_.size(); ++i)
      if (builders_[i].variant == Variant::kRefit) {
        refits[i].tree =
            builders_[i].run->info->build(BuildInput::from_triangles(first), builders_[i].run->values);
        if (refits[i].tree.prim_refs.size() > first.size())
          log_ << fmt::format("scene {}: {}: {}\n", name, builders_[i].label, kRefitOfSplitsNote);
      }

    for (uint32_t f = 0; f < times.size(); ++f) {
      if (pending[f] == 0) continue;
      FrameData frame = make_frame(animated, f, times[f], *camera);
      for (const auto& [set, reason] : frame.skipped)
        log_ << fmt::format("scene {} frame {}: skipping ray set '{}': {}\n", name, f, set, reason);
      for (int threads : cfg_.threads) {
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                        static_cast<std::size_t>(threads));
        run_frame(frame, threads, refits, first, csv);
      }
    }
  }

  FrameData make_frame(const AnimatedScene& animated, uint32_t index, double time, const Camera& camera) {
    FrameData frame;
    frame.index = index;
    frame.time = time;
    frame.scene = animated.scene;
    frame.scene.camera = camera;
    if (const LightsConfig* lights = cfg_.lights_for(animated.scene.name))
      frame.scene.lights = to_lights(*lights);
    animated.positions_at(time, frame.scene.triangles);
    frame.diagonal = scene_diagonal(frame.scene.triangles);
    GeneratedRaySets generated = generate_ray_sets(frame.scene, cfg_.ray_sets, cfg_.seed);
    frame.sets = std::move(generated.sets);
    frame.skipped = std::move(generated.skipped);
    for (const auto& rs : frame.sets)
      frame.references.push_back(make_reference(
          frame.scene, rs, cfg_.reference, cfg_.brute_force_max_triangles, [this] { check_interrupt(); }));
    return frame;
  }

  CsvRow base_row(const FrameData& frame, const AnimatedBuilder& b, int threads) const {
    CsvRow row = common_row(id_, env_, cfg_, frame.scene, frame.index, b.name, b.params_text(), threads);
    row["frame_time"] = fmt::format("{:.6g}", frame.time);
    return row;
  }

  // Stops before the next timed step once SIGINT or SIGTERM has come; measured rows are written already.
  void check_interrupt() const { InterruptGuard::check(progress_.done(), progress_.total(), continue_with_); }

  void append(CsvWriter& csv, const CsvRow& row, const std::string& what) {
    csv.append(row);
    rows_.push_back(row);
    progress_.cell_done(what);
  }

  // One builder run's tree source on one frame: its tree (a rebuild's own, or the refit state's) or its
  // Embree scene.
  struct FrameJob {
    const AnimatedBuilder* builder = nullptr;
    std::shared_ptr<Bvh> tree;  // a rebuild's
    RefitState* refit = nullptr;
    std::shared_ptr<EmbreeBuild> embree;
    TreeSource source;
  };

  // Our rebuild: built on the frame, the last freed first. Our refit: the first frame's tree refitted in
  // place (every refit recomputes every box, so repeating it times the same work). Embree: a rebuild per
  // frame, or its refit scene of the first frame made afresh here and refitted to this frame, so that
  // every Embree refit, like ours, starts from the first frame's tree.
  FrameJob make_job(const FrameData& frame, const AnimatedBuilder& b, int threads, RefitState* refit,
                    std::span<const Triangle> first) const {
    FrameJob job;
    job.builder = &b;
    const std::vector<Triangle>& triangles = frame.scene.triangles;
    switch (b.variant) {
      case Variant::kRebuild:
        job.tree = std::make_shared<Bvh>();
        job.source = our_build(b.label, *b.run->info, b.run->values, triangles, job.tree);
        break;
      case Variant::kRefit:
        job.refit = refit;
        job.source = our_refit(b.label, refit->tree, triangles);
        break;
      case Variant::kEmbreeRebuild:
        job.embree = std::make_shared<EmbreeBuild>(threads);
        job.source = embree_build(b.label, job.embree, triangles, b.run->quality, b.run->embree_options());
        break;
      case Variant::kEmbreeRefit:
        job.embree = std::make_shared<EmbreeBuild>(threads);
        job.embree->scene = std::make_unique<EmbreeScene>(job.embree->device, first, EmbreeQuality::kRefit,
                                                          b.run->embree_options());
        job.source = embree_refit(b.label, job.embree, triangles);
        break;
    }
    return job;
  }

  bool any_wanted(const FrameData& frame, const AnimatedBuilder& b, int threads) const {
    for (const auto& layout : layouts_for(b))
      for (const auto& rs : frame.sets)
        if (wanted(frame.scene.name, b, layout.name, threads, rs.name, frame.index)) return true;
    return false;
  }

  // The cells of one frame and thread count: every builder run's tree source timed in interleaved,
  // shuffled rounds, then every wanted cell queued, its traces timed the same way, and its row written.
  void run_frame(const FrameData& frame, int threads, std::map<std::size_t, RefitState>& refits,
                 std::span<const Triangle> first, CsvWriter& csv) {
    check_interrupt();
    std::vector<FrameJob> jobs;
    for (std::size_t i = 0; i < builders_.size(); ++i) {
      if (!any_wanted(frame, builders_[i], threads)) continue;
      const auto refit = refits.find(i);
      jobs.push_back(
          make_job(frame, builders_[i], threads, refit == refits.end() ? nullptr : &refit->second, first));
    }
    // Interleaved: every job of the frame in turns. Otherwise one job at a time, so that one tree is in
    // memory at a time and its rows are written at once (Repetitions::interleave).
    if (cfg_.reps.interleave) {
      measure(frame, threads, jobs, csv);
    } else {
      for (FrameJob& job : jobs) {
        measure(frame, threads, {&job, 1}, csv);
        job = FrameJob{};  // its tree or Embree scene freed before the next is built
      }
    }
  }

  void measure(const FrameData& frame, int threads, std::span<FrameJob> jobs, CsvWriter& csv) {
    std::vector<TreeSource*> sources;
    for (auto& job : jobs) sources.push_back(&job.source);
    const std::string group = fmt::format("{} frame {}", frame.scene.name, frame.index);
    const auto interrupt = [this] { check_interrupt(); };
    time_sources(sources, cfg_.reps, order_seed(cfg_.seed, group, threads, "build"), interrupt);
    std::vector<TraceCell> cells;
    for (const FrameJob& job : jobs) {
      if (job.embree)
        queue_embree(frame, job, threads, cells);
      else
        queue_ours(frame, job, threads, csv, cells);
    }
    time_cells(cells, cfg_.reps, order_seed(cfg_.seed, group, threads, "trace"), interrupt, {});
    progress_.batch(cells.size());
    for (auto& cell : cells) {
      finish_cell(cell, frame.references[cell.set_index], frame.diagonal);
      append(csv, cell.row, cell_summary(cell.label, cell.row));
    }
  }

  CsvRow base_row(const FrameData& frame, const FrameJob& job, int threads, const std::string& layout) const {
    const AnimatedBuilder& b = *job.builder;
    CsvRow row = common_row(id_, env_, cfg_, frame.scene, frame.index, b.name, b.params_text(), threads);
    row["frame_time"] = fmt::format("{:.6g}", frame.time);
    row["layout"] = layout;
    put_timing(row, "build_ms", job.source.time());
    return row;
  }

  std::string label(const FrameData& frame, const FrameJob& job, int threads, const std::string& layout,
                    const RaySet& rs) const {
    return fmt::format("{} f{} {} {} t={} {}", frame.scene.name, frame.index, job.builder->label, layout,
                       threads, rs.name);
  }

  // The layout `layout` of a refit cell, compiled the first time it is traced and kept in `state`
  // for the frames after: from the refitted tree, which has the first frame's topology, and at once
  // refitted to the frame's triangles. Layouts depend only on the tree's topology and the triangles, so
  // this is the first frame's layout refitted, whichever frame traces it first. The first refit also
  // makes bvh2 copy the tree it borrows, so that refitting the tree no longer moves the layout's boxes:
  // every later frame's layout_refit_ms is then the layout's own refit.
  CompiledLayout& refit_layout(RefitState& state, const CellLayout& layout,
                               std::span<const Triangle> triangles) {
    std::unique_ptr<CompiledLayout>& compiled = state.layouts[layout.name];
    if (!compiled) {
      compiled = compile_layout(*layout.ours, state.tree, triangles);
      compiled->refit(triangles);
    }
    return *compiled;
  }

  // Queues the cells of a tree of ours on `frame`, checked first. A rebuild is compiled into each layout,
  // timed into layout_ms; a refit's layouts are refitted in place (refit_layout), timed into
  // layout_refit_ms, and layout_ms is left empty (their one compile, of the first frame's tree, is the
  // rebuild's layout_ms on the first frame). An invalid tree's rows are written at once, untraced.
  void queue_ours(const FrameData& frame, const FrameJob& job, int threads, CsvWriter& csv,
                  std::vector<TraceCell>& cells) {
    const AnimatedBuilder& b = *job.builder;
    const Scene& scene = frame.scene;
    const Bvh& bvh = job.refit ? job.refit->tree : *job.tree;
    const CheckedTree checked = check_tree(bvh, scene.triangles, b.run->values, cfg_.epo);
    if (!checked.ok()) {
      exit_code_ = 1;
      log_ << fmt::format("INVALID tree from {} on {} frame {}:\n{}", b.label, scene.name, frame.index,
                          checked.report.summary());
    }
    for (const CellLayout& layout : layouts_for(b)) {
      std::vector<std::size_t> sets;
      for (std::size_t s = 0; s < frame.sets.size(); ++s)
        if (wanted(scene.name, b, layout.name, threads, frame.sets[s].name, frame.index)) sets.push_back(s);
      if (sets.empty()) continue;
      auto row_for = [&](const RaySet& rs) {
        CsvRow row = base_row(frame, job, threads, layout.name);
        put_ray_set(row, rs);
        if (job.refit) add_note(row, "tree and layout of frame 0 refitted");
        if (job.refit && bvh.prim_refs.size() > scene.triangles.size()) add_note(row, kRefitOfSplitsNote);
        return row;
      };
      if (!checked.ok()) {
        for (const std::size_t s : sets) {
          CsvRow row = row_for(frame.sets[s]);
          row["isa"] = env_.isa;
          put_invalid_tree(row, bvh, checked.report);
          append(csv, row,
                 label(frame, job, threads, layout.name, frame.sets[s]) + ": INVALID tree, not traced");
        }
        continue;
      }
      std::shared_ptr<const CompiledLayout> compiled;
      TimingSummary layout_t;
      if (job.refit) {
        CompiledLayout& kept = refit_layout(*job.refit, layout, scene.triangles);
        TreeSource layout_refit;
        layout_refit.make = [&] { return time_ms([&] { kept.refit(scene.triangles); }); };
        TreeSource* one = &layout_refit;
        time_sources({&one, 1}, cfg_.reps, 0, [this] { check_interrupt(); });
        layout_t = layout_refit.time();
        compiled =
            std::shared_ptr<const CompiledLayout>(std::shared_ptr<void>(), &kept);  // the state owns it
      } else {
        TimedCompile timed = compile_timed(*layout.ours, bvh, scene.triangles, cfg_.reps);
        layout_t = timed.time;
        // The layout borrows the tree (bvh2 as built): the cells keep both alive.
        auto owner = std::make_shared<std::pair<std::shared_ptr<Bvh>, std::unique_ptr<CompiledLayout>>>(
            job.tree, std::move(timed.layout));
        compiled = std::shared_ptr<const CompiledLayout>(owner, owner->second.get());
      }
      for (const std::size_t s : sets) {
        const RaySet& rs = frame.sets[s];
        CsvRow row = row_for(rs);
        row[job.refit ? "layout_refit_ms" : "layout_ms"] = fmt::format("{:.4f}", layout_t.median);
        if (!job.refit) put_build_layout_ms(row, job.source.time(), layout_t);
        put_our_layout(row, *compiled, bvh, checked, scene.triangles.size(), job.source.peak);
        cells.push_back(our_cell(std::move(row), label(frame, job, threads, layout.name, rs), compiled, rs, s,
                                 checked.cost));
      }
    }
  }

  // Queues a cell per supported Embree layout and wanted ray set of an Embree build or refit.
  void queue_embree(const FrameData& frame, const FrameJob& job, int threads, std::vector<TraceCell>& cells) {
    const AnimatedBuilder& b = *job.builder;
    const bool refit = b.variant == Variant::kEmbreeRefit;
    for (const auto& layout : layouts_.embree) {
      for (std::size_t s = 0; s < frame.sets.size(); ++s) {
        const RaySet& rs = frame.sets[s];
        if (!wanted(frame.scene.name, b, layout.name, threads, rs.name, frame.index)) continue;
        CsvRow row = base_row(frame, job, threads, layout.name);
        if (!refit) put_build_layout_ms(row, job.source.time(), {});
        put_embree_scene(row, *job.embree->scene, job.embree->device, frame.scene.triangles.size(),
                         job.source.peak);
        if (refit) add_note(row, "Embree refit of frame 0's build (dynamic scene, geometry quality refit)");
        cells.push_back(embree_cell(std::move(row), label(frame, job, threads, layout.name, rs),
                                    *job.embree->scene, layout, rs, s, job.embree));
      }
    }
  }

  // Per scene and thread count, one line per frame: for each of our builders and each of its layouts, the
  // refit's cost (tree refit + layout refit) against the rebuild's (build + layout compile) and their
  // ratio, the refit tree's SAH cost relative to the rebuild's, and Embree's refit time.
  void print_summary() const {
    struct Cell {
      std::optional<double> build_ms, sah;
      std::map<std::string, double> layout_ms;  // by layout: the compile (rebuild) or the layout refit
    };
    // (scene, threads) -> frame -> builder name + params -> first row's figures (build time and SAH
    // are the same in every layout and ray-set row of a tree, layout times in every ray-set row).
    std::map<std::pair<std::string, int>, std::map<int, std::map<std::string, Cell>>> table;
    std::map<std::pair<std::string, int>, std::map<int, std::string>> frame_times;
    std::vector<std::pair<std::string, int>> order;
    for (const auto& row : rows_) {
      const auto key = std::make_pair(row.at("scene"), std::stoi(row.at("threads")));
      if (std::find(order.begin(), order.end(), key) == order.end()) order.push_back(key);
      const int frame = std::stoi(row.at("frame"));
      frame_times[key][frame] = row.at("frame_time");
      Cell& cell = table[key][frame][row.at("builder") + "|" + row.at("builder_params")];
      if (!cell.build_ms) cell.build_ms = csv_number(row, "build_ms_median");
      if (!cell.sah) cell.sah = csv_number(row, "sah_cost");
      for (const char* column : {"layout_ms", "layout_refit_ms"})
        if (const auto ms = csv_number(row, column)) cell.layout_ms.emplace(row.at("layout"), *ms);
    }
    // "TREE+LAYOUT" (the layout part only where the tree was traced), and the total.
    auto cost = [](const Cell& c, const std::string& layout) {
      const auto it = c.layout_ms.find(layout);
      if (it == c.layout_ms.end()) return std::make_pair(fmt::format("{:.3f}", *c.build_ms), *c.build_ms);
      return std::make_pair(fmt::format("{:.3f}+{:.3f}", *c.build_ms, it->second), *c.build_ms + it->second);
    };
    for (const auto& key : order) {
      log_ << fmt::format(
          "\nsummary: {}, {} thread{} (median ms; refit = tree refit + layout refit, rebuild = build + "
          "layout compile; speed-up = rebuild / refit; SAH = refit / rebuild)\n",
          key.first, key.second, key.second == 1 ? "" : "s");
      for (const auto& [frame, cells] : table.at(key)) {
        std::string line = fmt::format("  frame {:>3} t={:<8}", frame, frame_times.at(key).at(frame));
        for (const auto& b : builders_) {
          if (b.variant != Variant::kRefit && b.variant != Variant::kEmbreeRefit) continue;
          const auto refit_cell = cells.find(b.name + "|" + b.params_text());
          if (refit_cell == cells.end() || !refit_cell->second.build_ms) continue;
          const Cell& r = refit_cell->second;
          if (b.variant == Variant::kEmbreeRefit) {
            line += fmt::format(" | embree refit {:.3f}", *r.build_ms);
            continue;
          }
          const auto rebuild_cell = cells.find(b.run->name + "|" + b.params_text());
          const Cell* k =
              rebuild_cell != cells.end() && rebuild_cell->second.build_ms ? &rebuild_cell->second : nullptr;
          line += " | " + b.label;
          if (k && r.sah && k->sah && *k->sah > 0) line += fmt::format(" SAH {:.3f}", *r.sah / *k->sah);
          // A tree not traced in any layout (invalid) has its refit time alone.
          if (r.layout_ms.empty()) line += fmt::format(" refit {:.3f}", *r.build_ms);
          for (const CellLayout& cell_layout : layouts_for(b)) {
            const std::string& layout = cell_layout.name;
            if (!r.layout_ms.count(layout)) continue;  // not traced in this frame (--only, invalid tree)
            const auto [refit_text, refit_ms] = cost(r, layout);
            line += fmt::format(", {}: refit {}", layout, refit_text);
            if (!k) continue;
            const auto [rebuild_text, rebuild_ms] = cost(*k, layout);
            line += fmt::format(" rebuild {} ({:.1f}x)", rebuild_text, rebuild_ms / std::max(refit_ms, 1e-9));
          }
        }
        log_ << line << "\n";
      }
    }
  }

  const ExperimentConfig& cfg_;
  const RunOptions& options_;
  std::ostream& log_;
  Environment env_;
  std::vector<AnimatedBuilder> builders_;
  RunLayouts layouts_;
  std::filesystem::path output_;
  std::string continue_with_;  // the command that resumes this run, for the interrupt message
  RunIdentity id_;
  std::set<std::string> finished_;
  std::vector<CsvRow> rows_;  // written by this run, for the summary
  Progress progress_{0, log_};
  int exit_code_ = 0;
};

}  // namespace

std::vector<std::string> animation_columns() {
  std::vector<std::string> columns = result_columns();
  columns.insert(std::find(columns.begin(), columns.end(), "layout_ms") + 1, "layout_refit_ms");
  columns.push_back("frame_time");
  return columns;
}

int run_animation_experiment(const ExperimentConfig& cfg, const RunOptions& options, std::ostream& log) {
  if (!cfg.animation) throw Error(cfg.path.string() + ": not an animation experiment (no [animation] table)");
  for (const BuilderRun& run : cfg.builders) require_resolved(run);
  return AnimationRunner(cfg, options, log).run();
}

}  // namespace sahbench
