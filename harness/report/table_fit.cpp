#include "harness/report/table_fit.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string_view>

#include "core/error.h"

namespace sahbench {
namespace {

// Font sizes in points as render_latex sets them in a 10 pt document (LaTeX's size10.clo): the table
// body, and the script size of parameters and ratios, whose super- and subscripts are in 5 pt.
constexpr double kSmallPt = 9.0, kFootnotePt = 8.0, kScriptPt = 7.0, kScriptScriptPt = 5.0;
// Bold digits (cmbx10) are 0.575 em against cmr10's 0.5.
constexpr double kBoldFactor = 1.15;
// The estimate is used to stay under the width: 3% spare for the glyphs the table below rounds down.
constexpr double kSpare = 0.97;

// The advance width in em of a character of Computer Modern Roman (cmr10's tfm widths, rounded up);
// characters not listed count as the widest lowercase letter's.
double glyph_em(char c) {
  if (c >= '0' && c <= '9') return 0.5;
  if (c >= 'A' && c <= 'Z') return c == 'M' || c == 'W' ? 1.03 : 0.75;
  switch (c) {
    case 'i':
    case 'l':
    case '.':
    case ',':
    case ':':
    case ';':
    case '[':
    case ']':
    case '!':
    case '\'':
      return 0.28;
    case 'f':
    case 'j':
    case 't':
    case 'r':
    case 's':
    case '-':
    case '(':
    case ')':
      return 0.4;
    case 'c':
    case 'e':
    case 'z':
    case ' ':
      return 0.45;
    case 'a':
    case 'g':
    case 'o':
    case '/':
    case '_':
    case '*':
      return 0.5;
    case 'b':
    case 'd':
    case 'h':
    case 'k':
    case 'n':
    case 'p':
    case 'q':
    case 'u':
    case 'v':
    case 'x':
    case 'y':
      return 0.56;
    case 'w':
      return 0.73;
    case 'm':
    case '=':
    case '+':
    case '<':
    case '>':
    case '%':
    case '&':
    case '@':
    case '#':
      return 0.84;
    default:
      return 0.84;
  }
}

// Computer Modern's small sizes are drawn wider than the 10 pt design scaled down (cmr7's digits are
// 0.569 em against cmr10's 0.5 em): the factor of each size's font over cmr10 scaled, rounded up.
double optical_factor(double size_pt) {
  if (size_pt <= kScriptScriptPt) return 1.36;
  if (size_pt <= kScriptPt) return 1.14;
  if (size_pt <= kFootnotePt) return 1.06;
  if (size_pt <= kSmallPt) return 1.03;
  return 1.0;
}

// The width in points of plain `text` at `size_pt`. LaTeX markup (backslash commands, braces, '$') is
// skipped: a command's name is not printed.
double text_pt(std::string_view text, double size_pt) {
  double em = 0.0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\\') {
      // \_ \& \% \# print one glyph; a named command (\\textbf, \\textdagger{}) prints its argument.
      if (i + 1 < text.size() && !std::isalpha(static_cast<unsigned char>(text[i + 1]))) {
        em += glyph_em(text[++i]);
        continue;
      }
      while (i + 1 < text.size() && std::isalpha(static_cast<unsigned char>(text[i + 1]))) ++i;
      continue;
    }
    if (c == '{' || c == '}' || c == '$') continue;
    em += glyph_em(c);
  }
  return em * size_pt * optical_factor(size_pt);
}

// The widest line of a header ("Build +\nlayout (ms)").
double header_pt(const std::string& header, double size_pt) {
  double widest = 0.0;
  std::size_t start = 0;
  while (start <= header.size()) {
    const std::size_t end = std::min(header.find('\n', start), header.size());
    widest = std::max(widest, text_pt(std::string_view(header).substr(start, end - start), size_pt));
    start = end + 1;
  }
  return widest;
}

// The ratio line of a cell as render_latex writes it: the estimate in script size, the interval's
// offsets ("+.05", "-.04") as a super- and subscript, an arrow.
double ratio_pt(const ReportCell& cell) {
  if (cell.interval) {
    const RatioInterval& r = *cell.interval;
    double pt = text_pt(fmt::format("{:.2f}", r.estimate), kScriptPt) + 0.6 * kScriptPt;  // and an arrow
    if (r.has_interval()) {
      auto offset = [](double v) {
        std::string digits = fmt::format("{:.2f}", std::fabs(v));
        return digits.starts_with("0.") ? digits.substr(1) : digits;
      };
      pt += std::max(text_pt(fmt::format("+{}", offset(*r.hi - r.estimate)), kScriptScriptPt),
                     text_pt(fmt::format("-{}", offset(r.estimate - *r.lo)), kScriptScriptPt)) +
            0.2 * kScriptPt;  // the script's kern
    }
    return pt;
  }
  if (cell.ratio) return text_pt(fmt::format("{:.2f}", *cell.ratio), kScriptPt) + 0.8 * kScriptPt;  // x
  return 0.0;
}

double cell_pt(const ReportCell& cell, const ReportColumn& column, double size_pt) {
  if (!cell.value) return text_pt("--", size_pt);
  double value =
      text_pt(format_value(*cell.value, column.decimals), size_pt) * (cell.best ? kBoldFactor : 1.0);
  if (!cell.note.empty()) value += text_pt(" [" + cell.note + "]", kScriptPt);
  return std::max(value, ratio_pt(cell));
}

double body_pt(PageWidth width) {
  return width == PageWidth::kDouble ? kFootnotePt : kSmallPt;
}

// The widths of the label columns, each with its two \\tabcolsep: builder with its varying parameters and
// layout where it varies; in two-column pages one column, the builder over a script-size line of its
// parameters and layout (render_latex's stacked labels).
double label_columns_pt(const ReportTable& table, PageWidth width) {
  const double size = body_pt(width), sep = 2.0 * kLatexTabColSepPt;
  const bool layout_column = layouts_vary(table);
  const double dagger_pt = 0.5 * kScriptPt;
  double builder = text_pt("Builder", size), layout = text_pt("Layout", size);
  for (const ReportRow& row : table.rows) {
    const auto [name, varying] = split_row_label(row.builder_short);
    const double dagger = row.marked ? dagger_pt : 0.0;
    if (latex_stacked_labels(width)) {
      builder = std::max({builder,
                          text_pt(latex_label_detail(name, layout_column ? row.layout : ""), size) + dagger,
                          text_pt(varying, kScriptPt)});
      continue;
    }
    double label = text_pt(name, size) + (varying.empty() ? 0.0 : text_pt(" " + varying, kScriptPt));
    if (layout_column)
      layout = std::max(layout, text_pt(row.layout, size) + dagger);
    else
      label += dagger;
    builder = std::max(builder, label);
  }
  return builder + sep + (layout_column && !latex_stacked_labels(width) ? layout + sep : 0.0);
}

double column_pt(const ReportTable& table, std::size_t c, PageWidth width) {
  const double size = body_pt(width);
  double widest = header_pt(table.columns[c].latex_header, size);
  for (const ReportRow& row : table.rows)
    if (c < row.cells.size()) widest = std::max(widest, cell_pt(row.cells[c], table.columns[c], size));
  return widest + 2.0 * kLatexTabColSepPt;
}

// The table with the columns `indices` of `table`, in that order.
ReportTable with_columns(const ReportTable& table, const std::vector<std::size_t>& indices) {
  ReportTable part = table;
  part.columns.clear();
  for (ReportRow& row : part.rows) row.cells.clear();
  for (const std::size_t c : indices) {
    part.columns.push_back(table.columns[c]);
    for (std::size_t r = 0; r < table.rows.size(); ++r)
      part.rows[r].cells.push_back(c < table.rows[r].cells.size() ? table.rows[r].cells[c] : ReportCell{});
  }
  return part;
}

}  // namespace

double page_width_pt(PageWidth width) {
  return width == PageWidth::kDouble ? (469.0 - 10.0) / 2.0 : 345.0;
}

ReportTable select_columns(const ReportTable& table, const std::vector<std::string>& keys) {
  if (keys.empty()) return table;
  // Ray-set columns are those after the four of every table (harness/report/report.cpp's make_table).
  auto is_ray_set = [](const ReportColumn& column) { return column.larger_is_better; };
  std::vector<std::size_t> indices;
  for (const std::string& key : keys) {
    bool found = false;
    for (std::size_t c = 0; c < table.columns.size(); ++c)
      if (table.columns[c].key == key || (key == "rays" && is_ray_set(table.columns[c]))) {
        if (std::find(indices.begin(), indices.end(), c) == indices.end()) indices.push_back(c);
        found = true;
      }
    if (!found) {
      std::string known;
      for (const ReportColumn& column : table.columns) known += (known.empty() ? "" : ", ") + column.key;
      throw Error("--columns: no column '" + key + "' in table " + table.title + " (known: " + known +
                  ", rays)");
    }
  }
  return with_columns(table, indices);
}

double estimated_latex_width(const ReportTable& table, PageWidth width) {
  double total = label_columns_pt(table, width);
  for (std::size_t c = 0; c < table.columns.size(); ++c) total += column_pt(table, c, width);
  return total;
}

std::vector<ReportTable> split_to_width(const ReportTable& table, PageWidth width) {
  const double limit = page_width_pt(width) * kSpare;
  const double labels = label_columns_pt(table, width);
  std::vector<std::vector<std::size_t>> groups(1);
  double used = labels;
  for (std::size_t c = 0; c < table.columns.size(); ++c) {
    const double w = column_pt(table, c, width);
    if (!groups.back().empty() && used + w > limit) {
      groups.emplace_back();
      used = labels;
    }
    groups.back().push_back(c);
    used += w;
  }
  if (groups.size() == 1) return {table};
  std::vector<ReportTable> parts;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    ReportTable part = with_columns(table, groups[g]);
    const std::string suffix = fmt::format(" (part {} of {})", g + 1, groups.size());
    if (part.caption.ends_with("."))
      part.caption.insert(part.caption.size() - 1, suffix);
    else
      part.caption += suffix;
    if (g > 0) part.label += fmt::format("-p{}", g + 1);
    parts.push_back(std::move(part));
  }
  return parts;
}

}  // namespace sahbench
