#pragma once
// What `sahbench run` is asked to do beyond its config: every experiment plan (static, animation) takes
// these.

#include <filesystem>
#include <optional>
#include <string>

namespace sahbench {

struct RunOptions {
  std::filesystem::path config;
  bool resume = false;  ///< continue the run of the same fingerprint in the output CSV (run_session.h)
  std::string only;     ///< run only cells whose key contains this text (cell_key, result_row.h)
  std::optional<std::filesystem::path> output;  ///< overrides the config's output path
};

}  // namespace sahbench
