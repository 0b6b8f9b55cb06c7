#pragma once
// Shards of a static experiment, for running one sweep as N independent processes (a Slurm job array, a
// CI matrix) and merging their CSVs into one run (shard_merge.h). A shard is a filter on the static plan
// (static_plan.h): the unit of assignment is one builder run's cells of one scene and thread count, so
// that each tree is built once in the whole sweep; and every shard that measures a scene and thread count
// also runs Embree's anchor cells for them, so that every ratio to Embree stays same-run and same-node.
// The assignment comes from a deterministic cost model (scene sizes, repetitions, rays), never from
// timings, so that every shard of a sweep computes the same plan on its own.

#include <cstddef>
#include <filesystem>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "harness/config/config.h"
#include "harness/embree/embree_layouts.h"
#include "harness/run/run_options.h"
#include "harness/run/static_plan.h"

namespace sahbench {

/// "K/N" with 0 <= K < N: a ShardSpec. Anything else is an Error naming the text.
ShardSpec parse_shard_spec(std::string_view text);

/// Where a shard writes by default: the config's output with "-shard-K-of-N" before the extension
/// (results/ci.csv -> results/ci-shard-0-of-4.csv), so the shards of a sweep never share a file.
std::filesystem::path shard_output_path(const std::filesystem::path& output, const ShardSpec& shard);

/// The triangle count the cost model assumes for `scene`: a procedural spec's `tris`; a file's size
/// over kFileBytesPerTriangle (a mesh file holds about that much per triangle), so that no shard needs
/// to load every scene to plan. `exact` is false for the file estimate.
struct SceneSize {
  double triangles = 0;
  bool exact = false;
};
SceneSize scene_size(const std::string& scene);

/// The cost model, in estimated nanoseconds on one core before calibration. Only the ratios decide the
/// assignment; `sahbench plan` scales the sum by a short measured build to print seconds.
/// One builder run's builds (warm-ups and timed rounds) and its layout compiles on `triangles`.
double build_cost(const ExperimentConfig& cfg, const BuilderRun& run, double triangles, int threads,
                  std::size_t layouts);
/// One cell's traces: warm-ups, timed rounds and the counting pass over `rays` rays, on `threads`
/// threads (rays are independent, so a trace divides among them, unlike a build's serial top levels),
/// through a tree of `arity` children per node (a ray visits about log2(n) / log2(arity) levels).
double trace_cost(const ExperimentConfig& cfg, double triangles, double rays, int threads, int arity);
/// A scene's fixed cost in every shard that measures it: loading, ray generation and the reference hits.
double scene_cost(const ExperimentConfig& cfg, double triangles);
/// The rays of a ray set as the model counts them (a secondary set at most one per primary pixel).
double ray_count(const RaySetConfig& rs);

/// The cells that go to one shard together: one builder run's non-anchor cells of one scene and thread
/// count (the anchors are copied to every shard of that scene and thread count instead).
struct PlanUnit {
  std::string scene;
  int threads = 1;
  std::size_t builder = 0;         ///< index into ExperimentConfig::builders
  std::vector<std::size_t> cells;  ///< indices into ShardPlan::cells
  double cost = 0;                 ///< build_cost plus the cells' trace_cost
  int shard = 0;
};

struct ShardPlan {
  int shards = 1;
  std::vector<PlannedCell> cells;        ///< the static plan (static_cells), in its order
  std::vector<std::vector<int>> owners;  ///< per cell: the shards that run it, ascending
  std::vector<PlanUnit> units;           ///< in the order assigned (largest first)
  std::vector<double> cost;              ///< per shard: model cost, scenes and anchors included
  std::vector<std::string> scenes;       ///< as given to plan_shards
  std::vector<SceneSize> sizes;          ///< per scene

  /// Keys (cell_key) of the cells shard `k` runs.
  std::set<std::string> keys_of(int k) const;
  /// Whether shard `k` runs cell `i`.
  bool owns(std::size_t i, int k) const;
};

/// Assigns the cells of `cfg` over `scenes` to `shards` shards: units in order of decreasing cost (ties in
/// plan order), each to the shard whose cost grows least, where a shard new to the unit's scene and
/// thread count also pays that group's scene cost and anchor cells (longest processing time first,
/// Graham 1969, with the shared setup counted). The same inputs give the same plan on every machine.
ShardPlan plan_shards(const ExperimentConfig& cfg, const std::vector<std::string>& scenes,
                      const RunLayouts& layouts, int shards);

}  // namespace sahbench
