#include "harness/report/html_report.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <ostream>
#include <vector>

#include "core/error.h"

namespace sahbench {
namespace {

std::string html_cell(const ReportCell& cell, const ReportColumn& column) {
  if (!cell.value) return "-";
  std::string s = html_escape(format_value(*cell.value, column.decimals));
  if (cell.best) s = "<strong>" + s + "</strong>";
  if (!cell.note.empty()) s += " [" + html_escape(cell.note) + "]";
  if (cell.interval) {
    const Verdict v = verdict(*cell.interval, column.larger_is_better);
    const std::string_view mark = v == Verdict::kAhead ? " \u25B2" : v == Verdict::kBehind ? " \u25BC" : "";
    s += " <span class=\"ratio\">(" + html_escape(format_ratio(*cell.interval)) + std::string(mark) +
         ")</span>";
  } else if (cell.ratio) {
    s += fmt::format(" <span class=\"ratio\">({:.2f}x)</span>", *cell.ratio);
  }
  return s;
}

// The MIME type of a figure file, or empty for a file that is not one.
std::string_view figure_type(const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  return "";
}

}  // namespace

std::string base64_encode(std::string_view bytes) {
  static constexpr std::string_view kAlphabet =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    // Three bytes make four 6-bit digits; a short last group is padded with '='.
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    std::uint32_t group = 0;
    for (std::size_t k = 0; k < 3; ++k)
      group = group << 8 | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    for (std::size_t k = 0; k < 4; ++k) out += k <= n ? kAlphabet[(group >> (18 - 6 * k)) & 0x3F] : '=';
  }
  return out;
}

std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

void html_begin(const std::string& title, const std::string& subtitle, std::ostream& out) {
  fmt::print(out,
             "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{0}</title>\n"
             "<style>\nbody {{ font-family: sans-serif; margin: 2em; }}\n"
             "table {{ border-collapse: collapse; margin: 1em 0; }}\n"
             "caption {{ caption-side: top; text-align: left; font-weight: bold; padding-bottom: 0.3em; }}\n"
             "th, td {{ border-bottom: 1px solid #ccc; padding: 0.2em 0.6em; }}\n"
             "td.num {{ text-align: right; white-space: nowrap; }}\n"
             ".ratio {{ color: #555; font-size: 85%; }}\n.legend {{ font-size: 85%; max-width: 60em; }}\n"
             "img {{ max-width: 100%; }}\n</style>\n</head>\n<body>\n<h1>{0}</h1>\n<p>{1}</p>\n",
             html_escape(title), html_escape(subtitle));
}

void render_html(const ReportTable& table, std::ostream& out) {
  const bool layout_column = layouts_vary(table);
  fmt::print(out, "<section>\n<h2>{}</h2>\n<table>\n", html_escape(table.title));
  if (!table.caption.empty()) fmt::print(out, "<caption>{}</caption>\n", html_escape(table.caption));
  fmt::print(out, "<thead><tr><th>builder</th>{}", layout_column ? "<th>layout</th>" : "");
  for (const auto& column : table.columns) fmt::print(out, "<th>{}</th>", html_escape(column.header));
  fmt::print(out, "</tr></thead>\n<tbody>\n");
  for (const ReportRow& row : table.rows) {
    const std::string dagger = row.marked ? " \u2020" : "";
    fmt::print(out, "<tr><td>{}{}</td>", html_escape(row.builder_short), layout_column ? "" : dagger);
    if (layout_column) fmt::print(out, "<td>{}{}</td>", html_escape(row.layout), dagger);
    for (std::size_t c = 0; c < table.columns.size(); ++c)
      fmt::print(out, "<td class=\"num\">{}</td>",
                 c < row.cells.size() ? html_cell(row.cells[c], table.columns[c]) : "-");
    fmt::print(out, "</tr>\n");
  }
  fmt::print(out, "</tbody>\n</table>\n");
  std::string legend;
  if (!table.rows.empty() && !layout_column)
    legend = "Every row traces the " + table.rows.front().layout + " layout.";
  for (const auto& sentence : table.legend) legend += (legend.empty() ? "" : " ") + sentence;
  if (!legend.empty()) fmt::print(out, "<p class=\"legend\">{}</p>\n", html_escape(legend));
  for (const auto& note : table.notes)
    fmt::print(out, "<p class=\"legend\">Note: {}</p>\n", html_escape(note));
  fmt::print(out, "</section>\n");
}

void html_paragraph(const std::string& text, std::ostream& out) {
  fmt::print(out, "<p>{}</p>\n", html_escape(text));
}

void html_figures(const std::filesystem::path& folder, std::ostream& out) {
  if (folder.empty()) return;
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec))
    throw Error(folder.string() + ": --figures: no such folder (write it with scripts/plots.py --out)");
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.is_regular_file() && !figure_type(entry.path()).empty()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  if (files.empty()) return;
  fmt::print(out, "<section>\n<h2>Figures</h2>\n");
  for (const auto& path : files) {
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in.good() && !in.eof()) throw Error(path.string() + ": cannot read");
    const std::string name = html_escape(path.filename().string());
    fmt::print(
        out, "<figure>\n<img alt=\"{}\" src=\"data:{};base64,{}\">\n<figcaption>{}</figcaption>\n</figure>\n",
        name, figure_type(path), base64_encode(bytes), name);
  }
  fmt::print(out, "</section>\n");
}

void html_end(std::ostream& out) {
  fmt::print(out, "</body>\n</html>\n");
}

}  // namespace sahbench
