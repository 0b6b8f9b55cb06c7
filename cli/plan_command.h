#pragma once
// `sahbench plan CONFIG [--shards N]`: what `run` would measure and how a sweep splits into shards
// (harness/run/shard_plan.h): cells per scene, builder and layout; each shard's cells, anchors and
// estimated time; and, with --cells, every cell with the shards that run it.

#include <filesystem>
#include <iosfwd>

namespace sahbench {

struct PlanCommandOptions {
  std::filesystem::path config;
  int shards = 1;
  bool list_cells = false;  ///< print every cell key with its shards
  bool calibrate = true;    ///< time a short build to turn the model's cost into seconds
};

void run_plan_command(const PlanCommandOptions& options, std::ostream& out, std::ostream& log);

}  // namespace sahbench
