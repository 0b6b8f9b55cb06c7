#pragma once
// What `sahbench run` is asked to do beyond its config: every experiment plan (static, animation) takes
// these.

#include <filesystem>
#include <optional>
#include <string>

namespace sahbench {

/// Shard K of N (0 <= K < N) of a static experiment's cells (shard_plan.h): "K/N" on the command line,
/// K counted from 0 like a Slurm array's SLURM_ARRAY_TASK_ID.
struct ShardSpec {
  int index = 0;
  int count = 1;
  /// "K/N", the rows' shard column.
  std::string text() const { return std::to_string(index) + "/" + std::to_string(count); }
  bool operator==(const ShardSpec&) const = default;
};

struct RunOptions {
  std::filesystem::path config;
  bool resume = false;  ///< continue the run of the same fingerprint in the output CSV (run_session.h)
  std::string only;     ///< run only cells whose key contains this text (cell_key, result_row.h)
  std::optional<std::filesystem::path> output;    ///< overrides the config's output path
  std::optional<ShardSpec> shard = std::nullopt;  ///< run only this shard of the static plan
};

}  // namespace sahbench
