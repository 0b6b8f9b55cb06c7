#pragma once
// Stress configs (`sahbench stress CONFIG`): which generated cases to run, which builders to run on each
// (every one with a time bound), which layout variants and Embree modes to trace, and where the CSV
// goes. Checked when read, every error naming file, line, key and value. A complete example (values of
// optional keys are their defaults):
//
//   [stress]
//   name = "stress"                  # required: letters, digits, '-', '_'
//   output = "results/stress.csv"    # default "results/<name>.csv"
//   rays = 2000                      # rays per case unless the case says otherwise
//   threads = 1                      # threads for builds and timed traces (the exact reference uses all)
//   trace_reps = 5                   # timed passes over a case's rays (median reported), after
//   trace_warmup = 1                 # untimed ones
//   build_time_limit_s = 30          # a build still running after this is abandoned and counted failed
//   builders = ["binned_sah", "wide_collapse:arity=4"]   # default: every registered builder, defaults
//   layouts = ["bvh2", "bvh2:tri=mt"]  # variants traced on the first tree of each layout's arity;
//                                    # default: every layout with every triangle and box test
//   embree = ["default", "robust"]   # Embree's own BVH and kernels in these modes; [] for none
//
//   [[case]]                         # one table per case; at least one
//   name = "sphere_far"              # required, unique
//   kind = "sphere"                  # required: a stress kind (scenes/stress_cases.h)
//   seed = 1
//   size = 1000                      # triangles, as the kind reads it
//   rays = 500                       # overrides [stress] rays
//   scale = 1e3                      # real parameters: only those the kind reads (scale, offset,
//   offset = 1e6                     # aspect, outer) are accepted

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "harness/config/config.h"
#include "scenes/stress_cases.h"

namespace sahbench {

struct StressConfig {
  std::filesystem::path path;
  std::string name;
  std::filesystem::path output;
  uint32_t rays = 2000;
  int threads = 1;
  int trace_reps = 5;
  int trace_warmup = 1;
  double build_time_limit_s = 30.0;
  std::vector<BuilderRun> builders;  ///< parse_builder_run's, each checked against the registry
  std::vector<LayoutSpec> layouts;   ///< parsed and checked
  std::vector<bool> embree_robust{false, true};
  std::vector<StressCaseSpec> cases;

  bool operator==(const StressConfig&) const = default;
};

/// Every registered builder with its defaults, except those that read a file (a path parameter: `file`);
/// builders with an `arity` parameter also at every other wide arity a registered layout traverses (e.g.
/// wide_collapse:arity=4 beside its default 8).
std::vector<BuilderRun> all_builder_specs();
/// Every registered layout with every triangle test and every box test, the defaults first.
std::vector<LayoutSpec> all_layout_variants();

StressConfig load_stress_config(const std::filesystem::path& path);
StressConfig parse_stress_config(std::string_view toml_text, const std::string& source_name);

}  // namespace sahbench
