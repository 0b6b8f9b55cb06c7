#include "cli/build_command.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>
#include <ostream>

#include "builders/registry.h"
#include "core/bvh_stats.h"
#include "core/error.h"
#include "core/text_file.h"
#include "core/validate.h"
#include "harness/embree/embree_scene.h"
#include "harness/run/cell_pipeline.h"
#include "harness/run/environment.h"
#include "harness/run/round_order.h"
#include "harness/run/run_common.h"
#include "harness/run/timing.h"
#include "scenes/load.h"
#include "scenes/tree_file.h"

namespace sahbench {
namespace {

// The builder runs of the command, resolved: --param applies to each of ours, before the run's own
// parameters.
std::vector<BuilderRun> resolved_runs(const BuildCommandOptions& options) {
  std::vector<BuilderRun> out;
  for (BuilderRun run : options.builders) {
    if (!run.is_embree()) run.params.insert(run.params.begin(), options.params.begin(), options.params.end());
    resolve(run);
    out.push_back(std::move(run));
  }
  return out;
}

// "embree_medium" (or "embree_medium_robust") for Embree's run, the builder's name for ours.
std::string short_label(const BuilderRun& run) {
  if (!run.is_embree()) return run.name;
  return "embree_" + to_string(run.quality) + (run.robust ? "_robust" : "");
}

}  // namespace

int run_build_command(const BuildCommandOptions& options, std::ostream& out, std::ostream& log) {
  if (options.reps < 1) throw Error("--reps must be at least 1 (got " + std::to_string(options.reps) + ")");
  if (options.warmup < 0)
    throw Error("--warmup must be at least 0 (got " + std::to_string(options.warmup) + ")");
  if (options.builders.empty()) throw Error("no builder given (--builder NAME)");
  for (std::size_t i = 0; i < options.threads.size(); ++i) {
    const int t = options.threads[i];
    if (t < 1) throw Error("--threads: " + std::to_string(t) + " is not a thread count");
    // As a config's threads list: the same count twice would build and print everything twice.
    if (std::find(options.threads.begin(), options.threads.begin() + static_cast<std::ptrdiff_t>(i), t) !=
        options.threads.begin() + static_cast<std::ptrdiff_t>(i))
      throw Error("--threads lists " + std::to_string(t) + " twice");
  }
  warn_oversubscribed(options.threads, "warning: --threads ", "builds", log);
  const std::vector<BuilderRun> runs = resolved_runs(options);
  if (!options.save.empty()) {
    if (runs.size() != 1 || runs.front().is_embree())
      throw Error(
          "--save writes one tree: give exactly one builder that makes a tree of the common format "
          "(not embree, whose rtcCommitScene keeps its tree to itself)");
    require_file_path(options.save, "tree");
    if (std::filesystem::path(options.save).filename().empty())
      throw Error("--save " + options.save + ": give the path of a tree file, not of a folder");
    // The folder is made before the build, as `run --output` makes its own, so that a path that cannot
    // be written fails before minutes of building rather than after.
    const std::filesystem::path folder = std::filesystem::path(options.save).parent_path();
    std::error_code ec;
    if (!folder.empty()) std::filesystem::create_directories(folder, ec);
    if (ec) throw Error(options.save + ": cannot make its folder " + folder.string() + ": " + ec.message());
  }

  Scene scene;
  const double load_ms = time_ms([&] { scene = load_scene(options.scene); });
  const Environment env = current_environment();
  fmt::print(out,
             "# scene {} ({}): {} triangles, {} removed (non-finite {}, bad index {}, zero area {}), loaded "
             "in {:.1f} ms\n",
             scene.name, scene.source, scene.triangles.size(), scene.removed.total(),
             scene.removed.non_finite, scene.removed.bad_index, scene.removed.zero_area, load_ms);
  fmt::print(out, "# commit {} | cpu {} | isa {} | {} | {}\n", env.git_commit, env.cpu, env.isa, env.compiler,
             env.embree);
  fmt::print(
      out,
      "# build ms: median [min, max] of {} reps after {} warm-up, interleaved across builders; ours include\n"
      "#   per-primitive bounds, Embree's is rtcCommitScene alone\n",
      options.reps, options.warmup);
  fmt::print(out, "{:>7} {:<20} {:<46} {:>10} {:>21} {:>8} {:>8} {:>8} {:>6} {:>6} {:>9} {:>12} {}\n",
             "threads", "builder", "params", "build_ms", "[min, max]", "vs_emb_m", "nodes", "leaves", "depth",
             "leaf", "sah", "bytes", "valid");

  int exit_code = 0;
  for (int threads : options.threads) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(threads));
    // Every run a tree source of the cell pipeline, timed in the same interleaved, shuffled rounds.
    struct Job {
      std::shared_ptr<Bvh> tree;            // ours
      std::shared_ptr<EmbreeBuild> embree;  // Embree's
      TreeSource source;
    };
    std::vector<Job> jobs(runs.size());
    std::vector<TreeSource*> sources;
    for (std::size_t i = 0; i < runs.size(); ++i) {
      Job& job = jobs[i];
      if (runs[i].is_embree()) {
        job.embree = std::make_shared<EmbreeBuild>(threads);
        job.source = embree_build(runs[i].label(), job.embree, scene.triangles, runs[i].quality,
                                  runs[i].embree_options());
      } else {
        job.tree = std::make_shared<Bvh>();
        job.source = our_build(runs[i].label(), *runs[i].info, runs[i].values, scene.triangles, job.tree);
      }
      sources.push_back(&job.source);
    }
    Repetitions reps;
    reps.build = options.reps;
    reps.build_warmup = options.warmup;
    // On a terminal the progress line is rewritten in place; in a log file each repetition gets a line.
    const bool terminal = isatty(STDERR_FILENO) != 0;
    std::size_t made = 0;
    time_sources(sources, reps, order_seed(0, scene.name, threads, "build"), [&] {
      const std::size_t k = made++;
      if (k % sources.size() != 0) return;
      log << (terminal ? "\r" : "") << "threads " << threads << ": rep " << k / sources.size() + 1 << " of "
          << options.reps << (terminal ? "" : "\n") << std::flush;
    });
    if (terminal) log << "\r" << std::string(40, ' ') << "\r" << std::flush;

    std::optional<double> embree_medium_ms;
    for (std::size_t i = 0; i < runs.size(); ++i)
      if (runs[i].is_embree() && runs[i].quality == EmbreeQuality::kMedium && !runs[i].robust)
        embree_medium_ms = jobs[i].source.time().median;

    for (std::size_t i = 0; i < runs.size(); ++i) {
      const BuilderRun& run = runs[i];
      const TimingSummary t = jobs[i].source.time();
      const std::string ratio = embree_medium_ms ? fmt::format("{:.2f}", t.median / *embree_medium_ms) : "-";
      const std::string spread = fmt::format("[{:.2f}, {:.2f}]", t.min, t.max);
      if (run.is_embree()) {
        fmt::print(out,
                   "{:>7} {:<20} {:<46} {:>10.2f} {:>21} {:>8} {:>8} {:>8} {:>6} {:>6} {:>9} {:>12} {}\n",
                   threads, short_label(run), run.params_text(), t.median, spread, ratio, "-", "-", "-", "-",
                   "-", jobs[i].embree->scene->bytes(), "-");
        continue;
      }
      // The statistics of a valid tree only: compute_stats walks nodes[] unchecked.
      const CheckedTree tree = check_tree(*jobs[i].tree, scene.triangles, run.values, /*with_epo=*/false);
      if (!tree.ok()) {
        exit_code = 1;
        fmt::print(out,
                   "{:>7} {:<20} {:<46} {:>10.2f} {:>21} {:>8} {:>8} {:>8} {:>6} {:>6} {:>9} {:>12} {}\n",
                   threads, short_label(run), run.params_text(), t.median, spread, ratio, "-", "-", "-", "-",
                   "-", "-", "INVALID");
        log << short_label(run) << ": invalid tree:\n" << tree.report.summary();
        if (!options.save.empty()) log << "the tree is not saved to " << options.save << "\n";
        continue;
      }
      const BvhStats& s = tree.stats;
      fmt::print(out,
                 "{:>7} {:<20} {:<46} {:>10.2f} {:>21} {:>8} {:>8} {:>8} {:>6} {:>6.2f} {:>9.3f} {:>12} {}\n",
                 threads, short_label(run), run.params_text(), t.median, spread, ratio, s.nodes, s.leaves,
                 s.max_depth, s.mean_leaf_size, s.sah_cost, s.bytes, "ok");
      // Any thread count's tree: builders give the same tree for every one (DESIGN.md).
      if (!options.save.empty() && threads == options.threads.back()) {
        write_tree_file(options.save, *jobs[i].tree, scene.triangles);
        fmt::print(
            out, "# saved the tree to {} (arity {}, {} nodes, {} references; scene hash {}, {} triangles)\n",
            options.save, jobs[i].tree->arity, jobs[i].tree->nodes.size(), jobs[i].tree->prim_refs.size(),
            hash_text(triangle_hash(scene.triangles)), scene.triangles.size());
      }
    }
  }
  return exit_code;
}

}  // namespace sahbench
