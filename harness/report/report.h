#pragma once
// `sahbench report RESULTS.csv`: a table per scene, thread count (and animation frame), rows of builder
// and layout, columns of build time, build + layout time, memory, SAH cost and rays/second per ray set,
// with ratios to Embree medium (rtcIntersect1 / rtcOccluded1) from the same run: for the timings from
// samples paired by round, with a 95% interval and a mark where it excludes 1 (harness/report/ratio_stats.h).
// The best value of each column is marked, a short caption names the table, machine and commit, a legend
// under it the repetitions, how to read the ratios, the parameters the rows share (rows name only those
// that vary) and the share of rays that hit, and a note names the cells that another run of the same
// fingerprint has and this one lacks. Each table is followed by how well the costs (SAH, EPO, their blend,
// the measured cost per ray) rank its builders by rays/s (harness/report/predictors.h). A CSV that is not
// sahbench's, or a run whose rows carry two fingerprints, is an Error. Markdown (the default) or LaTeX
// (booktabs) for papers.

#include <filesystem>
#include <iosfwd>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "harness/report/report_table.h"

namespace sahbench {

enum class ReportFormat { kMarkdown, kLatex, kHtml };

/// "markdown", "latex" or "html"; anything else is an Error naming it.
ReportFormat parse_report_format(std::string_view name);

struct ReportOptions {
  // A constructor rather than an aggregate, so that callers may leave out the later options.
  ReportOptions(std::vector<std::filesystem::path> inputs_ = {}, std::string run_id_ = {},
                ReportFormat format_ = ReportFormat::kMarkdown, std::filesystem::path output_ = {})
      : inputs(std::move(inputs_)), run_id(std::move(run_id_)), format(format_), output(std::move(output_)) {}

  std::vector<std::filesystem::path> inputs;
  std::string run_id;  ///< only rows of this run; empty: the latest run_id in the files
  ReportFormat format;
  std::filesystem::path output;          ///< run_report_command writes here; empty: to its stream
  PageWidth width = PageWidth::kSingle;  ///< LaTeX: the text width its tables are split to fit
  std::vector<std::string> columns;      ///< table_fit.h's select_columns keys; empty: every column
  /// HTML: every PNG and SVG in this folder (scripts/plots.py's output) is embedded; empty: none.
  std::filesystem::path figures;
};

/// Writes the report of `options` to `out`. No rows (or none of the run asked for) is an Error.
void print_report(const ReportOptions& options, std::ostream& out);

/// The command: the report into options.output (an unwritable path is an Error naming it), else `out`.
void run_report_command(const ReportOptions& options, std::ostream& out);

}  // namespace sahbench
