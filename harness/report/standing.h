#pragma once
// The report's summary after its tables: for each row of ours (builder run and layout), over every table
// of the run, how many of its rays/s cells are ahead of their Embree anchor, at 1.1 or more, within noise
// or behind by the cells' 95% intervals (ratio_stats.h), and its lowest and highest ratio: the counts
// that a paper's text quotes ("ahead in 27 of 36 cells") and by which a trace-speed target is judged.

#include <map>
#include <string>
#include <vector>

#include "harness/report/report_table.h"

namespace sahbench {

/// The ratio at or above which, as printed (two decimals) and with the interval above 1, a cell counts
/// as "at 1.1".
inline constexpr double kStandingTarget = 1.1;

/// The summary of `tables` (the report's tables, as rendered): one row per builder run, layout and
/// anchor of ours with a rays/s ratio, in order of first appearance; rows traced by Embree's own kernels
/// (layouts embree_*) are left out. `labels` maps each row's full label (ReportRow::builder) to the
/// short one it gets here, whose parameters are those that differ over the whole run. No rows where
/// there is nothing to count. `run` is named in the caption.
ReportTable standing_table(const std::vector<ReportTable>& tables, const std::string& run,
                           const std::map<std::string, std::string>& labels);

}  // namespace sahbench
