#pragma once
// `sahbench report RESULTS.csv`: a Markdown table per scene and thread count, rows of builder and
// layout, columns of build time, memory, SAH cost and rays/second per ray set, each also as a ratio to
// Embree medium (rtcIntersect1 / rtcOccluded1) from the same run.

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace sahbench {

struct ReportOptions {
  std::vector<std::filesystem::path> inputs;
  std::string run_id;  ///< only rows of this run; empty: the latest run_id in the files
};

void print_report(const ReportOptions& options, std::ostream& out);

}  // namespace sahbench
