#pragma once
// `sahbench compare BASELINE.csv NEW.csv`: regression checks for CI. Deterministic metrics (SAH cost,
// node counts, nodes and primitives per ray, structure bytes, mismatches) must match the baseline
// exactly or within a declared tolerance; timings are compared only as ratios to Embree medium from
// the same run, with a noise margin taken from the measured spread. Prints a Markdown summary, can
// write JSON for dashboards, and returns non-zero on a regression.

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace sahbench {

struct CompareOptions {
  std::filesystem::path baseline;
  std::filesystem::path current;
  bool deterministic_only = false;            ///< ignore timings (CI on a shared machine)
  std::optional<std::filesystem::path> json;  ///< write github-action-benchmark style JSON here
  double min_timing_margin = 0.10;            ///< noise floor for timing ratios (machines vary 10-25%)
};

/// One deterministic metric: its column, whether larger is worse, and the relative tolerance within
/// which a change is noise (0: must be equal).
struct MetricRule {
  const char* column;
  bool larger_is_worse;
  double tolerance;
};
const std::vector<MetricRule>& deterministic_metrics();

struct CompareResult {
  int regressions = 0;
  int improvements = 0;
  int compared_cells = 0;
  int missing_cells = 0;  ///< in the baseline but not in the new run
};

CompareResult compare_results(const CompareOptions& options, std::ostream& out);

}  // namespace sahbench
