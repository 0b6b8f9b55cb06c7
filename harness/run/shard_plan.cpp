#include "harness/run/shard_plan.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <numeric>

#include "core/error.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "scenes/scene_path.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

// The model's constants are orders of magnitude for one core of a current x86 CPU, not measurements to
// rely on: only their ratios decide which cells go together, and `sahbench plan` scales the total by a
// build it times. A binned SAH build costs about this much per triangle (Wald 2007 reports builds of
// millions of triangles per second per core).
constexpr double kBuildNsPerTriangle = 200.0;
// A layout compile walks the tree once: a small share of a build.
constexpr double kCompileShareOfBuild = 0.1;
// One traversal step (a node or a triangle test) of a ray; a ray takes about log2(n) of them, times this
// factor for the nodes and triangles visited at each level.
constexpr double kTraceNsPerStep = 10.0;
constexpr double kStepsPerLevel = 4.0;
// Loading or generating a scene, per triangle (parse, filter, bounds).
constexpr double kLoadNsPerTriangle = 100.0;
// A brute-force reference hit tests every triangle per ray (reference.h).
constexpr double kBruteForceNsPerTest = 3.0;
// A scene file holds about this many bytes per triangle (float positions shared by about two triangles,
// three 32-bit indices), for the size of a scene that no shard loads to plan.
constexpr double kFileBytesPerTriangle = 32.0;

// Builders' costs relative to binned SAH's: spatial splits clip and re-bin references (Stich et al.
// 2009), a full sweep sorts and scans every axis (MacDonald and Booth 1990), the optimisers and
// agglomerative builders do several passes over a built tree, LBVH is a sort (Karras 2012), the wide
// collapse builds a fine binned source and reinserts it by default. Embree's builders are tuned SIMD code.
double relative_build_cost(const BuilderRun& run) {
  if (run.is_embree())
    return run.quality == EmbreeQuality::kHigh ? 1.0 : run.quality == EmbreeQuality::kLow ? 0.2 : 0.4;
  static const std::map<std::string, double, std::less<>> known = {
      {"binned_sah", 1.0}, {"wide_binned_sah", 1.2}, {"sweep_sah", 3.0},
      {"sbvh", 4.0},       {"wide_sbvh", 4.0},       {"lbvh", 0.3},
      {"ploc", 1.5},       {"wide_collapse", 2.5}};
  const auto it = known.find(run.name);
  return it == known.end() ? 2.0 : it->second;  // passes over a source tree (reinsertion, treelets)
}

// The children per node of the tree a layout traces: our layouts' registered arity; Embree's layouts trace
// its 8-wide BVH where the CPU has AVX2 (4-wide without; the model takes 8).
int layout_arity(const std::string& layout) {
  const std::string name = layout.substr(0, layout.find(':'));
  return name.starts_with("embree") ? 8 : static_cast<int>(find_layout(name).arity);
}

bool uses_brute_force(const ExperimentConfig& cfg, double triangles) {
  return cfg.reference == ReferencePolicy::kBruteForce ||
         (cfg.reference == ReferencePolicy::kAuto &&
          triangles <= static_cast<double>(cfg.brute_force_max_triangles));
}

}  // namespace

ShardSpec parse_shard_spec(std::string_view text) {
  const auto bad = [&](const std::string& why) {
    return Error(fmt::format("--shard '{}': {}; expected K/N with 0 <= K < N, e.g. 0/4", text, why));
  };
  const std::size_t slash = text.find('/');
  if (slash == std::string_view::npos) throw bad("no '/'");
  ShardSpec spec;
  const auto number = [&](std::string_view part, int& out) {
    const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), out);
    if (part.empty() || ec != std::errc() || end != part.data() + part.size())
      throw bad("'" + std::string(part) + "' is not a whole number");
  };
  number(text.substr(0, slash), spec.index);
  number(text.substr(slash + 1), spec.count);
  if (spec.count < 1) throw bad("N must be at least 1");
  if (spec.index < 0 || spec.index >= spec.count) throw bad("K must lie in 0..N-1");
  return spec;
}

std::filesystem::path shard_output_path(const std::filesystem::path& output, const ShardSpec& shard) {
  std::filesystem::path out = output;
  out.replace_filename(fmt::format("{}-shard-{}-of-{}{}", output.stem().string(), shard.index, shard.count,
                                   output.extension().string()));
  return out;
}

SceneSize scene_size(const std::string& scene) {
  if (is_procedural_spec(scene))
    return {static_cast<double>(parse_proc_spec(scene, procedural_kinds()).integer("tris")), true};
  std::filesystem::path file = scene;
  if (!std::filesystem::is_regular_file(file)) {
    const auto found = find_scene_file(scene);
    if (!found) return {};
    file = *found;
  }
  // A .gltf keeps its geometry in the buffers beside it.
  std::uintmax_t bytes = 0;
  std::error_code ec;
  if (file.extension() == ".gltf") {
    for (const auto& entry : std::filesystem::directory_iterator(file.parent_path(), ec))
      if (entry.is_regular_file()) bytes += entry.file_size();
  } else {
    bytes = std::filesystem::file_size(file, ec);
  }
  return {static_cast<double>(bytes) / kFileBytesPerTriangle, false};
}

double ray_count(const RaySetConfig& rs) {
  return rs.count > 0 ? rs.count : static_cast<double>(rs.width) * rs.height;
}

double build_cost(const ExperimentConfig& cfg, const BuilderRun& run, double triangles, int threads,
                  std::size_t layouts) {
  const double one = triangles * kBuildNsPerTriangle * relative_build_cost(run);
  // Builds scale with threads, but not perfectly (the top levels are serial): the square root is between.
  const double builds = (cfg.reps.build_warmup + cfg.reps.build) * one / std::sqrt(std::max(threads, 1));
  const double compiles = run.is_embree() ? 0.0
                                          : static_cast<double>(layouts) * std::max(1, cfg.reps.build) *
                                                triangles * kBuildNsPerTriangle * kCompileShareOfBuild;
  return builds + compiles;
}

double trace_cost(const ExperimentConfig& cfg, double triangles, double rays, int threads, int arity) {
  // A wide node is tested in one SIMD pass, about as long as a binary node's step: the cost is per level.
  const double levels = std::log2(std::max(triangles, 2.0)) / std::log2(std::max(arity, 2));
  const double per_ray = kTraceNsPerStep * kStepsPerLevel * levels;
  return (cfg.reps.trace_warmup + cfg.reps.trace + 1) * rays * per_ray / std::max(threads, 1);
}

double scene_cost(const ExperimentConfig& cfg, double triangles) {
  double rays = 0;
  for (const auto& rs : cfg.ray_sets) rays += ray_count(rs);
  const double reference = uses_brute_force(cfg, triangles) ? rays * triangles * kBruteForceNsPerTest
                                                            : trace_cost(cfg, triangles, rays, 1, 2) / 4;
  return triangles * kLoadNsPerTriangle + reference;
}

std::set<std::string> ShardPlan::keys_of(int k) const {
  std::set<std::string> out;
  for (std::size_t i = 0; i < cells.size(); ++i)
    if (owns(i, k)) out.insert(cells[i].key);
  return out;
}

bool ShardPlan::owns(std::size_t i, int k) const {
  return std::binary_search(owners[i].begin(), owners[i].end(), k);
}

ShardPlan plan_shards(const ExperimentConfig& cfg, const std::vector<std::string>& scenes,
                      const RunLayouts& layouts, int shards) {
  if (shards < 1) throw Error(fmt::format("{} shards: at least 1", shards));
  ShardPlan plan;
  plan.shards = shards;
  plan.scenes = scenes;
  plan.cells = static_cells(cfg, scenes, layouts);
  plan.owners.resize(plan.cells.size());
  plan.cost.assign(static_cast<std::size_t>(shards), 0.0);
  std::map<std::string, double> triangles;
  for (const auto& scene : scenes) {
    plan.sizes.push_back(scene_size(scene));
    triangles[scene] = plan.sizes.back().triangles;
  }
  std::map<std::string, double> rays;
  for (const auto& rs : cfg.ray_sets) rays[rs.name] = ray_count(rs);

  // Groups (scene, threads), each with its anchor cells and their cost, and its units; in plan order.
  struct Group {
    std::string scene;
    int threads;
    std::vector<std::size_t> anchors;
    double setup = 0;  // scene cost plus the anchors' build and traces
    std::vector<std::size_t> units;
  };
  std::vector<Group> groups;
  std::map<std::pair<std::string, int>, std::size_t> group_of;
  std::map<std::tuple<std::string, int, std::size_t>, std::size_t> unit_of;
  for (std::size_t i = 0; i < plan.cells.size(); ++i) {
    const PlannedCell& c = plan.cells[i];
    auto [g, new_group] = group_of.try_emplace({c.scene, c.threads}, groups.size());
    if (new_group) groups.push_back({c.scene, c.threads, {}, scene_cost(cfg, triangles[c.scene]), {}});
    Group& group = groups[g->second];
    const double trace =
        trace_cost(cfg, triangles[c.scene], rays[c.ray_set], c.threads, layout_arity(c.layout));
    if (is_anchor_cell(cfg, c)) {
      if (group.anchors.empty())
        group.setup += build_cost(cfg, cfg.builders[c.builder], triangles[c.scene], c.threads, 1);
      group.anchors.push_back(i);
      group.setup += trace;
      continue;
    }
    auto [u, new_unit] = unit_of.try_emplace({c.scene, c.threads, c.builder}, plan.units.size());
    if (new_unit) {
      std::set<std::string> layouts;
      for (const auto& d : plan.cells)
        if (d.scene == c.scene && d.builder == c.builder) layouts.insert(d.layout);
      plan.units.push_back(
          {c.scene,
           c.threads,
           c.builder,
           {},
           build_cost(cfg, cfg.builders[c.builder], triangles[c.scene], c.threads, layouts.size()),
           0});
      group.units.push_back(u->second);
    }
    plan.units[u->second].cells.push_back(i);
    plan.units[u->second].cost += trace;
  }
  // A group of anchors only (a config of Embree alone) is a unit of its own.
  for (Group& group : groups)
    if (group.units.empty() && !group.anchors.empty()) {
      group.units.push_back(plan.units.size());
      plan.units.push_back(
          {group.scene, group.threads, plan.cells[group.anchors.front()].builder, group.anchors, 0, 0});
      group.anchors.clear();
    }
  std::vector<std::size_t> unit_group(plan.units.size());
  for (std::size_t g = 0; g < groups.size(); ++g)
    for (const std::size_t u : groups[g].units) unit_group[u] = g;

  // Longest processing time first; a shard new to a group pays its setup (scene and anchors) too.
  std::vector<std::size_t> order(plan.units.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return plan.units[a].cost > plan.units[b].cost; });
  std::vector<std::set<std::size_t>> groups_of_shard(static_cast<std::size_t>(shards));
  for (const std::size_t u : order) {
    const std::size_t g = unit_group[u];
    int best = 0;
    double best_total = 0;
    for (int k = 0; k < shards; ++k) {
      const auto ks = static_cast<std::size_t>(k);
      const double total =
          plan.cost[ks] + plan.units[u].cost + (groups_of_shard[ks].count(g) ? 0.0 : groups[g].setup);
      if (k == 0 || total < best_total) best = k, best_total = total;
    }
    plan.units[u].shard = best;
    plan.cost[static_cast<std::size_t>(best)] = best_total;
    groups_of_shard[static_cast<std::size_t>(best)].insert(g);
    for (const std::size_t i : plan.units[u].cells) plan.owners[i].push_back(best);
  }
  std::vector<PlanUnit> assigned;
  for (const std::size_t u : order) assigned.push_back(plan.units[u]);
  plan.units = std::move(assigned);
  for (int k = 0; k < shards; ++k)
    for (const std::size_t g : groups_of_shard[static_cast<std::size_t>(k)])
      for (const std::size_t i : groups[g].anchors) plan.owners[i].push_back(k);
  for (auto& o : plan.owners) std::sort(o.begin(), o.end());
  return plan;
}

}  // namespace sahbench
