#pragma once
// Report tables that go into a paper without hand editing: the columns a reader asked for, and a table
// split into parts by column groups where its LaTeX would be wider than the page's text width. The width
// is estimated from the glyph widths of Computer Modern (Knuth, "Computer Modern Typefaces", 1986) at the
// sizes render_latex sets, so that the pdflatex test (tests/scripts/test_latex_fit.py) finds no overfull
// box; the estimate errs on the wide side.

#include <string>
#include <vector>

#include "harness/report/report_table.h"

namespace sahbench {

/// The text width render_latex's tables must fit, in TeX points: \textwidth of `article` at 10 pt (345 pt)
/// or \columnwidth of `article` with `twocolumn` ((469 - 10) / 2 pt), the narrowest of the common
/// two-column classes (acmart sigconf 241 pt, IEEEtran 252 pt).
double page_width_pt(PageWidth width);

/// The table with only the columns named in `keys` (ReportColumn::key: build, build_layout, memory,
/// sah or a ray set's name; "rays" for every ray set), in the order given; empty keys keep them all. A
/// key the table has no column for is an Error naming it and the keys it has.
ReportTable select_columns(const ReportTable& table, const std::vector<std::string>& keys);

/// The estimated width in points of render_latex(table, out, width)'s tabular.
double estimated_latex_width(const ReportTable& table, PageWidth width);

/// `table` as one part, or split into parts of consecutive columns (build columns first, then each ray
/// set's) each estimated to fit page_width_pt(width); every part has the rows' label columns, and a
/// caption and \label of its own ("... (part 2 of 3)", "LABEL-p2"). A part with one column is kept even
/// where it is wider, and the test reports it.
std::vector<ReportTable> split_to_width(const ReportTable& table, PageWidth width);

}  // namespace sahbench
