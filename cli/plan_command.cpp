#include "cli/plan_command.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <map>
#include <memory>
#include <ostream>
#include <set>

#include "core/error.h"
#include "harness/config/config.h"
#include "harness/run/cell_pipeline.h"
#include "harness/run/run_common.h"
#include "harness/run/shard_plan.h"
#include "harness/run/timing.h"
#include "scenes/load.h"

namespace sahbench {
namespace {

// The calibration: a few binned SAH builds of a small generated scene, timed, against the model's cost
// of one such build. One scale for the whole model: it says how fast this machine is, not how the
// builders compare.
constexpr const char* kCalibrationScene = "proc:sphere:tris=20k";
constexpr int kCalibrationBuilds = 3;

double seconds_per_model_ns(std::ostream& log) {
  BuilderRun run = parse_builder_run("binned_sah");
  resolve(run);
  const Scene scene = load_scene(kCalibrationScene);
  auto tree = std::make_shared<Bvh>();
  TreeSource source = our_build("calibration", *run.info, run.values, scene.triangles, tree);
  std::vector<double> ms;
  source.make();  // warm-up
  for (int i = 0; i < kCalibrationBuilds; ++i) {
    if (source.release) source.release();
    ms.push_back(source.make());
  }
  const double measured_ms = summarize(ms).median;
  ExperimentConfig one;
  one.reps.build = 1;
  one.reps.build_warmup = 0;
  const double model_ns = build_cost(one, run, static_cast<double>(scene.triangles.size()), 1, 0);
  log << fmt::format(
      "calibration: binned_sah on {}: {:.1f} ms per build (median of {}), the model says "
      "{:.1f} ms\n",
      kCalibrationScene, measured_ms, kCalibrationBuilds, model_ns / 1e6);
  return measured_ms / 1e3 / model_ns;
}

}  // namespace

void run_plan_command(const PlanCommandOptions& options, std::ostream& out, std::ostream& log) {
  const ExperimentConfig cfg = load_experiment_config(options.config);
  if (cfg.animation)
    throw Error(
        fmt::format("{}: plan and --shard apply to static experiments; an animation runs as one "
                    "process",
                    cfg.path.string()));
  for (const BuilderRun& run : cfg.builders) require_resolved(run);
  const std::vector<std::string> scenes = scenes_to_run(cfg, log);
  const ShardPlan plan = plan_shards(cfg, scenes, runnable_layouts(cfg, log), options.shards);
  const double scale = options.calibrate ? seconds_per_model_ns(log) : 0.0;

  fmt::print(out, "# plan of {}: {} cells, {} scenes, {} shards\n\n", cfg.path.string(), plan.cells.size(),
             scenes.size(), plan.shards);
  fmt::print(out, "## Scenes\n\n| scene | triangles |\n|---|---:|\n");
  for (std::size_t s = 0; s < scenes.size(); ++s)
    fmt::print(out, "| {} | {}{:.0f} |\n", scenes[s], plan.sizes[s].exact ? "" : "~",
               plan.sizes[s].triangles);
  // Cells per scene, builder run and layout (thread counts and ray sets counted together).
  fmt::print(out,
             "\n## Cells per scene, builder and layout\n\n| scene | builder | layout | cells |\n"
             "|---|---|---|---:|\n");
  std::vector<std::tuple<std::string, std::size_t, std::string>> order;
  std::map<std::tuple<std::string, std::size_t, std::string>, std::size_t> count;
  for (const PlannedCell& c : plan.cells) {
    const auto key = std::make_tuple(c.scene, c.builder, c.layout);
    if (count[key]++ == 0) order.push_back(key);
  }
  for (const auto& key : order)
    fmt::print(out, "| {} | {} | {} | {} |\n", std::get<0>(key), cfg.builders[std::get<1>(key)].label(),
               std::get<2>(key), count[key]);

  fmt::print(out,
             "\n## Shards\n\n| shard | cells | anchor cells | scene x threads groups | model cost | "
             "estimated time |\n|---:|---:|---:|---:|---:|---:|\n");
  double longest = 0, total = 0;
  for (int k = 0; k < plan.shards; ++k) {
    std::size_t cells = 0, anchors = 0;
    std::set<std::pair<std::string, int>> groups;
    for (std::size_t i = 0; i < plan.cells.size(); ++i)
      if (plan.owns(i, k)) {
        ++cells;
        anchors += is_anchor_cell(cfg, plan.cells[i]);
        groups.insert({plan.cells[i].scene, plan.cells[i].threads});
      }
    const double cost = plan.cost[static_cast<std::size_t>(k)];
    longest = std::max(longest, cost);
    total += cost;
    fmt::print(out, "| {}/{} | {} | {} | {} | {:.3g} | {} |\n", k, plan.shards, cells, anchors, groups.size(),
               cost / 1e9, scale > 0 ? format_duration(cost * scale) : "-");
  }
  if (scale > 0)
    fmt::print(out,
               "\nEstimated: {} in all, the longest shard {} (the estimate is a cost model scaled by one "
               "timed build; expect it within a factor of two).\n",
               format_duration(total * scale), format_duration(longest * scale));

  fmt::print(out,
             "\n## Assignment\n\nEach builder run's cells of a scene and thread count go to one shard "
             "(its tree is built once); each shard with a scene and thread count also runs Embree's "
             "anchor cells for them.\n\n");
  for (int k = 0; k < plan.shards; ++k) {
    fmt::print(out, "- shard {}/{}:", k, plan.shards);
    bool any = false;
    for (const PlanUnit& u : plan.units)
      if (u.shard == k) {
        fmt::print(out, "{} {} t={} {} ({} cells)", any ? ";" : "", u.scene, u.threads,
                   cfg.builders[u.builder].label(), u.cells.size());
        any = true;
      }
    fmt::print(out, "{}\n", any ? "" : " nothing (more shards than units of work)");
  }
  if (options.list_cells) {
    fmt::print(out, "\n## Cells\n\n");
    for (std::size_t i = 0; i < plan.cells.size(); ++i)
      fmt::print(out, "{} -> {}\n", plan.cells[i].key, fmt::join(plan.owners[i], ","));
  }
}

}  // namespace sahbench
