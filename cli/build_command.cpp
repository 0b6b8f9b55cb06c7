#include "cli/build_command.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <memory>
#include <optional>
#include <ostream>

#include "builders/registry.h"
#include "core/bvh_stats.h"
#include "core/error.h"
#include "core/validate.h"
#include "harness/embree/embree_scene.h"
#include "harness/run/environment.h"
#include "harness/run/timing.h"
#include "scenes/load.h"

namespace sahbench {
namespace {

// One builder of the run, resolved, with its samples for the current thread count.
struct Candidate {
  BuilderRun run;
  const BuilderInfo* info = nullptr;  // ours; null for Embree
  ParamSet params;
  std::optional<EmbreeQuality> embree_quality;
  std::vector<double> samples_ms;
  Bvh last_tree;
  int64_t embree_bytes = 0;

  std::string label() const { return info ? run.name : "embree_" + to_string(*embree_quality); }
  std::string params_text() const {
    return info ? params.to_string() : "quality=" + to_string(*embree_quality);
  }
};

std::vector<Candidate> candidates_of(const BuildCommandOptions& options) {
  std::vector<Candidate> out;
  for (const BuilderRun& run : options.builders) {
    Candidate c;
    c.run = run;
    if (run.is_embree()) {
      c.embree_quality = parse_embree_quality(run.params.front().second);
    } else {
      // --param applies to every builder run, before the run's own parameters.
      BuilderRun with_globals = run;
      with_globals.params = options.params;
      with_globals.params.insert(with_globals.params.end(), run.params.begin(), run.params.end());
      sahbench::resolve(with_globals);
      c.info = with_globals.info;
      c.params = with_globals.values;
    }
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace

int run_build_command(const BuildCommandOptions& options, std::ostream& out, std::ostream& log) {
  if (options.reps < 1) throw Error("--reps must be at least 1 (got " + std::to_string(options.reps) + ")");
  if (options.builders.empty()) throw Error("no builder given (--builder NAME)");
  for (int t : options.threads)
    if (t < 1) throw Error("--threads: " + std::to_string(t) + " is not a thread count");
  std::vector<Candidate> candidates = candidates_of(options);

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
  fmt::print(out, "{:>7} {:<16} {:<46} {:>10} {:>21} {:>8} {:>8} {:>8} {:>6} {:>6} {:>9} {:>12} {}\n",
             "threads", "builder", "params", "build_ms", "[min, max]", "vs_emb_m", "nodes", "leaves", "depth",
             "leaf", "sah", "bytes", "valid");

  int exit_code = 0;
  for (int threads : options.threads) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(threads));
    std::unique_ptr<EmbreeDevice> device;
    for (auto& c : candidates) c.samples_ms.clear();

    auto build_once = [&](Candidate& c) -> double {
      if (c.embree_quality) {
        if (!device) device = std::make_unique<EmbreeDevice>(threads);
        EmbreeScene built(*device, scene.triangles, *c.embree_quality);
        c.embree_bytes = built.bytes();
        return built.commit_ms();
      }
      return time_ms([&] {
        const BuildInput input = BuildInput::from_triangles(scene.triangles);
        c.last_tree = c.info->build(input, c.params);
      });
    };
    for (int w = 0; w < options.warmup; ++w)
      for (auto& c : candidates) build_once(c);
    // On a terminal the progress line is rewritten in place; in a log file each repetition gets a line.
    const bool terminal = isatty(STDERR_FILENO) != 0;
    for (int rep = 0; rep < options.reps; ++rep) {
      for (auto& c : candidates) c.samples_ms.push_back(build_once(c));
      log << (terminal ? "\r" : "") << "threads " << threads << ": rep " << rep + 1 << " of " << options.reps
          << (terminal ? "" : "\n") << std::flush;
    }
    if (terminal) log << "\r" << std::string(40, ' ') << "\r" << std::flush;

    std::optional<double> embree_medium_ms;
    for (const auto& c : candidates)
      if (c.embree_quality == EmbreeQuality::kMedium) embree_medium_ms = summarize(c.samples_ms).median;

    for (const auto& c : candidates) {
      const TimingSummary t = summarize(c.samples_ms);
      const std::string ratio = embree_medium_ms ? fmt::format("{:.2f}", t.median / *embree_medium_ms) : "-";
      const std::string spread = fmt::format("[{:.2f}, {:.2f}]", t.min, t.max);
      if (c.embree_quality) {
        fmt::print(out,
                   "{:>7} {:<16} {:<46} {:>10.2f} {:>21} {:>8} {:>8} {:>8} {:>6} {:>6} {:>9} {:>12} {}\n",
                   threads, c.label(), c.params_text(), t.median, spread, ratio, "-", "-", "-", "-", "-",
                   c.embree_bytes, "-");
        continue;
      }
      const BvhStats s = compute_stats(c.last_tree, scene.triangles.size(), sah_cost_of(c.params));
      const ValidationReport report = validate(c.last_tree, std::span<const Triangle>(scene.triangles));
      if (!report.ok()) exit_code = 1;
      fmt::print(out,
                 "{:>7} {:<16} {:<46} {:>10.2f} {:>21} {:>8} {:>8} {:>8} {:>6} {:>6.2f} {:>9.3f} {:>12} {}\n",
                 threads, c.label(), c.params_text(), t.median, spread, ratio, s.nodes, s.leaves, s.max_depth,
                 s.mean_leaf_size, s.sah_cost, s.bytes, report.ok() ? "ok" : "INVALID");
      if (!report.ok()) log << c.label() << ": invalid tree:\n" << report.summary();
    }
  }
  return exit_code;
}

}  // namespace sahbench
