#pragma once
// `sahbench stress CONFIG`: numerical stability on stiff and extreme cases. For every generated case
// (scenes/stress_cases.h) the exact reference (traversal/exact_reference.h) answers every ray; then
// every configured builder builds the scene under a time bound, each tree is validated and searched for
// NaN bounds and traced with the default kernel of each layout of its arity, the first tree of each
// arity is also traced with every configured layout variant (triangle test x box test), and Embree
// traces in its default and robust modes. Each trace is timed and compared with the exact answers, and
// one CSV row per (case, builder, layout) puts the error metrics (harness/run/stress_metrics.h) next to the
// rays/second of the same run.
//
// Guarantees checked on every run, each failure listed in StressSummary::failures: every builder
// terminates within the bound without throwing and gives a valid tree without NaN bounds; the default
// kernels (watertight triangle test, conservative box test) have no false misses and no leaks on the
// closed cases; the triangle filter removes exactly the invalid triangles a case made; and every ray a
// generator flags as must-hit is a hit for the exact reference (a check of the generators themselves).

#include <cstddef>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "harness/config/stress_config.h"

namespace sahbench {

struct StressOptions {
  std::filesystem::path config;
  std::optional<std::filesystem::path> output;  ///< overrides the config's
  std::string only;                             ///< run only cases whose name contains this
};

struct StressSummary {
  std::vector<std::string> failures;  ///< broken guarantees, one line each
  std::size_t rows = 0;
  std::size_t abandoned_builds = 0;  ///< builds still running past the time bound (threads detached)
  int exit_code() const { return failures.empty() ? 0 : 1; }
};

/// The CSV columns the stress suite adds to DESIGN.md's (the report's stress table keys on them).
const std::vector<std::string>& stress_metric_columns();

/// Runs the config at options.config.
StressSummary run_stress(const StressOptions& options, std::ostream& log);
/// Runs `config` (options.config is ignored).
StressSummary run_stress(const StressConfig& config, const StressOptions& options, std::ostream& log);

}  // namespace sahbench
