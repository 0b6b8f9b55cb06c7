// `sahbench report` on a hand-written CSV whose best values and ratios are known: Markdown keeps its
// layout, LaTeX is a booktabs table with escaped text, the best value of each column is marked, and the
// caption names the machine, commit, threads and repetitions.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "harness/csv.h"
#include "harness/report.h"
#include "harness/report_table.h"

namespace sahbench {
namespace {

std::filesystem::path temp_csv(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "sahbench_test_report";
  std::filesystem::create_directories(dir);
  const auto path = dir / name;
  std::filesystem::remove(path);
  return path;
}

CsvRow make_row(const std::string& builder, const std::string& params, const std::string& layout,
                const std::string& ray_set, double build_ms, double mem_bytes, const std::string& sah,
                double mrays, const std::string& frame = "0") {
  return {{"run_id", "r1"},
          {"git_commit", "abc123"},
          {"cpu", "Test CPU 9000"},
          {"isa", "avx2"},
          {"build_isa", "avx512"},
          {"compiler", "gcc"},
          {"threads", "2"},
          {"scene", "proc:soup"},
          {"scene_triangles", "100"},
          {"frame", frame},
          {"builder", builder},
          {"builder_params", params},
          {"layout", layout},
          {"build_ms_median", std::to_string(build_ms)},
          {"build_reps", "5"},
          {"mem_bytes", std::to_string(mem_bytes)},
          {"sah_cost", sah},
          {"ray_set", ray_set},
          {"trace_mrays_median", std::to_string(mrays)},
          {"trace_reps", "7"}};
}

// Embree medium (the anchor), two binned runs (one faster, one smaller), a sweep run with the lowest SAH.
std::filesystem::path write_results(const std::string& name) {
  const auto path = temp_csv(name);
  std::vector<std::string> columns = design_columns();
  columns.push_back("build_isa");
  CsvWriter w(path, columns);
  for (const std::string rs : {"primary", "shadow"}) {
    w.append(make_row("embree", "quality=medium", "embree_1", rs, 10.0, 4.0 * (1 << 20), "",
                      rs == "primary" ? 8.0 : 4.0));
    w.append(make_row("binned_sah", "bins=8;max_leaf=8", "bvh2", rs, 5.0, 2.0 * (1 << 20), "40.5", 2.0));
    w.append(make_row("binned_sah", "bins=32;max_leaf=8", "bvh2", rs, 20.0, 3.0 * (1 << 20), "39.25", 16.0));
    w.append(make_row("sweep_sah", "max_leaf=8", "bvh2_packed", rs, 30.0, 6.0 * (1 << 20), "38.0", 1.0));
  }
  return path;
}

TEST(Report, MarkdownMarksTheBestOfEachColumnWithRatiosAndCaption) {
  std::ostringstream out;
  print_report({{write_results("md.csv")}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("## proc:soup (100 triangles), 2 threads"), std::string::npos) << md;
  // Fastest build, smallest memory: binned bins=8; most rays/s: binned bins=32; lowest SAH: sweep.
  EXPECT_NE(md.find("| binned_sah [bins=8;max_leaf=8] | bvh2 | **5.0** (0.50x) | **2.0** (0.50x) | 40.50 | "
                    "2.00 (0.25x) |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| binned_sah [bins=32;max_leaf=8] | bvh2 | 20.0 (2.00x) | 3.0 (0.75x) | 39.25 | "
                    "**16.00** (2.00x) | "
                    "**16.00** (4.00x) |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| sweep_sah [max_leaf=8] | bvh2_packed | 30.0 (3.00x) | 6.0 (1.50x) | **38.00** |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| embree [quality=medium] | embree_1 | 10.0 (1.00x) | 4.0 (1.00x) | - | 8.00 (1.00x) | "
                    "4.00 (1.00x) |"),
            std::string::npos)
      << md;
  EXPECT_NE(
      md.find("Table: proc:soup (100 triangles), 2 threads; Test CPU 9000 (built for avx512), commit abc123; "
              "medians of 5 builds and 7 traces; kernels: avx2."),
      std::string::npos)
      << md;
}

TEST(Report, SahCostsUnderOtherConstantsAreNotedAndNotCompared) {
  // Two rows costed with c_trav = 1 and one with c_trav = 2, whose larger constants make its cost
  // incomparable (here it is even the lowest): it gets its constants as a note and no bold.
  const auto path = temp_csv("sah_models.csv");
  std::vector<std::string> columns = design_columns();
  for (const char* c : {"build_isa", "sah_c_trav", "sah_c_isect", "sah_block"}) columns.push_back(c);
  {
    CsvWriter w(path, columns);
    auto with_model = [](CsvRow row, const std::string& c_trav) {
      row["sah_c_trav"] = c_trav;
      row["sah_c_isect"] = "1";
      row["sah_block"] = "4";
      return row;
    };
    w.append(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 8.0));
    w.append(with_model(
        make_row("wide_collapse", "c_trav=1;bins=8", "bvh8", "primary", 5.0, 1 << 20, "40.5", 9.0), "1"));
    w.append(with_model(
        make_row("wide_collapse", "c_trav=1;bins=32", "bvh8", "primary", 6.0, 1 << 20, "39.25", 9.0), "1"));
    w.append(with_model(
        make_row("wide_collapse", "c_trav=2;bins=32", "bvh8", "primary", 7.0, 1 << 20, "30.0", 9.5), "2"));
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("| bvh8 | 6.0 (0.60x) | **1.0** (1.00x) | **39.25** |"), std::string::npos) << md;
  EXPECT_NE(md.find("| bvh8 | 7.0 (0.70x) | **1.0** (1.00x) | 30.00 [c_trav=2] |"), std::string::npos) << md;
  EXPECT_NE(
      md.find(
          "SAH costs are in each builder's own constants; those in brackets differ from the table's usual "
          "c_trav=1, c_isect=1, block=4, and are not compared."),
      std::string::npos)
      << md;

  // One model in the table: no notes and no such sentence (the other tests' rows have no model at all).
  std::ostringstream plain;
  print_report({{write_results("one_model.csv")}, ""}, plain);
  EXPECT_EQ(plain.str().find("own constants"), std::string::npos) << plain.str();
  EXPECT_EQ(plain.str().find("[c_"), std::string::npos) << plain.str();
  EXPECT_EQ(plain.str().find("[block"), std::string::npos) << plain.str();
}

TEST(Report, LatexIsABooktabsTableWithEscapedTextAndShortLabels) {
  std::ostringstream out;
  print_report({{write_results("tex.csv")}, "", ReportFormat::kLatex}, out);
  const std::string tex = out.str();
  EXPECT_NE(tex.find("\\begin{table}"), std::string::npos) << tex;
  EXPECT_NE(tex.find("\\begin{tabular}{llrrrrr}"), std::string::npos) << tex;
  EXPECT_NE(tex.find("\\toprule"), std::string::npos);
  EXPECT_NE(tex.find("\\midrule"), std::string::npos);
  EXPECT_NE(tex.find("\\bottomrule"), std::string::npos);
  EXPECT_NE(tex.find("\\label{tab:proc-soup-t2}"), std::string::npos) << tex;
  // Only the parameter that varies is in the row; the shared one is in the caption, escaped.
  EXPECT_NE(tex.find("    binned\\_sah [bins=8] & bvh2 & \\textbf{5.0} (0.50$\\times$) & \\textbf{2.0} "
                     "(0.50$\\times$) & 40.50"),
            std::string::npos)
      << tex;
  EXPECT_NE(tex.find("    sweep\\_sah & bvh2\\_packed & "), std::string::npos) << tex;
  EXPECT_NE(tex.find("binned\\_sah max\\_leaf=8"), std::string::npos) << tex;
  EXPECT_NE(
      tex.find(
          "\\caption{proc:soup (100 triangles), 2 threads; Test CPU 9000 (built for avx512), commit abc123"),
      std::string::npos)
      << tex;
  EXPECT_EQ(tex.find("**"), std::string::npos) << tex;
  // Every row ends with \\ and has one & per column boundary (2 label columns + 5 numeric columns).
  std::istringstream lines(tex);
  for (std::string line; std::getline(lines, line);)
    if (line.find("bvh2") != std::string::npos && line.find("\\\\") != std::string::npos) {
      EXPECT_EQ(std::count(line.begin(), line.end(), '&'), 6) << line;
    }
}

TEST(Report, LatexEscapesEverySpecialCharacter) {
  EXPECT_EQ(latex_escape("a_b%c&d$e#f{g}h~i^j\\k"),
            "a\\_b\\%c\\&d\\$e\\#f\\{g\\}h\\textasciitilde{}i\\textasciicircum{}j\\textbackslash{}k");
  EXPECT_EQ(latex_escape("plain text 1.5"), "plain text 1.5");
}

TEST(Report, BestIsJudgedOnPrintedValuesAndNeedsTwoValues) {
  ReportTable t;
  t.columns = {{"ms", "ms", 1, false}, {"rays", "rays", 2, true}};
  t.rows = {{"a", "a", "l", {{2.04, {}, false}, {2.0, {}, false}}},
            {"b", "b", "l", {{1.96, {}, false}, {std::nullopt, {}, false}}},
            {"c", "c", "l", {{2.5, {}, false}, {std::nullopt, {}, false}}}};
  mark_best(t);
  EXPECT_TRUE(t.rows[0].cells[0].best);  // 2.04 and 1.96 both print as 2.0
  EXPECT_TRUE(t.rows[1].cells[0].best);
  EXPECT_FALSE(t.rows[2].cells[0].best);
  EXPECT_FALSE(t.rows[0].cells[1].best);  // a lone value is not a win

  // Values below 1 keep three significant digits, so that small ones neither print as 0.0 nor tie.
  ReportTable small;
  small.columns = {{"build ms", "ms", 1, false}};
  small.rows = {{"a", "a", "l", {{0.0123, {}, false}}}, {"b", "b", "l", {{0.0456, {}, false}}}};
  mark_best(small);
  EXPECT_TRUE(small.rows[0].cells[0].best);
  EXPECT_FALSE(small.rows[1].cells[0].best);
  std::ostringstream md;
  render_markdown(small, md);
  EXPECT_NE(md.str().find("| a | l | **0.0123** |"), std::string::npos) << md.str();
  EXPECT_NE(md.str().find("| b | l | 0.0456 |"), std::string::npos) << md.str();
}

TEST(Report, FramesGetTablesOfTheirOwnAndMissingColumnsAreTolerated) {
  const auto path = temp_csv("frames.csv");
  {
    // A CSV from another writer: no triangle count, memory, SAH, embree_version or anchor.
    std::vector<std::string> columns = {"run_id",  "scene",           "threads",
                                        "builder", "builder_params",  "layout",
                                        "ray_set", "build_ms_median", "trace_mrays_median",
                                        "frame"};
    CsvWriter w(path, columns);
    w.append({{"run_id", "r"},
              {"scene", "anim"},
              {"threads", "1"},
              {"builder", "refit"},
              {"layout", "bvh2"},
              {"ray_set", "primary"},
              {"build_ms_median", "1.5"},
              {"trace_mrays_median", "3"},
              {"frame", "0"}});
    w.append({{"run_id", "r"},
              {"scene", "anim"},
              {"threads", "1"},
              {"builder", "refit"},
              {"layout", "bvh2"},
              {"ray_set", "primary"},
              {"build_ms_median", "1.7"},
              {"trace_mrays_median", "2"},
              {"frame", "3"}});
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("## anim (? triangles), 1 thread\n"), std::string::npos) << md;
  EXPECT_NE(md.find("## anim (? triangles), 1 thread, frame 3"), std::string::npos) << md;
  EXPECT_NE(md.find("| refit | bvh2 | 1.7 | - | - | 2.00 |"), std::string::npos) << md;
}

TEST(Report, BadInputIsAnErrorNamingIt) {
  EXPECT_THROW(parse_report_format("html"), Error);
  EXPECT_EQ(parse_report_format("latex"), ReportFormat::kLatex);
  EXPECT_THROW(print_report({{write_results("run.csv")}, "no_such_run"}, std::cout), Error);
  ReportOptions options{
      {write_results("out.csv")}, "", ReportFormat::kMarkdown, "/proc/no/such/dir/report.md"};
  try {
    std::ostringstream out;
    run_report_command(options, out);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/proc/no/such/dir/report.md"), std::string::npos) << e.what();
  }
  // A good path gets the whole report.
  options.output = temp_csv("report.md");
  std::ostringstream unused;
  run_report_command(options, unused);
  EXPECT_TRUE(unused.str().empty());
  std::ifstream in(options.output);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("## proc:soup"), std::string::npos);
}

}  // namespace
}  // namespace sahbench
