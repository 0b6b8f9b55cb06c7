#include "harness/report/report_table.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <cmath>
#include <ostream>

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

std::string format_value(double value, int column_decimals) {
  return fmt::format("{:.{}f}", value, decimals_for(value, column_decimals));
}

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

std::string latex_cell(const ReportCell& cell, const ReportColumn& column) {
  if (!cell.value) return "--";
  std::string s = format_value(*cell.value, column.decimals);
  if (cell.best) s = "\\textbf{" + s + "}";
  if (!cell.note.empty()) s += " [" + latex_escape(cell.note) + "]";
  if (cell.interval)
    s += interval_text(*cell.interval, column.larger_is_better, "\\textuparrow", "\\textdownarrow");
  else if (cell.ratio)
    s += fmt::format(" ({:.2f}$\\times$)", *cell.ratio);
  return s;
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

void render_markdown(const ReportTable& table, std::ostream& out) {
  fmt::print(out, "## {}\n\n| builder | layout |", table.title);
  for (const auto& column : table.columns) fmt::print(out, " {} |", column.header);
  fmt::print(out, "\n|---|---|");
  for (std::size_t i = 0; i < table.columns.size(); ++i) fmt::print(out, "---:|");
  fmt::print(out, "\n");
  for (const ReportRow& row : table.rows) {
    fmt::print(out, "| {} | {}{} |", row.builder, row.layout, row.marked ? " \u2020" : "");  // †
    for (std::size_t c = 0; c < table.columns.size(); ++c)
      fmt::print(out, " {} |", c < row.cells.size() ? markdown_cell(row.cells[c], table.columns[c]) : "-");
    fmt::print(out, "\n");
  }
  // pandoc reads a "Table:" paragraph next to a pipe table as its caption.
  if (!table.caption.empty()) fmt::print(out, "\nTable: {}\n", table.caption);
  for (const auto& note : table.notes) fmt::print(out, "\nNote: {}\n", note);
  fmt::print(out, "\n");
}

void render_latex(const ReportTable& table, std::ostream& out) {
  fmt::print(out, "\\begin{{table}}[htbp]\n  \\centering\n  \\small\n");
  if (!table.caption.empty()) fmt::print(out, "  \\caption{{{}}}\n", latex_escape(table.caption));
  if (!table.label.empty()) fmt::print(out, "  \\label{{{}}}\n", table.label);
  fmt::print(out, "  \\begin{{tabular}}{{ll{}}}\n    \\toprule\n    Builder & Layout",
             std::string(table.columns.size(), 'r'));
  for (const auto& column : table.columns) fmt::print(out, " & {}", column.latex_header);
  fmt::print(out, " \\\\\n    \\midrule\n");
  for (const ReportRow& row : table.rows) {
    fmt::print(out, "    {} & {}{}", latex_escape(row.builder_short), latex_escape(row.layout),
               row.marked ? "$^\\dagger$" : "");
    for (std::size_t c = 0; c < table.columns.size(); ++c)
      fmt::print(out, " & {}", c < row.cells.size() ? latex_cell(row.cells[c], table.columns[c]) : "--");
    fmt::print(out, " \\\\\n");
  }
  fmt::print(out, "    \\bottomrule\n  \\end{{tabular}}\n");
  for (const auto& note : table.notes)
    fmt::print(out, "  \\par\\smallskip{{\\footnotesize Note: {}}}\n", latex_escape(note));
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
