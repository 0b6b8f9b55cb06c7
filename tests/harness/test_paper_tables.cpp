// Report tables that go into a paper without hand editing (issue 28): only the parameters that vary
// between a builder's rows are in the rows, the shared ones under the table; `--columns` picks columns;
// LaTeX tables wider than the page are split by columns; the HTML page holds every table and figure.
// The LaTeX widths themselves are checked by pdflatex in tests/scripts/test_latex_fit.py.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "harness/report/html_report.h"
#include "harness/report/report.h"
#include "harness/report/report_table.h"
#include "harness/report/table_fit.h"
#include "harness/run/csv.h"
#include "tests/support/error_of.h"
#include "tests/support/process_temp_dir.h"

namespace sahbench {
namespace {

using test::error_of;

std::filesystem::path temp_path(const std::string& name) {
  const auto dir = test::process_temp_dir("paper_tables");
  const auto path = dir / name;
  std::filesystem::remove_all(path);
  return path;
}

std::vector<std::string> columns() {
  std::vector<std::string> out = design_columns();
  for (const char* c : {"run_fingerprint", "build_ms_samples", "trace_mrays_samples",
                        "build_layout_ms_median", "build_layout_ms_samples"})
    if (std::find(out.begin(), out.end(), c) == out.end()) out.push_back(c);
  return out;
}

// One cell's row; samples of three rounds around the median, so that ratios have intervals.
CsvRow row(const std::string& builder, const std::string& params, const std::string& layout,
           const std::string& ray_set, double build_ms, double mrays,
           const std::string& scene = "proc:soup") {
  auto three = [](double v) {
    return std::to_string(v * 0.98) + ";" + std::to_string(v) + ";" + std::to_string(v * 1.03);
  };
  return {{"run_id", "r1"},
          {"run_fingerprint", "0123456789abcdef"},
          {"git_commit", "abc123"},
          {"cpu", "Test CPU"},
          {"isa", "avx2"},
          {"compiler", "gcc"},
          {"threads", "1"},
          {"scene", scene},
          {"scene_triangles", "100"},
          {"frame", "0"},
          {"builder", builder},
          {"builder_params", params},
          {"layout", layout},
          {"build_ms_median", std::to_string(build_ms)},
          {"build_ms_samples", three(build_ms)},
          {"build_layout_ms_median", std::to_string(build_ms + 1.0)},
          {"build_layout_ms_samples", three(build_ms + 1.0)},
          {"build_reps", "3"},
          {"mem_bytes", "1048576"},
          {"sah_cost", builder == "embree" ? "" : "40.5"},
          {"sah_c_trav", "1"},
          {"sah_c_isect", "1"},
          {"ray_set", ray_set},
          {"trace_mrays_median", std::to_string(mrays)},
          {"trace_mrays_samples", three(mrays)},
          {"trace_reps", "3"}};
}

// Two binned_sah builders that differ in bins only, beside Embree's anchor; `ray_sets` ray sets each.
std::filesystem::path two_builders(const std::string& name, const std::vector<std::string>& ray_sets,
                                   bool with_embree = true) {
  const auto path = temp_path(name);
  CsvWriter w(path, columns());
  for (const auto& rs : ray_sets) {
    if (with_embree) w.append(row("embree", "quality=medium", "embree_1", rs, 10.0, 8.0));
    w.append(row("binned_sah", "bins=8;max_leaf=8;c_trav=1", "bvh2", rs, 5.0, 6.0));
    w.append(row("binned_sah", "bins=32;max_leaf=8;c_trav=1", "bvh2", rs, 7.0, 7.0));
  }
  return path;
}

std::string report(const std::filesystem::path& csv, ReportFormat format,
                   PageWidth width = PageWidth::kSingle, std::vector<std::string> columns = {}) {
  ReportOptions options({csv}, "", format);
  options.width = width;
  options.columns = std::move(columns);
  std::ostringstream out;
  print_report(options, out);
  return out.str();
}

// The lines of `text` between the first line containing `from` and the next containing `to`.
std::string between(const std::string& text, const std::string& from, const std::string& to) {
  const std::size_t a = text.find(from);
  if (a == std::string::npos) return {};
  const std::size_t b = text.find(to, a);
  return text.substr(a, b == std::string::npos ? std::string::npos : b - a);
}

TEST(PaperTables, MarkdownRowsNameOnlyTheParameterThatVaries) {
  const std::string md = report(two_builders("md.csv", {"primary"}), ReportFormat::kMarkdown);
  std::string rows;  // the table's lines
  std::istringstream lines(md);
  for (std::string line; std::getline(lines, line);)
    if (line.starts_with("| ")) rows += line + "\n";
  EXPECT_NE(rows.find("| binned_sah [bins=8] | bvh2 |"), std::string::npos) << md;
  EXPECT_NE(rows.find("| binned_sah [bins=32] | bvh2 |"), std::string::npos) << md;
  EXPECT_NE(rows.find("| embree | embree_1 |"), std::string::npos) << md;
  for (const char* shared : {"max_leaf", "c_trav", "quality"})
    EXPECT_EQ(rows.find(shared), std::string::npos) << rows;
  // The shared parameters are under the table.
  EXPECT_NE(
      md.find(
          "Parameters common to a builder's rows: binned_sah max_leaf=8, c_trav=1; embree quality=medium."),
      std::string::npos)
      << md;
}

TEST(PaperTables, LatexRowsNameOnlyTheParameterThatVaries) {
  const std::string tex = report(two_builders("tex.csv", {"primary"}), ReportFormat::kLatex);
  const std::string body = between(tex, "\\midrule", "\\bottomrule");
  EXPECT_NE(body.find("binned\\_sah {\\scriptsize bins=8} & bvh2 & "), std::string::npos) << tex;
  EXPECT_NE(body.find("binned\\_sah {\\scriptsize bins=32} & bvh2 & "), std::string::npos) << tex;
  for (const char* shared : {"max\\_leaf", "c\\_trav", "quality"})
    EXPECT_EQ(body.find(shared), std::string::npos) << body;
  EXPECT_NE(tex.find("binned\\_sah max\\_leaf=8, c\\_trav=1; embree quality=medium."), std::string::npos)
      << tex;
  // booktabs, a short caption (the legend carries the rest), ratios with their interval as offsets.
  EXPECT_NE(tex.find("\\toprule"), std::string::npos);
  EXPECT_NE(
      tex.find("\\caption{proc:soup (100 triangles), 1 thread; Test CPU (built for avx2), commit abc123.}"),
      std::string::npos)
      << tex;
  EXPECT_NE(body.find("$^{+"), std::string::npos) << body;
  EXPECT_NE(body.find("}_{-"), std::string::npos) << body;
}

TEST(PaperTables, OneLayoutIsNamedUnderTheTableNotInAColumn) {
  const auto csv = two_builders("one_layout.csv", {"primary"}, false);
  const std::string md = report(csv, ReportFormat::kMarkdown);
  EXPECT_NE(md.find("| builder | build ms |"), std::string::npos) << md;
  EXPECT_NE(md.find("| binned_sah [bins=8] | "), std::string::npos) << md;
  EXPECT_NE(md.find("Every row traces the bvh2 layout."), std::string::npos) << md;
  const std::string tex = report(csv, ReportFormat::kLatex);
  EXPECT_NE(tex.find("\\begin{tabular}{lrrrrr}"), std::string::npos) << tex;
  EXPECT_EQ(between(tex, "\\midrule", "\\bottomrule").find("bvh2"), std::string::npos) << tex;
}

TEST(PaperTables, ColumnsPicksColumnsInTheOrderGiven) {
  const auto csv = two_builders("columns.csv", {"primary", "shadow"});
  const std::string md = report(csv, ReportFormat::kMarkdown, PageWidth::kSingle, {"shadow", "sah"});
  EXPECT_NE(md.find("| builder | layout | shadow Mrays/s | SAH |\n"), std::string::npos) << md;
  const std::string rays = report(csv, ReportFormat::kMarkdown, PageWidth::kSingle, {"rays"});
  EXPECT_NE(rays.find("| builder | layout | primary Mrays/s | shadow Mrays/s |\n"), std::string::npos)
      << rays;
  const std::string error =
      error_of([&] { report(csv, ReportFormat::kMarkdown, PageWidth::kSingle, {"diffuse"}); });
  EXPECT_NE(error.find("no column 'diffuse'"), std::string::npos) << error;
  EXPECT_NE(error.find("build_layout"), std::string::npos) << error;  // the known keys
}

TEST(PaperTables, WideTablesAreSplitIntoPartsThatFit) {
  const auto csv = two_builders("wide.csv", {"primary", "shadow", "diffuse", "ambient_occlusion"});
  for (const PageWidth width : {PageWidth::kSingle, PageWidth::kDouble}) {
    const std::string tex = report(csv, ReportFormat::kLatex, width);
    std::size_t parts = 0;
    for (std::size_t at = tex.find("\\begin{table}"); at != std::string::npos;
         at = tex.find("\\begin{table}", at + 1))
      ++parts;
    EXPECT_GT(parts, 1u) << tex;
    EXPECT_NE(tex.find(" (part 2 of "), std::string::npos) << tex;
    EXPECT_NE(tex.find("\\label{tab:proc-soup-t1-p2}"), std::string::npos) << tex;
    // Every column heads exactly one part: counted in the header rows only (\toprule to \midrule), not
    // in captions.
    std::string headers;
    for (std::size_t at = tex.find("\\toprule"); at != std::string::npos; at = tex.find("\\toprule", at + 1))
      headers += tex.substr(at, tex.find("\\midrule", at) - at);
    for (const char* header : {"Build +", "SAH", "primary", "shadow", "diffuse", "ambient\\_occlusion"}) {
      std::size_t seen = 0;
      for (std::size_t at = headers.find(header); at != std::string::npos; at = headers.find(header, at + 1))
        ++seen;
      EXPECT_EQ(seen, 1u) << header << " in the header rows:\n" << headers;
    }
  }
}

TEST(PaperTables, SplitPartsAreEstimatedWithinThePageWidth) {
  ReportTable table;
  table.title = table.caption = "t.";
  table.label = "tab:t";
  for (int c = 0; c < 9; ++c)
    table.columns.push_back({"c", "Column\n(Mrays/s)", 2, true, "c" + std::to_string(c)});
  for (int r = 0; r < 3; ++r) {
    ReportRow row{"wide_binned_sah [arity=8]", "wide_binned_sah [arity=8]", "bvh8", {}};
    for (int c = 0; c < 9; ++c) {
      ReportCell cell{1234.5, std::nullopt, false};
      cell.interval = RatioInterval{1.08, 1.03, 1.12, 3};
      row.cells.push_back(cell);
    }
    table.rows.push_back(row);
  }
  for (const PageWidth width : {PageWidth::kSingle, PageWidth::kDouble}) {
    const auto parts = split_to_width(table, width);
    ASSERT_GT(parts.size(), 1u);
    std::size_t columns = 0;
    for (const auto& part : parts) {
      columns += part.columns.size();
      EXPECT_LE(estimated_latex_width(part, width), page_width_pt(width));
    }
    EXPECT_EQ(columns, table.columns.size());
  }
  EXPECT_EQ(split_to_width(select_columns(table, {"c0"}), PageWidth::kDouble).size(), 1u);
}

TEST(PaperTables, PageWidthIsSingleOrDouble) {
  EXPECT_EQ(parse_page_width("single"), PageWidth::kSingle);
  EXPECT_EQ(parse_page_width("double"), PageWidth::kDouble);
  EXPECT_NE(error_of([] { parse_page_width("triple"); }).find("'triple'"), std::string::npos);
}

TEST(HtmlReport, Base64MatchesRfc4648TestVectors) {
  EXPECT_EQ(base64_encode(""), "");
  EXPECT_EQ(base64_encode("f"), "Zg==");
  EXPECT_EQ(base64_encode("fo"), "Zm8=");
  EXPECT_EQ(base64_encode("foo"), "Zm9v");
  EXPECT_EQ(base64_encode("foob"), "Zm9vYg==");
  EXPECT_EQ(base64_encode("fooba"), "Zm9vYmE=");
  EXPECT_EQ(base64_encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64_encode(std::string("\xff\x00\x80", 3)), "/wCA");
}

TEST(HtmlReport, OnePageWithEveryTableAndFigureEmbedded) {
  const auto csv = temp_path("html.csv");
  {
    CsvWriter w(csv, columns());
    for (const char* scene : {"proc:a", "proc:b"}) {
      w.append(row("embree", "quality=medium", "embree_1", "primary", 10.0, 8.0, scene));
      w.append(row("binned_sah", "bins=8", "bvh2", "primary", 5.0, 6.0, scene));
    }
  }
  const auto figures = temp_path("figures");
  std::filesystem::create_directories(figures);
  std::ofstream(figures / "a.png", std::ios::binary) << "PNGDATA";
  std::ofstream(figures / "b.svg") << "<svg/>";
  std::ofstream(figures / "notes.txt") << "not a figure";
  ReportOptions options({csv}, "", ReportFormat::kHtml);
  options.figures = figures;
  std::ostringstream out;
  print_report(options, out);
  const std::string page = out.str();
  EXPECT_TRUE(page.starts_with("<!DOCTYPE html>")) << page;
  EXPECT_NE(page.find("</html>"), std::string::npos);
  std::size_t tables = 0;
  for (std::size_t at = page.find("<table>"); at != std::string::npos; at = page.find("<table>", at + 1))
    ++tables;
  EXPECT_EQ(tables, 3u) << page;  // one per scene, and the standing against Embree over both
  EXPECT_NE(page.find("Standing against Embree"), std::string::npos) << page;
  EXPECT_NE(page.find("src=\"data:image/png;base64," + base64_encode("PNGDATA") + "\""), std::string::npos)
      << page;
  EXPECT_NE(page.find("src=\"data:image/svg+xml;base64," + base64_encode("<svg/>") + "\""),
            std::string::npos);
  EXPECT_EQ(page.find("notes.txt"), std::string::npos);
  EXPECT_EQ(page.find("src=\"http"), std::string::npos);  // self-contained

  options.figures = figures / "missing";
  EXPECT_NE(error_of([&] { print_report(options, out); }).find("missing: --figures: no such folder"),
            std::string::npos);
}

}  // namespace
}  // namespace sahbench
