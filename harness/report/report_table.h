#pragma once
// One table of `sahbench report`, independent of its output format: numeric cells with their ratio to
// the anchor (Embree medium; for timings with a 95% interval and a mark where it lies wholly on one side
// of 1) and a mark on the best value of each column, rendered as Markdown (GitHub and pandoc pipe
// tables) or as a LaTeX table in the booktabs style.

#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "harness/report/ratio_stats.h"

namespace sahbench {

struct ReportColumn {
  std::string header;             ///< as the Markdown report has always printed it, e.g. "build ms"
  std::string latex_header;       ///< already LaTeX, e.g. "Build (ms)"
  int decimals = 2;               ///< digits printed after the point (more for values below 1: 3 significant)
  bool larger_is_better = false;  ///< rays/s: largest is best; time, memory, SAH: smallest
  /// What `report --columns` names it by: "build", "build_layout", "memory", "sah" or a ray set's name.
  std::string key = {};
};

struct ReportCell {
  std::optional<double> value;  ///< empty: printed as "-"
  std::optional<double> ratio;  ///< value / anchor's value, when the anchor has one
  bool best = false;            ///< set by mark_best
  /// Printed after the value in brackets, e.g. "c_trav=2": the value is on another scale than the
  /// column's others, so mark_best leaves it out.
  std::string note = {};
  /// A timing's ratio to the anchor with its interval (ratio_stats.h), printed instead of `ratio` as
  /// "(1.08 [1.03, 1.12] ▲)": ▲ ahead of the anchor, ▼ behind (verdict with the column's
  /// larger_is_better), no mark within noise.
  std::optional<RatioInterval> interval = {};
};

struct ReportRow {
  std::string builder;        ///< full label: "binned_sah [bins=8;max_leaf=8;...]"
  std::string builder_short;  ///< only the parameters that differ between rows of the builder
  std::string layout;
  std::vector<ReportCell> cells;  ///< one per column
  /// Its ratios are to the table's other anchor, which the caption names: printed with a dagger after
  /// the layout ("bvh8 †", LaTeX "bvh8$^\dagger$").
  bool marked = false;
  /// Its rays/s ratios are to Embree's packets (our packet layouts where the run has them).
  bool against_packets = false;
};

struct ReportTable {
  std::string title;    ///< "proc:sphere (100 triangles), 2 threads"
  std::string caption;  ///< plain text (escaped for LaTeX when rendered)
  std::string label;    ///< LaTeX \label key, letters, digits, ':' and '-' only
  std::vector<ReportColumn> columns;
  std::vector<ReportRow> rows;
  std::vector<std::string> notes = {};  ///< plain text, printed after the table ("Note: ...")
  /// Plain-text sentences printed under the table, in small type in LaTeX: how to read it (ratios,
  /// marks), and what its rows share (parameters, layout), so that the caption stays short.
  std::vector<std::string> legend = {};
};

/// The text width a LaTeX table is set for: a one-column article (\textwidth 345 pt) or one column of
/// a two-column ACM/IEEE-like paper (about 229 pt in `article` with `twocolumn`, 241 pt in acmart,
/// 252 pt in IEEEtran).
enum class PageWidth { kSingle, kDouble };

/// "single" or "double"; anything else is an Error naming it.
PageWidth parse_page_width(std::string_view name);

/// `value` with the column's decimals, or 3 significant digits below 1 (a 36-triangle scene builds in
/// 0.0123 ms, which one decimal would print as 0.0).
std::string format_value(double value, int column_decimals);

/// Marks in each column every cell whose value, rounded as printed, is the best of the column: the
/// smallest, or the largest for larger_is_better columns. Rounding first means that two values the
/// reader sees as equal are both marked. Cells with a note are not compared. A column with fewer than two
/// compared values marks nothing.
void mark_best(ReportTable& table);

/// Whether the rows trace more than one layout; where they do not, the layout is named in the legend
/// rather than in a column of equal values.
bool layouts_vary(const ReportTable& table);

/// "binned_sah [bins=8]" (ReportRow::builder_short) as {"binned_sah", "bins=8"}; no brackets: {label, ""}.
std::pair<std::string, std::string> split_row_label(const std::string& builder_short);

/// Whether render_latex stacks a row's label: builder and layout on the value line, its varying
/// parameters on the ratio line under it, in one column (two-column pages, where two label columns
/// would leave no room for numbers).
inline bool latex_stacked_labels(PageWidth width) {
  return width == PageWidth::kDouble;
}

/// "a, b", or whichever is not empty: a stacked label's "binned_sah, bvh2".
std::string latex_label_detail(const std::string& varying, const std::string& layout);

/// \tabcolsep of the LaTeX tables: half of LaTeX's 6 pt default, as in most papers' dense tables.
inline constexpr int kLatexTabColSepPt = 3;

/// "## title", the pipe table (best values in **bold**, ratios as "(0.85x)", timing ratios as
/// "(0.85 [0.80, 0.90] ▼)"; the layout column only where layouts differ), "Table: caption", the legend
/// as one paragraph and a "Note:" paragraph per note.
void render_markdown(const ReportTable& table, std::ostream& out);

/// A `table` float with \caption, \label and a booktabs tabular (\toprule, \midrule, \bottomrule); best
/// values in \textbf; each row's ratios to the anchor on a second line in script size, "0.85$\times$"
/// for exact ratios and "0.85$^{+.05}_{-.04}$\textdownarrow" for timing ratios with their 95% interval
/// (table_fit.h sizes the columns for `width`); the layout column only where layouts differ; legend
/// and notes in small type under the tabular. Needs \usepackage{booktabs} (the arrows are textcomp's,
/// in the LaTeX kernel since 2020).
void render_latex(const ReportTable& table, std::ostream& out, PageWidth width = PageWidth::kSingle);

/// latex_escape(text) with a permitted line break after each ';' that no space follows ("bins=8;max_leaf=8"),
/// for parameter lists in legends.
std::string latex_breakable(std::string_view text);

/// `text` with LaTeX's special characters escaped: \ & % $ # _ { } ~ ^ (and < > | outside math mode),
/// and the dagger (U+2020) as \textdagger{}.
std::string latex_escape(std::string_view text);

}  // namespace sahbench
