#pragma once
// The stress suite's section of `sahbench report`: error against run time per variant over all cases,
// the errors of each case grouped by the variants that share them, and what each case contained.

#include <iosfwd>
#include <vector>

#include "harness/csv.h"

namespace sahbench {

/// Whether the rows come from `sahbench stress` (they carry its error columns).
bool is_stress_result(const std::vector<CsvRow>& rows);

/// Markdown tables of one stress run's rows.
void print_stress_report(const std::vector<CsvRow>& rows, std::ostream& out);

}  // namespace sahbench
