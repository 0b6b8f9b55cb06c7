#pragma once
// `sahbench compare BASELINE.csv NEW.csv`: regression checks for CI. Deterministic metrics (SAH cost,
// node counts, nodes and primitives per ray, structure bytes, mismatches) must match the baseline
// exactly or within a declared tolerance, in either direction; timings are compared only as ratios to
// Embree medium from the same run, each from samples paired by round, and a change of such a ratio is
// flagged only when it is larger than a margin and Holm's step-down test over all of the file's timing
// changes rejects no change (harness/report/ratio_stats.h), so that an unchanged build is flagged
// anywhere at most 5% of the time. Two runs of different inputs (seed, scenes, ray sets, cameras,
// reference) are not compared. Bad data (a missing column, a field that is not a number, a cell twice,
// two runs under one run id) is an Error naming file, column and line. Prints a Markdown summary, can
// write JSON for dashboards, and fails (CompareResult::failed) on a regression or an out-of-date
// baseline.

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
  /// The smallest change of a timing ratio worth flagging (0.02: 2%); noise is told apart by the change's
  /// interval, not by this margin.
  double min_timing_margin = 0.02;
};

/// One deterministic metric: its column, whether larger is worse, and the relative tolerance within
/// which a change is noise (0: must be equal). A column added after baselines were committed is
/// `optional`: a baseline from before it still gates every other metric, and the summary names the
/// metric it could not compare; a new run without a column its baseline has is an Error.
struct MetricRule {
  const char* column;
  bool larger_is_worse;
  double tolerance;
  bool optional = false;
};
const std::vector<MetricRule>& deterministic_metrics();

struct CompareResult {
  int regressions = 0;
  int improvements = 0;
  /// Deterministic metrics that improved: the same code on the same input reproduces them to the bit, so
  /// the baseline no longer describes the code, and a later regression that stays below its old value
  /// would pass. Counted among the improvements too; the gate fails until the baseline is refreshed.
  int out_of_date = 0;
  int new_cells = 0;  ///< in the new run only: listed, not gated
  int compared_cells = 0;
  int missing_cells = 0;             ///< in the baseline but not in the new run
  int timings_without_interval = 0;  ///< timing ratios of one round in a run, which cannot be told from noise
  /// Cells whose baseline has its Embree anchor and whose new run has none: their timings cannot be
  /// compared, and each counts as a regression (a run with --only that left Embree out is no pass).
  int missing_anchors = 0;
  int timing_comparisons = 0;  ///< timing changes with an interval, the family Holm's correction is over

  /// What the exit status says: a regression, or a baseline that no longer describes the code.
  bool failed() const { return regressions > 0 || out_of_date > 0; }
};

/// The required columns: the cell key (scene, builder, builder_params, layout, threads, ray_set, frame),
/// run_id, run_fingerprint and each deterministic metric but the optional ones, and, unless
/// deterministic_only, the samples (build_ms_samples, trace_mrays_samples).
std::vector<std::string> required_columns(bool deterministic_only);

/// Compares the latest run of options.current with the latest run of options.baseline; prints the
/// summary to `out`. Bad data in either file is an Error naming file, column and line.
CompareResult compare_results(const CompareOptions& options, std::ostream& out);

}  // namespace sahbench
