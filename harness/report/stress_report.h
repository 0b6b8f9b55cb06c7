#pragma once
// The stress suite's section of `sahbench report`: error against run time per variant over all cases
// (Markdown or LaTeX, through harness/report/report_table.h), then in Markdown the errors of each case
// grouped by the variants that share them, and what each case contained.

#include <iosfwd>
#include <vector>

#include "harness/report/report.h"
#include "harness/run/csv.h"

namespace sahbench {

/// Whether the rows come from `sahbench stress` (they carry its error columns).
bool is_stress_result(const std::vector<CsvRow>& rows);

/// The tables of one stress run's rows. LaTeX gets the error-against-time table only (the per-case
/// tables are long lists meant for reading, not for a paper).
/// LaTeX tables are split to fit `width` (table_fit.h); HTML is a page of its own (html_report.h).
void print_stress_report(const std::vector<CsvRow>& rows, ReportFormat format, std::ostream& out,
                         PageWidth width = PageWidth::kSingle);

}  // namespace sahbench
