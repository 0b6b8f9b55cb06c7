#include "harness/report/report_table.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <cmath>
#include <ostream>
#include <utility>

#include "core/error.h"

namespace sahbench {
namespace {

// Digits after the point: the column's, or for values below 1 enough for three significant digits (a
// 36-triangle scene builds in 0.0123 ms, which one decimal would print as 0.0).
constexpr int kMinSignificantDigits = 3;
constexpr int kMaxDecimals = 9;

int decimals_for(double value, int column_decimals) {
  if (value == 0.0 || !std::isfinite(value) || std::fabs(value) >= 1.0) return column_decimals;
  const int leading = static_cast<int>(std::floor(std::log10(std::fabs(value))));  // 0.0123 -> -2
  return std::clamp(kMinSignificantDigits - 1 - leading, column_decimals, kMaxDecimals);
}

// The value as printed, so that ties are judged on what the reader sees.
double rounded(double value, int column_decimals) {
  const double scale = std::pow(10.0, decimals_for(value, column_decimals));
  return std::round(value * scale) / scale;
}

}  // namespace

std::string format_value(double value, int column_decimals) {
  return fmt::format("{:.{}f}", value, decimals_for(value, column_decimals));
}

namespace {

// " (1.08 [1.03, 1.12] UP)": the timing ratio and, where its interval excludes 1, the mark of the side.
std::string interval_text(const RatioInterval& ratio, bool larger_is_better, std::string_view ahead,
                          std::string_view behind) {
  const Verdict v = verdict(ratio, larger_is_better);
  const std::string_view mark = v == Verdict::kAhead ? ahead : v == Verdict::kBehind ? behind : "";
  return fmt::format(" ({}{}{})", format_ratio(ratio), mark.empty() ? "" : " ", mark);
}

std::string markdown_cell(const ReportCell& cell, const ReportColumn& column) {
  if (!cell.value) return "-";
  std::string s = format_value(*cell.value, column.decimals);
  if (cell.best) s = "**" + s + "**";
  if (!cell.note.empty()) s += " [" + cell.note + "]";
  if (cell.interval)
    s += interval_text(*cell.interval, column.larger_is_better, "\u25B2", "\u25BC");  // ▲ ▼
  else if (cell.ratio)
    s += fmt::format(" ({:.2f}x)", *cell.ratio);
  return s;
}

// The value line of a LaTeX cell: the value (bold where best) and a note in brackets.
std::string latex_value(const ReportCell& cell, const ReportColumn& column) {
  if (!cell.value) return "--";
  std::string s = format_value(*cell.value, column.decimals);
  if (cell.best) s = "\\textbf{" + s + "}";
  if (!cell.note.empty()) s += " {\\scriptsize[" + latex_escape(cell.note) + "]}";
  return s;
}

// "+.05" or "+1.20": an interval's offset from the estimate, the leading zero dropped as in most papers'
// tables, to keep the column narrow.
std::string offset_text(char sign, double offset) {
  std::string digits = fmt::format("{:.2f}", std::fabs(offset));
  if (digits.starts_with("0.")) digits.erase(0, 1);
  return sign + digits;
}

// The ratio line of a LaTeX cell, empty where there is no ratio: "0.85$\times$" for an exact ratio,
// "0.85$^{+.05}_{-.04}$\textdownarrow" for a timing ratio with its interval (the offsets to the interval's
// ends), "0.85$^{n=1}$" or "0.85$^{\mathrm{med}}$" for one without (one round, or a ratio of medians;
// the legend says so).
std::string latex_ratio(const ReportCell& cell, const ReportColumn& column) {
  if (!cell.value) return "";
  if (cell.interval) {
    const RatioInterval& r = *cell.interval;
    std::string s = fmt::format("{:.2f}", r.estimate);
    if (r.has_interval())
      s += "$^{" + offset_text('+', *r.hi - r.estimate) + "}_{" + offset_text('-', r.estimate - *r.lo) + "}$";
    else
      s += r.n == 0 ? "$^{\\mathrm{med}}$" : fmt::format("$^{{n={}}}$", r.n);
    const Verdict v = verdict(r, column.larger_is_better);
    if (v == Verdict::kAhead) s += "\\textuparrow";
    if (v == Verdict::kBehind) s += "\\textdownarrow";
    return s;
  }
  if (cell.ratio) return fmt::format("{:.2f}$\\times$", *cell.ratio);
  return "";
}

// A header cell; a '\n' in it starts a second line (a nested tabular, so that booktabs rules still fit).
std::string latex_header_cell(const std::string& header, char align) {
  if (header.find('\n') == std::string::npos) return header;
  std::string lines;
  for (const char c : header) lines += c == '\n' ? std::string("\\\\") : std::string(1, c);
  return fmt::format("\\begin{{tabular}}[b]{{@{{}}{}@{{}}}}{}\\end{{tabular}}", align, lines);
}

}  // namespace

void mark_best(ReportTable& table) {
  for (std::size_t c = 0; c < table.columns.size(); ++c) {
    const ReportColumn& column = table.columns[c];
    std::optional<double> best;
    int values = 0;
    auto compared = [&](const ReportRow& row) {
      return c < row.cells.size() && row.cells[c].value && row.cells[c].note.empty();
    };
    for (const ReportRow& row : table.rows) {
      if (!compared(row)) continue;
      const double v = rounded(*row.cells[c].value, column.decimals);
      ++values;
      if (!best || (column.larger_is_better ? v > *best : v < *best)) best = v;
    }
    // With one value there is nothing to compare it with; a bold lone value would claim a win.
    if (values < 2) continue;
    for (ReportRow& row : table.rows)
      if (compared(row)) row.cells[c].best = rounded(*row.cells[c].value, column.decimals) == *best;
  }
}

bool layouts_vary(const ReportTable& table) {
  return std::any_of(table.rows.begin(), table.rows.end(),
                     [&](const ReportRow& r) { return r.layout != table.rows.front().layout; });
}

std::vector<std::string> legend_with_layout(const ReportTable& table) {
  std::vector<std::string> legend = table.legend;
  if (!table.rows.empty() && !layouts_vary(table))
    legend.insert(legend.begin(), "Every row traces the " + table.rows.front().layout + " layout.");
  return legend;
}

void render_markdown(const ReportTable& table, std::ostream& out) {
  const bool layout_column = layouts_vary(table);
  fmt::print(out, "## {}\n\n| builder |{}", table.title, layout_column ? " layout |" : "");
  for (const auto& column : table.columns) fmt::print(out, " {} |", column.header);
  fmt::print(out, "\n|---|{}", layout_column ? "---|" : "");
  for (std::size_t i = 0; i < table.columns.size(); ++i) fmt::print(out, "---:|");
  fmt::print(out, "\n");
  for (const ReportRow& row : table.rows) {
    const std::string_view dagger = row.marked ? " \u2020" : "";  // †
    if (layout_column)
      fmt::print(out, "| {} | {}{} |", row.builder_short, row.layout, dagger);
    else
      fmt::print(out, "| {}{} |", row.builder_short, dagger);
    for (std::size_t c = 0; c < table.columns.size(); ++c)
      fmt::print(out, " {} |", c < row.cells.size() ? markdown_cell(row.cells[c], table.columns[c]) : "-");
    fmt::print(out, "\n");
  }
  // pandoc reads a "Table:" paragraph next to a pipe table as its caption.
  if (!table.caption.empty()) fmt::print(out, "\nTable: {}\n", table.caption);
  const auto legend = legend_with_layout(table);
  if (!legend.empty()) {
    fmt::print(out, "\n");
    for (std::size_t i = 0; i < legend.size(); ++i) fmt::print(out, "{}{}", i ? " " : "", legend[i]);
    fmt::print(out, "\n");
  }
  for (const auto& note : table.notes) fmt::print(out, "\nNote: {}\n", note);
  fmt::print(out, "\n");
}

PageWidth parse_page_width(std::string_view name) {
  if (name == "single") return PageWidth::kSingle;
  if (name == "double") return PageWidth::kDouble;
  throw Error("unknown page width '" + std::string(name) + "' (known: single, double)");
}

std::pair<std::string, std::string> split_row_label(const std::string& builder_short) {
  const std::size_t open = builder_short.find(" [");
  if (open == std::string::npos || !builder_short.ends_with("]")) return {builder_short, ""};
  return {builder_short.substr(0, open), builder_short.substr(open + 2, builder_short.size() - open - 3)};
}

std::string latex_breakable(std::string_view text) {
  std::string out;
  std::size_t start = 0;
  for (std::size_t end = text.find(';'); end != std::string_view::npos; end = text.find(';', start)) {
    out += latex_escape(text.substr(start, end + 1 - start));
    // "; " breaks at its space already; "a;b" (a parameter list) needs a permitted break.
    if (end + 1 < text.size() && text[end + 1] != ' ') out += "\\allowbreak{}";
    start = end + 1;
  }
  return out + latex_escape(text.substr(start));
}

std::string latex_label_detail(const std::string& varying, const std::string& layout) {
  return varying + (!varying.empty() && !layout.empty() ? ", " : "") + layout;
}

void render_latex(const ReportTable& table, std::ostream& out, PageWidth width) {
  const bool layout_column = layouts_vary(table);
  const bool stacked = latex_stacked_labels(width);
  const bool double_column = width == PageWidth::kDouble;
  fmt::print(out, "\\begin{{table}}[htbp]\n  \\centering\n  {}\n  \\setlength{{\\tabcolsep}}{{{}pt}}\n",
             double_column ? "\\footnotesize" : "\\small", kLatexTabColSepPt);
  if (!table.caption.empty()) fmt::print(out, "  \\caption{{{}}}\n", latex_escape(table.caption));
  if (!table.label.empty()) fmt::print(out, "  \\label{{{}}}\n", table.label);
  const bool two_label_columns = layout_column && !stacked;
  fmt::print(out, "  \\begin{{tabular}}{{l{}{}}}\n    \\toprule\n    {}", two_label_columns ? "l" : "",
             std::string(table.columns.size(), 'r'),
             two_label_columns          ? "Builder & Layout"
             : stacked && layout_column ? "Builder, layout"
                                        : "Builder");
  for (const auto& column : table.columns)
    fmt::print(out, " & {}", latex_header_cell(column.latex_header, 'r'));
  fmt::print(out, " \\\\\n    \\midrule\n");
  for (std::size_t i = 0; i < table.rows.size(); ++i) {
    const ReportRow& row = table.rows[i];
    const auto [builder, varying] = split_row_label(row.builder_short);
    const std::string dagger = row.marked ? "$^\\dagger$" : "";
    std::string detail;  // the stacked label's second line
    if (stacked) {
      // The builder and layout on the value line, the varying parameters under them: the two lines
      // are about as long, which keeps the one label column narrow.
      fmt::print(out, "    {}{}", latex_escape(latex_label_detail(builder, layout_column ? row.layout : "")),
                 dagger);
      if (!varying.empty()) detail = "{\\scriptsize " + latex_escape(varying) + "}";
    } else {
      std::string label = latex_escape(builder);
      if (!varying.empty()) label += " {\\scriptsize " + latex_breakable(varying) + "}";
      if (layout_column)
        fmt::print(out, "    {} & {}{}", label, latex_escape(row.layout), dagger);
      else
        fmt::print(out, "    {}{}", label, dagger);
    }
    std::string ratios;
    bool any_ratio = false;
    for (std::size_t c = 0; c < table.columns.size(); ++c) {
      const ReportCell none;
      const ReportCell& cell = c < row.cells.size() ? row.cells[c] : none;
      fmt::print(out, " & {}", latex_value(cell, table.columns[c]));
      const std::string ratio = latex_ratio(cell, table.columns[c]);
      any_ratio |= !ratio.empty();
      ratios += " & " + (ratio.empty() ? std::string() : "{\\scriptsize " + ratio + "}");
    }
    fmt::print(out, " \\\\\n");
    // The ratios to the anchor on a line of their own, under the values they belong to.
    const bool second_line = any_ratio || !detail.empty();
    if (second_line) fmt::print(out, "    {}{}{} \\\\\n", detail, two_label_columns ? "&" : "", ratios);
    if (second_line && i + 1 < table.rows.size()) fmt::print(out, "    \\addlinespace[2pt]\n");
  }
  fmt::print(out, "    \\bottomrule\n  \\end{{tabular}}\n");
  auto legend = legend_with_layout(table);
  const bool unpaired = std::any_of(table.rows.begin(), table.rows.end(), [](const ReportRow& row) {
    return std::any_of(row.cells.begin(), row.cells.end(),
                       [](const ReportCell& c) { return c.interval && !c.interval->has_interval(); });
  });
  if (unpaired)
    legend.push_back(
        "A ratio marked n=1 is from one round, one marked med the ratio of the medians (the results have no "
        "samples to pair); neither has an interval.");
  if (!legend.empty()) {
    fmt::print(out, "  \\par\\smallskip{{\\scriptsize");
    for (const auto& sentence : legend) fmt::print(out, " {}", latex_breakable(sentence));
    fmt::print(out, "\\par}}\n");
  }
  for (const auto& note : table.notes)
    fmt::print(out, "  \\par\\smallskip{{\\scriptsize Note: {}\\par}}\n", latex_breakable(note));
  fmt::print(out, "\\end{{table}}\n\n");
}

std::string latex_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    // The dagger that marks rows (ReportRow::marked), in UTF-8, as LaTeX's own command.
    if (text.substr(i).starts_with("\u2020")) {
      out += "\\textdagger{}";
      i += std::string_view("\u2020").size() - 1;
      continue;
    }
    const char c = text[i];
    switch (c) {
      case '\\':
        out += "\\textbackslash{}";
        break;
      case '&':
      case '%':
      case '$':
      case '#':
      case '_':
      case '{':
      case '}':
        out += '\\';
        out += c;
        break;
      case '~':
        out += "\\textasciitilde{}";
        break;
      case '^':
        out += "\\textasciicircum{}";
        break;
      // In text mode with the default OT1 encoding these print as other glyphs.
      case '<':
        out += "\\textless{}";
        break;
      case '>':
        out += "\\textgreater{}";
        break;
      case '|':
        out += "\\textbar{}";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace sahbench
