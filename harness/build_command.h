#pragma once
// `sahbench build`: load a scene, build it with one or more builders (ours and Embree's) at one or more
// thread counts, validate every tree, and print build times with their spread and tree statistics.

#include <iosfwd>
#include <string>
#include <vector>

#include "builders/params.h"

namespace sahbench {

struct BuildCommandOptions {
  std::string scene;                  ///< file, shared-scene name or procedural spec
  std::vector<std::string> builders;  ///< "name" or "name:key=value,key=value"; embree_{low,medium,high}
  ParamOverrides params;              ///< applied to every one of our builders
  std::vector<int> threads{1};
  int reps = 5;
  int warmup = 1;
};

/// A builder as the command line names it: our registry name or an Embree quality, and its overrides.
struct BuilderSpec {
  std::string name;
  ParamOverrides params;
  /// Embree's own BVH (rtcCommitScene); embree_bvh is a registry builder like ours.
  bool is_embree() const { return name == "embree_low" || name == "embree_medium" || name == "embree_high"; }
};

/// Parses "name" or "name:key=value,key=value"; malformed text is an error naming it.
BuilderSpec parse_builder_spec(std::string_view text);

/// Runs the command; returns the process exit code (0, or 1 when a tree fails validation). Bad input
/// throws sahbench::Error.
int run_build_command(const BuildCommandOptions& options, std::ostream& out, std::ostream& log);

}  // namespace sahbench
