#pragma once
// `sahbench run CONFIG`: expands an experiment config into cells (scene x builder run x layout x threads x
// ray set), measures each, and appends one CSV row per cell as soon as it finishes.

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace sahbench {

struct RunOptions {
  std::filesystem::path config;
  bool resume = false;  ///< skip cells whose row is already in the output CSV
  std::string only;     ///< run only cells whose key contains this text (see cell_key)
  std::optional<std::filesystem::path> output;  ///< overrides the config's output path
};

/// Runs the experiment (an animation experiment, with an [animation] table, through
/// run_animation_experiment). Returns 0, or 1 when a tree failed validation (its cells are still written,
/// with the failure in `notes`). Bad input throws sahbench::Error.
int run_experiment(const RunOptions& options, std::ostream& log);

/// The CSV columns of a run: DESIGN.md's, then config, seed, scene_source, scene_removed, query,
/// embree_version, notes.
std::vector<std::string> result_columns();

/// The key that identifies a cell, in the form `scene|builder|builder_params|layout|threads|ray_set|frame`,
/// the same from a planned cell and from a CSV row; --only matches against it.
std::string cell_key(const std::string& scene, const std::string& builder, const std::string& params,
                     const std::string& layout, int threads, const std::string& ray_set, int frame);

}  // namespace sahbench
