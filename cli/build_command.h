#pragma once
// `sahbench build`: load a scene, build it with one or more builders (ours and Embree's) at one or more
// thread counts, validate every tree, and print build times with their spread and tree statistics.

#include <iosfwd>
#include <string>
#include <vector>

#include "builders/params.h"
#include "harness/config/config.h"

namespace sahbench {

struct BuildCommandOptions {
  std::string scene;  ///< file, shared-scene name or procedural spec
  /// parse_builder_run's; Embree's own BVH is "embree" with its quality and mode (robust)
  std::vector<BuilderRun> builders;
  ParamOverrides params;  ///< applied to every one of our builders
  std::vector<int> threads{1};
  int reps = 5;
  int warmup = 1;
  /// Non-empty: the tree of the one builder run is written there as a tree file (scenes/tree_file.h) once
  /// it has passed validation.
  std::string save;
};

/// Runs the command; returns the process exit code (0, or 1 when a tree fails validation, and is then not
/// saved). Bad input throws sahbench::Error, before any build: --save with other than one builder that
/// makes a tree of the common format (Embree's rtcCommitScene makes none), or to a directory.
int run_build_command(const BuildCommandOptions& options, std::ostream& out, std::ostream& log);

}  // namespace sahbench
