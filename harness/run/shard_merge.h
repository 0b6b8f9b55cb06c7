#pragma once
// `sahbench merge OUT.csv SHARD.csv...`: the CSVs of a sweep's shards (shard_plan.h) made into one run.
// The shards must share one run fingerprint and count, and together hold every cell of the plan exactly
// once (each anchor cell once in every shard that measures its scene and thread count); anything else is
// an Error that names the missing or duplicated cells and shards. The merged rows get one run id, so
// that `report` and `compare` read them like a single run, and keep their `shard` column, by which those
// pair every row with its own shard's Embree anchor (same run, same node).

#include <cstddef>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace sahbench {

struct MergeOptions {
  std::filesystem::path output;
  std::vector<std::filesystem::path> shards;
  /// The config the shards ran; by default the one their rows name (column `config`), read relative
  /// to the current directory as `run` was.
  std::optional<std::filesystem::path> config;
};

struct MergeSummary {
  std::string run_id;  ///< of the merged rows
  int shards = 0;      ///< the sweep's N
  std::size_t rows = 0;
};

/// Checks the shards against the plan and writes the merged CSV (replacing `output`, which must not be
/// one of the shards); progress and notes go to `log`.
MergeSummary merge_shards(const MergeOptions& options, std::ostream& log);

}  // namespace sahbench
