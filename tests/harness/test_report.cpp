// `sahbench report` on a hand-written CSV whose best values and ratios are known: Markdown keeps its
// layout, LaTeX is a booktabs table with escaped text, the best value of each column is marked, the
// caption names the machine, commit, threads and repetitions, timing ratios come with their 95% interval
// and a mark only where it excludes 1, and a CSV that is not sahbench's, or mixes two runs, is refused.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "core/error.h"
#include "harness/report/predictors.h"
#include "harness/report/ratio_stats.h"
#include "harness/report/report.h"
#include "harness/report/report_table.h"
#include "harness/run/csv.h"
#include "tests/support/error_of.h"
#include "tests/support/process_temp_dir.h"

namespace sahbench {
namespace {

std::filesystem::path temp_csv(const std::string& name) {
  const auto dir = test::process_temp_dir("report");
  const auto path = dir / name;
  std::filesystem::remove(path);
  return path;
}

using test::error_of;

std::vector<std::string> columns_with_samples() {
  std::vector<std::string> columns = design_columns();
  for (const char* c : {"build_isa", "run_fingerprint", "build_ms_samples", "trace_mrays_samples",
                        "build_layout_ms_median", "build_layout_ms_samples", "hit_fraction"})
    if (std::find(columns.begin(), columns.end(), c) == columns.end()) columns.push_back(c);
  return columns;
}

// columns_with_samples() and the SAH constants' columns.
std::vector<std::string> columns_with_models() {
  std::vector<std::string> columns = columns_with_samples();
  for (const char* c : {"sah_c_trav", "sah_c_isect", "sah_block"})
    if (std::find(columns.begin(), columns.end(), c) == columns.end()) columns.push_back(c);
  return columns;
}

// columns_with_samples() and the columns of the costs the report ranks against rays/s.
std::vector<std::string> columns_with_predictors() {
  std::vector<std::string> columns = columns_with_samples();
  for (const char* c : {"epo_cost", "sah_epo_cost", "cost_per_ray"}) columns.push_back(c);
  return columns;
}

// `row` with its SAH cost under c_trav, c_isect = 1 and sah_block.
CsvRow with_model(CsvRow row, const std::string& c_trav, const std::string& block) {
  row.insert_or_assign("sah_c_trav", c_trav);
  row.insert_or_assign("sah_c_isect", std::string("1"));
  row.insert_or_assign("sah_block", block);
  return row;
}

std::string join(const std::vector<double>& samples) {
  std::string out;
  for (const double v : samples) {
    if (!out.empty()) out += ';';
    out += std::to_string(v);
  }
  return out;
}

// Three rounds of the same value: exact ratios, with intervals of zero width. Our build + layout is the
// build plus 1 ms, Embree's the build (rtcCommitScene does both).
CsvRow make_row(const std::string& builder, const std::string& params, const std::string& layout,
                const std::string& ray_set, double build_ms, double mem_bytes, const std::string& sah,
                double mrays, const std::string& frame = "0") {
  auto three = [](double v) {
    const std::string s = std::to_string(v);
    return s + ";" + s + ";" + s;
  };
  return {{"run_id", "r1"},
          {"run_fingerprint", "0123456789abcdef"},
          {"build_ms_samples", three(build_ms)},
          {"trace_mrays_samples", three(mrays)},
          {"build_layout_ms_median", std::to_string(builder == "embree" ? build_ms : build_ms + 1.0)},
          {"build_layout_ms_samples", three(builder == "embree" ? build_ms : build_ms + 1.0)},
          {"hit_fraction", ray_set == "primary" ? "0.8123" : "0.4567"},
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
  CsvWriter w(path, columns_with_samples());
  for (const std::string rs : {"primary", "shadow"}) {
    w.append(make_row("embree", "quality=medium", "embree_1", rs, 10.0, 4.0 * (1 << 20), "",
                      rs == "primary" ? 8.0 : 4.0));
    w.append(make_row("binned_sah", "bins=8;max_leaf=8", "bvh2", rs, 5.0, 2.0 * (1 << 20), "40.5", 2.0));
    w.append(make_row("binned_sah", "bins=32;max_leaf=8", "bvh2", rs, 20.0, 3.0 * (1 << 20), "39.25", 16.0));
    w.append(make_row("sweep_sah", "max_leaf=8", "bvh2_packed", rs, 30.0, 6.0 * (1 << 20), "38.0", 1.0));
  }
  return path;
}

// Two tree files: the label names the file, not also the hash of its bytes (recorded beside it in the
// CSV), which widened the LaTeX table past the page; a hash that alone tells two rows apart stays.
TEST(Report, FileLabelsNameThePathWithoutItsHash) {
  const auto path = temp_csv("files.csv");
  {
    CsvWriter w(path, columns_with_samples());
    w.append(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 4.0 * (1 << 20), "", 8.0));
    w.append(make_row("file", "path=a.sbt;path_hash=0x2b5477d10d8a3dff;c_trav=1", "bvh2", "primary", 5.0,
                      2.0 * (1 << 20), "40.5", 2.0));
    w.append(make_row("file", "path=b.sbt;path_hash=0x0123456789abcdef;c_trav=1", "bvh2", "primary", 5.0,
                      2.0 * (1 << 20), "40.5", 2.0));
    w.append(make_row("tagged", "x=1;y_hash=0x1", "bvh2", "primary", 5.0, 2.0 * (1 << 20), "40.5", 2.0));
    w.append(make_row("tagged", "x=1;y_hash=0x2", "bvh2", "primary", 5.0, 2.0 * (1 << 20), "40.5", 2.0));
    // Two files of one name (the CSV records no folder) and a third: the hash tells the first two apart.
    for (const char* params :
         {"path=t.sbt;path_hash=0x1", "path=t.sbt;path_hash=0x2", "path=u.sbt;path_hash=0x3"})
      w.append(make_row("twice", params, "bvh2", "primary", 5.0, 2.0 * (1 << 20), "40.5", 2.0));
  }
  std::ostringstream md;
  print_report({{path}, ""}, md);
  EXPECT_NE(md.str().find("| file [path=a.sbt] | bvh2 |"), std::string::npos) << md.str();
  EXPECT_NE(md.str().find("| file [path=b.sbt] | bvh2 |"), std::string::npos) << md.str();
  EXPECT_EQ(md.str().find("path=a.sbt;path_hash"), std::string::npos) << md.str();
  EXPECT_NE(md.str().find("| tagged [y_hash=0x1] |"), std::string::npos) << md.str();
  EXPECT_NE(md.str().find("| twice [path=t.sbt;path_hash=0x1] |"), std::string::npos) << md.str();
  EXPECT_NE(md.str().find("| twice [path=t.sbt;path_hash=0x2] |"), std::string::npos) << md.str();
}

TEST(Report, MarkdownMarksTheBestOfEachColumnWithRatiosAndCaption) {
  std::ostringstream out;
  print_report({{write_results("md.csv")}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("## proc:soup (100 triangles), 2 threads"), std::string::npos) << md;
  EXPECT_NE(md.find("| builder | layout | build ms | build+layout ms | memory MiB | SAH | primary Mrays/s | "
                    "shadow Mrays/s |"),
            std::string::npos)
      << md;
  // Fastest build, smallest memory: binned bins=8; most rays/s: binned bins=32; lowest SAH: sweep. Build
  // + layout is against Embree's build; behind Embree (more time, fewer rays/s) is marked, and so is
  // ahead, since each interval (of zero width here) excludes 1.
  EXPECT_NE(
      md.find(
          "| binned_sah [bins=8] | bvh2 | **5.0** | **6.0** (0.60 [0.60, 0.60] \u25B2) | "
          "**2.0** (0.50x) | 40.50 | 2.00 (0.25 [0.25, 0.25] \u25BC) | 2.00 (0.50 [0.50, 0.50] \u25BC) |"),
      std::string::npos)
      << md;
  EXPECT_NE(
      md.find("| binned_sah [bins=32] | bvh2 | 20.0 | 21.0 (2.10 [2.10, 2.10] \u25BC) | "
              "3.0 (0.75x) | 39.25 | **16.00** (2.00 [2.00, 2.00] \u25B2) | **16.00** (4.00 [4.00, 4.00] "
              "\u25B2) |"),
      std::string::npos)
      << md;
  EXPECT_NE(md.find("| sweep_sah | bvh2_packed | 30.0 | 31.0 (3.10 [3.10, 3.10] \u25BC) | 6.0 "
                    "(1.50x) | **38.00** |"),
            std::string::npos)
      << md;
  // Embree against itself: within noise, no mark.
  EXPECT_NE(md.find("| embree | embree_1 | 10.0 | 10.0 (1.00 [1.00, 1.00]) | 4.0 (1.00x) | "
                    "- | 8.00 (1.00 [1.00, 1.00]) | 4.00 (1.00 [1.00, 1.00]) |"),
            std::string::npos)
      << md;
  EXPECT_NE(
      md.find("Share of rays that hit (closest) or are occluded (any hit): primary 0.8123, shadow 0.4567."),
      std::string::npos)
      << md;
  EXPECT_NE(md.find("\u25B2 ahead of Embree"), std::string::npos) << md;
  EXPECT_NE(
      md.find(
          "Table: proc:soup (100 triangles), 2 threads; Test CPU 9000 (built for avx512), commit abc123.\n\n"
          "Medians of 5 builds and 7 traces; kernels: avx2."),
      std::string::npos)
      << md;
}

// Embree in both modes, and wide_collapse through exact and fast kernels: like for like, the exact ones
// (the layouts' default tests, whatever their any-hit order or ISA) against Embree robust, every faster
// variant against Embree's default mode. `with_robust` false: the same run without Embree robust.
std::filesystem::path write_like_for_like(const std::string& name, bool with_robust) {
  const auto path = temp_csv(name);
  CsvWriter w(path, columns_with_samples());
  for (const std::string rs : {"primary", "shadow"}) {
    const double k = rs == "primary" ? 2.0 : 1.0;  // every row twice as fast on primary rays
    w.append(make_row("embree", "quality=medium", "embree_1", rs, 10.0, 4.0 * (1 << 20), "", 4.0 * k));
    if (with_robust)
      w.append(
          make_row("embree", "quality=medium;robust=1", "embree_1", rs, 20.0, 8.0 * (1 << 20), "", 2.0 * k));
    w.append(make_row("embree", "quality=medium", "embree_8", rs, 10.0, 4.0 * (1 << 20), "", 6.0 * k));
    for (const std::string layout :
         {"bvh8", "bvh8:anyhit=stored,isa=avx2", "bvh8:tri=mtn,box=fma", "bvh8:box=fast", "bvh8:tri=mt0"})
      w.append(make_row("wide_collapse", "c_trav=1", layout, rs, 5.0, 2.0 * (1 << 20), "30.0", 3.0 * k));
  }
  return path;
}

TEST(Report, ExactKernelsAreComparedWithEmbreeRobustAndFastOnesWithItsDefault) {
  std::ostringstream out;
  print_report({{write_like_for_like("like_for_like.csv", true)}, ""}, out);
  const std::string md = out.str();
  // Exact kernels against Embree robust: rays/s 3/2 = 1.5 on both sets, build + layout 6 / 20, memory 2 / 8.
  for (const std::string layout : {"bvh8", "bvh8:anyhit=stored,isa=avx2"})
    EXPECT_NE(md.find("| wide_collapse | " + layout +
                      " \u2020 | **5.0** | **6.0** (0.30 [0.30, 0.30] \u25B2) | **2.0** (0.25x) | **30.00** "
                      "| 6.00 (1.50 [1.50, "
                      "1.50] \u25B2) | 3.00 (1.50 [1.50, 1.50] \u25B2) |"),
              std::string::npos)
        << layout << "\n"
        << md;
  // Faster variants against Embree's default mode: 3/4, build + layout 6 / 10, memory 2 / 4.
  for (const std::string layout : {"bvh8:tri=mtn,box=fma", "bvh8:box=fast", "bvh8:tri=mt0"})
    EXPECT_NE(md.find("| wide_collapse | " + layout +
                      " | **5.0** | **6.0** (0.60 [0.60, 0.60] \u25B2) | **2.0** (0.50x) | **30.00** | 6.00 "
                      "(0.75 [0.75, 0.75] "
                      "\u25BC) | 3.00 (0.75 [0.75, 0.75] \u25BC) |"),
              std::string::npos)
        << layout << "\n"
        << md;
  // Embree's own rows, robust mode included, against its default mode: what robustness costs it.
  EXPECT_NE(md.find("| embree [robust=1] | embree_1 | 20.0 | 20.0 (2.00 [2.00, 2.00] \u25BC) | "
                    "8.0 (2.00x) | - | 4.00 (0.50 [0.50, 0.50] \u25BC) |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| embree | embree_8 | 10.0 | 10.0 (1.00 [1.00, 1.00]) |"), std::string::npos) << md;
  EXPECT_EQ(md.find("embree_1 \u2020"), std::string::npos) << md;
  EXPECT_NE(
      md.find("like for like: rows marked \u2020 (our exact kernels: watertight triangle test, robust box "
              "test) to Embree's robust mode (RTC_SCENE_FLAG_ROBUST"),
      std::string::npos)
      << md;
  EXPECT_NE(md.find("Like for like: where the run has Embree's robust mode"), std::string::npos) << md;

  std::ostringstream tex;
  print_report({{write_like_for_like("like_for_like_tex.csv", true)}, "", ReportFormat::kLatex}, tex);
  EXPECT_NE(tex.str().find("wide\\_collapse & bvh8$^\\dagger$ & "), std::string::npos) << tex.str();
  // Only the robust row has robust=1: it is no parameter common to Embree's rows.
  EXPECT_NE(tex.str().find("    embree {\\scriptsize robust=1} & embree\\_1 & 20.0"), std::string::npos)
      << tex.str();
  EXPECT_NE(tex.str().find("    embree & embree\\_1 & 10.0"), std::string::npos) << tex.str();
  EXPECT_NE(tex.str().find("common to a builder's rows: embree quality=medium; wide"), std::string::npos)
      << tex.str();
  EXPECT_NE(tex.str().find("wide\\_collapse & bvh8:tri=mtn,box=fma & "), std::string::npos) << tex.str();
  EXPECT_NE(tex.str().find("rows marked \\textdagger{} (our exact kernels"), std::string::npos) << tex.str();
  EXPECT_EQ(tex.str().find("\u2020"), std::string::npos) << "LaTeX gets \\textdagger\n" << tex.str();
}

TEST(Report, ARowCutOffMidWriteIsLeftOutWithANote) {
  const auto whole = write_results("whole.csv");
  std::string text;
  {
    std::ifstream in(whole);
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const auto cut = temp_csv("cut.csv");
  std::ofstream(cut) << text.substr(0, text.size() - 10);
  std::ostringstream out;
  print_report({{cut}, ""}, out);
  EXPECT_NE(out.str().find("Note: " + cut.string() + ": its last line is incomplete"), std::string::npos)
      << out.str();
  std::ostringstream plain;
  print_report({{whole}, ""}, plain);
  EXPECT_EQ(plain.str().find("incomplete"), std::string::npos) << plain.str();
}

TEST(Report, RowsWhoseEmbreeModeTheRunLacksSaySo) {
  // Embree's robust mode alone: the exact kernels have their ratios, the fast variants none, and the
  // legend says why.
  const auto path = temp_csv("robust_only.csv");
  {
    CsvWriter w(path, columns_with_samples());
    w.append(
        make_row("embree", "quality=medium;robust=1", "embree_1", "primary", 20.0, 8.0 * (1 << 20), "", 2.0));
    w.append(make_row("wide_collapse", "c_trav=1", "bvh8", "primary", 5.0, 2.0 * (1 << 20), "30.0", 3.0));
    w.append(make_row("wide_collapse", "c_trav=1", "bvh8:tri=mtn,box=fma", "primary", 5.0, 2.0 * (1 << 20),
                      "30.0", 3.0));
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("| **3.00** (1.50 [1.50, 1.50] \u25B2) |"), std::string::npos) << md;
  EXPECT_NE(md.find("Rows without ratios: this run has no Embree medium 1-ray in its default mode to compare "
                    "them with"),
            std::string::npos)
      << md;
  // With both modes, no such sentence.
  std::ostringstream both;
  print_report({{write_like_for_like("both_modes.csv", true)}, ""}, both);
  EXPECT_EQ(both.str().find("Rows without ratios"), std::string::npos) << both.str();
}

TEST(Report, WithoutEmbreeRobustEveryRowKeepsEmbreesDefaultMode) {
  std::ostringstream out;
  print_report({{write_like_for_like("default_only.csv", false)}, ""}, out);
  const std::string md = out.str();
  for (const std::string layout : {"bvh8", "bvh8:anyhit=stored,isa=avx2", "bvh8:tri=mtn,box=fma"})
    EXPECT_NE(md.find("| wide_collapse | " + layout +
                      " | **5.0** | **6.0** (0.60 [0.60, 0.60] \u25B2) | **2.0** (0.50x) | **30.00** | 6.00 "
                      "(0.75 [0.75, 0.75] "
                      "\u25BC) |"),
              std::string::npos)
        << layout << "\n"
        << md;
  EXPECT_EQ(md.find("\u2020"), std::string::npos) << md;
  EXPECT_EQ(md.find("robust"), std::string::npos) << md;
  EXPECT_NE(
      md.find("In parentheses: ratio to Embree (quality=medium, rtcIntersect1/rtcOccluded1) in the same "
              "run; for build + layout"),
      std::string::npos)
      << md;
}

// Our packet layouts against Embree's packets: the faster of its widths in the cell (embree_16 on
// primary rays, embree_8 on shadow rays here), in the mode the row's kernels are compared with.
TEST(Report, PacketLayoutsAreComparedWithEmbreesFastestPacketWidth) {
  const auto path = temp_csv("packets.csv");
  {
    CsvWriter w(path, columns_with_samples());
    for (const std::string rs : {"primary", "shadow"}) {
      const bool primary = rs == "primary";
      w.append(make_row("embree", "quality=medium", "embree_1", rs, 10.0, 4.0 * (1 << 20), "", 4.0));
      w.append(make_row("embree", "quality=medium", "embree_8", rs, 10.0, 4.0 * (1 << 20), "",
                        primary ? 5.0 : 8.0));
      w.append(make_row("embree", "quality=medium", "embree_16", rs, 10.0, 4.0 * (1 << 20), "",
                        primary ? 6.0 : 2.0));
      w.append(make_row("embree", "quality=medium;robust=1", "embree_1", rs, 20.0, 8.0 * (1 << 20), "", 2.0));
      w.append(make_row("embree", "quality=medium;robust=1", "embree_8", rs, 20.0, 8.0 * (1 << 20), "", 4.0));
      w.append(make_row("wide_collapse", "c_trav=1", "bvh8:tri=mtn,box=fma,packet=8", rs, 5.0,
                        2.0 * (1 << 20), "30.0", 3.0));
      w.append(make_row("wide_collapse", "c_trav=1", "bvh8:packet=8", rs, 5.0, 2.0 * (1 << 20), "30.0", 3.0));
      w.append(make_row("wide_collapse", "c_trav=1", "bvh8", rs, 5.0, 2.0 * (1 << 20), "30.0", 3.0));
    }
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  const std::string md = out.str();
  // Fast variant in packets: 3 / 6 (embree_16) on primary rays, 3 / 8 (embree_8) on shadow rays.
  EXPECT_NE(
      md.find("| bvh8:tri=mtn,box=fma,packet=8 | **5.0** | **6.0** (0.60 [0.60, 0.60] \u25B2) | **2.0** "
              "(0.50x) | **30.00** | 3.00 (0.50 [0.50, 0.50] \u25BC) | 3.00 (0.38 [0.38, 0.38] \u25BC) |"),
      std::string::npos)
      << md;
  // Exact kernels in packets against Embree robust's packets: 3 / 4.
  EXPECT_NE(
      md.find("| bvh8:packet=8 \u2020 | **5.0** | **6.0** (0.30 [0.30, 0.30] \u25B2) | **2.0** (0.25x) | "
              "**30.00** | 3.00 (0.75 [0.75, 0.75] \u25BC) | 3.00 (0.75 [0.75, 0.75] \u25BC) |"),
      std::string::npos)
      << md;
  // One ray at a time stays against Embree robust 1-ray: 3 / 2.
  EXPECT_NE(
      md.find("| bvh8 \u2020 | **5.0** | **6.0** (0.30 [0.30, 0.30] \u25B2) | **2.0** (0.25x) | **30.00** | "
              "3.00 (1.50 [1.50, 1.50] \u25B2) | 3.00 (1.50 [1.50, 1.50] \u25B2) |"),
      std::string::npos)
      << md;
  EXPECT_NE(md.find("our packet layouts (packet=8, 16) against Embree's packets instead"), std::string::npos)
      << md;
}

TEST(Report, TheCaptionNamesTheIsaOfEachLayoutWhereTheyDiffer) {
  const auto path = temp_csv("isas.csv");
  {
    CsvWriter w(path, columns_with_samples());
    auto on = [](CsvRow row, const std::string& isa) {
      row["isa"] = isa;
      return row;
    };
    w.append(on(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 8.0),
                "embree:avx2"));
    w.append(on(make_row("embree", "quality=medium", "embree_8", "primary", 10.0, 1 << 20, "", 8.0),
                "embree:avx2"));
    w.append(on(make_row("binned_sah", "bins=8", "bvh2", "primary", 5.0, 1 << 20, "40", 2.0), "scalar"));
    w.append(
        on(make_row("binned_sah", "bins=8", "bvh2_packed", "primary", 5.0, 1 << 20, "40", 2.0), "scalar"));
    w.append(on(make_row("wide_collapse", "", "bvh8", "primary", 5.0, 1 << 20, "30", 9.0), "avx2"));
    w.append(
        on(make_row("wide_collapse", "", "bvh8:isa=avx512", "primary", 5.0, 1 << 20, "30", 9.0), "avx512"));
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  EXPECT_NE(
      out.str().find("kernels: embree:avx2 for embree_1, embree_8; scalar for bvh2, bvh2_packed; avx2 for "
                     "bvh8; avx512 for bvh8:isa=avx512."),
      std::string::npos)
      << out.str();
}

// A note every row of one ray set carries (a shadow set's enclosed lights) is printed under the table for
// that set, one every row carries (the view) for the table; a note of some rows only is not.
TEST(Report, NotesOfARaySetOrOfEveryRowArePrintedUnderTheTable) {
  const auto path = temp_csv("notes.csv");
  const std::string view = "camera eye (0, 0, 10) target (0, 0, 0) up (0, 1, 0) fov 20";
  const std::string lights = "automatic light 1 of 4 enclosed by the scene";
  {
    std::vector<std::string> columns = columns_with_samples();
    columns.push_back("notes");
    CsvWriter w(path, columns);
    auto noted = [](CsvRow row, const std::string& notes) {
      row["notes"] = notes;
      return row;
    };
    for (const std::string rs : {"primary", "shadow"}) {
      const std::string notes = rs == "shadow" ? view + "; " + lights : view;
      w.append(noted(make_row("embree", "quality=medium", "embree_1", rs, 10.0, 1 << 20, "", 8.0), notes));
      w.append(noted(make_row("binned_sah", "bins=8", "bvh2", rs, 5.0, 1 << 20, "40", 2.0),
                     rs == "primary" ? notes + "; invalid tree, not traced: x" : notes));
    }
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  EXPECT_NE(out.str().find("Note: every row: " + view + "."), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("Note: ray set 'shadow': " + lights + "."), std::string::npos) << out.str();
  EXPECT_EQ(out.str().find("invalid tree"), std::string::npos) << out.str();
  EXPECT_EQ(out.str().find("ray set 'primary'"), std::string::npos) << out.str();
}

TEST(Report, CellsWithMismatchesSaySoAndAreNotMarkedBest) {
  // The fastest row answers 3 rays otherwise than the reference: its speed is printed with the count and
  // the bold goes to the fastest row that answers right.
  const auto path = temp_csv("wrong.csv");
  {
    std::vector<std::string> columns = columns_with_samples();
    columns.push_back("mismatches");
    CsvWriter w(path, columns);
    auto with_wrong = [](CsvRow row, const std::string& wrong) {
      row["mismatches"] = wrong;
      return row;
    };
    w.append(
        with_wrong(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 8.0), "0"));
    w.append(with_wrong(make_row("binned_sah", "bins=8", "bvh2", "primary", 5.0, 1 << 20, "40", 9.0), "3"));
    w.append(with_wrong(make_row("binned_sah", "bins=8", "bvh8", "primary", 5.0, 1 << 20, "40", 6.0), "0"));
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("9.00 [3 mismatches] (1.12 [1.12, 1.12] \u25B2) |"), std::string::npos) << md;
  EXPECT_NE(md.find("**8.00**"), std::string::npos) << md;
  EXPECT_EQ(md.find("**9.00"), std::string::npos) << md;
  EXPECT_NE(md.find("[N mismatches]: N rays of the set answered otherwise than the run's reference"),
            std::string::npos)
      << md;
  // Without wrong answers, no such sentence.
  std::ostringstream plain;
  print_report({{write_results("all_right.csv")}, ""}, plain);
  EXPECT_EQ(plain.str().find("mismatch"), std::string::npos) << plain.str();

  // Over two tables, the standing counts the cells with wrong answers in a column of their own.
  const auto two = temp_csv("wrong_two.csv");
  {
    std::vector<std::string> columns = columns_with_samples();
    columns.push_back("mismatches");
    CsvWriter w(two, columns);
    for (const std::string scene : {"proc:soup", "proc:sphere"}) {
      auto row = [&](const std::string& layout, double mrays, const std::string& wrong) {
        CsvRow r = make_row(layout == "embree_1" ? "embree" : "binned_sah",
                            layout == "embree_1" ? "quality=medium" : "bins=8", layout, "primary", 5.0,
                            1 << 20, layout == "embree_1" ? "" : "40", mrays);
        r["scene"] = scene;
        r["mismatches"] = wrong;
        return r;
      };
      w.append(row("embree_1", 8.0, "0"));
      w.append(row("bvh2", 9.0, scene == "proc:soup" ? "3" : "0"));
    }
  }
  std::ostringstream standing;
  print_report({{two}, ""}, standing);
  EXPECT_NE(standing.str().find("| with mismatches |"), std::string::npos) << standing.str();
  EXPECT_NE(standing.str().find("| binned_sah | 2 | 2 | 2 | 0 | 0 | 1 | 1.12 | 1.12 |"), std::string::npos)
      << standing.str();
}

TEST(Report, SahCostsUnderOtherConstantsAreNotedAndNotCompared) {
  // Two rows costed with c_trav = 1 and one with c_trav = 2, whose larger constants make its cost
  // incomparable (here it is even the lowest): it gets its constants as a note and no bold.
  const auto path = temp_csv("sah_models.csv");
  {
    CsvWriter w(path, columns_with_models());
    auto with_model = [](CsvRow row, const std::string& c_trav) {
      return sahbench::with_model(row, c_trav, "4");
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
  EXPECT_NE(md.find("| bvh8 | 6.0 | 7.0 (0.70 [0.70, 0.70] \u25B2) | **1.0** (1.00x) | **39.25** |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| bvh8 | 7.0 | 8.0 (0.80 [0.80, 0.80] \u25B2) | **1.0** (1.00x) | 30.00 [c_trav=2] |"),
            std::string::npos)
      << md;
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
  EXPECT_NE(tex.find("\\toprule"), std::string::npos);
  EXPECT_NE(tex.find("\\midrule"), std::string::npos);
  EXPECT_NE(tex.find("\\bottomrule"), std::string::npos);
  EXPECT_NE(tex.find("\\label{tab:proc-soup-t2}"), std::string::npos) << tex;
  // Only the parameter that varies is in the row, in script size; the shared one is in the legend,
  // escaped. The ratios are on the line under the values.
  EXPECT_NE(tex.find("    binned\\_sah {\\scriptsize bins=8} & bvh2 & \\textbf{5.0} & \\textbf{6.0} & "
                     "\\textbf{2.0} & 40.50"),
            std::string::npos)
      << tex;
  EXPECT_NE(tex.find("{\\scriptsize 0.60$^{+.00}_{-.00}$\\textuparrow} & {\\scriptsize 0.50$\\times$}"),
            std::string::npos)
      << tex;
  EXPECT_NE(tex.find("{\\scriptsize 0.25$^{+.00}_{-.00}$\\textdownarrow}"), std::string::npos) << tex;
  EXPECT_NE(tex.find("    sweep\\_sah & bvh2\\_packed & "), std::string::npos) << tex;
  EXPECT_NE(tex.find("binned\\_sah max\\_leaf=8"), std::string::npos) << tex;
  EXPECT_NE(
      tex.find(
          "\\caption{proc:soup (100 triangles), 2 threads; Test CPU 9000 (built for avx512), commit abc123"),
      std::string::npos)
      << tex;
  EXPECT_EQ(tex.find("**"), std::string::npos) << tex;
  EXPECT_EQ(tex.find("\u25B2"), std::string::npos) << tex;  // LaTeX gets \textuparrow, not the glyph
  // Every line of a tabular's body has one & per column boundary.
  std::istringstream lines(tex);
  std::size_t columns = 0, rows = 0;
  bool body = false;
  for (std::string line; std::getline(lines, line);) {
    if (line.starts_with("  \\begin{tabular}{")) columns = line.find('}', 18) - 18;
    if (line.find("\\midrule") != std::string::npos) body = true;
    if (line.find("\\bottomrule") != std::string::npos) body = false;
    if (body && line.ends_with("\\\\")) {
      EXPECT_EQ(static_cast<std::size_t>(std::count(line.begin(), line.end(), '&')), columns - 1) << line;
      ++rows;
    }
  }
  EXPECT_GT(rows, 0u);
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
  // One layout: named under the table rather than in a column.
  EXPECT_NE(md.str().find("| a | **0.0123** |"), std::string::npos) << md.str();
  EXPECT_NE(md.str().find("| b | 0.0456 |"), std::string::npos) << md.str();
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
  EXPECT_NE(md.find("| refit | 1.7 | - | - | - | 2.00 |"), std::string::npos) << md;
  EXPECT_NE(md.find("Every row traces the bvh2 layout."), std::string::npos) << md;
}

TEST(Report, BadInputIsAnErrorNamingIt) {
  EXPECT_THROW(parse_report_format("pdf"), Error);
  EXPECT_EQ(parse_report_format("html"), ReportFormat::kHtml);
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
  // The report over one of its own inputs would lose the rows: refused, the CSV as it was.
  const auto input = write_results("self.csv");
  const std::string before = (std::stringstream() << std::ifstream(input).rdbuf()).str();
  options = ReportOptions{{input}, "", ReportFormat::kMarkdown, input};
  try {
    run_report_command(options, unused);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--output " + input.string() + " is one of the result CSVs"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ((std::stringstream() << std::ifstream(input).rdbuf()).str(), before);
}

// Two files of two runs: the report is of the last file's run, and says which runs it left out.
TEST(Report, FilesOfOtherRunsAreNamedNotSilentlyLeftOut) {
  const auto first = write_results("run_one.csv");
  const auto second = temp_csv("run_two.csv");
  {
    CsvWriter w(second, columns_with_samples());
    for (CsvRow row : read_csv(first)) {
      row["run_id"] = "r2";
      w.append(row);
    }
  }
  std::ostringstream out;
  print_report({{first, second}, ""}, out);
  EXPECT_NE(out.str().find("# sahbench report: run r2"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("Note: this report is of run r2 (the last row of " + second.string() +
                           "); the files hold 1 other runs, left out (r1): name one with --run."),
            std::string::npos)
      << out.str();
  std::ostringstream one;
  print_report({{first}, ""}, one);
  EXPECT_EQ(one.str().find("other runs"), std::string::npos) << one.str();
}

TEST(Report, ACsvThatIsNotSahbenchsIsRefused) {
  const auto other = temp_csv("other.csv");
  std::ofstream(other) << "name,value\nx,1\n";
  const std::string e = error_of([&] { print_report({{other}, ""}, std::cout); });
  EXPECT_NE(e.find(other.string() + ":1: not a sahbench result CSV: the header has no column 'run_id'"),
            std::string::npos)
      << e;
  // The first missing column of run_id, scene, builder, layout, ray_set is named.
  const auto partial = temp_csv("partial.csv");
  std::ofstream(partial) << "run_id,scene,builder,ray_set\nr,s,b,primary\n";
  const std::string f = error_of([&] {
    print_report({{write_results("good.csv"), partial}, ""}, std::cout);
  });
  EXPECT_NE(f.find(partial.string() + ":1: not a sahbench result CSV: the header has no column 'layout'"),
            std::string::npos)
      << f;
}

TEST(Report, TwoFingerprintsInOneRunAreAnErrorNamingBoth) {
  const auto path = temp_csv("two_fingerprints.csv");
  {
    CsvWriter w(path, columns_with_samples());
    w.append(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 8.0));
    CsvRow other = make_row("binned_sah", "bins=8", "bvh2", "primary", 5.0, 1 << 20, "40.5", 9.0);
    other["run_fingerprint"] = "fedcba9876543210";
    w.append(other);
  }
  const std::string e = error_of([&] { print_report({{path}, ""}, std::cout); });
  EXPECT_NE(e.find("run 'r1' has rows of two fingerprints: " + path.string() +
                   ":2 has run_fingerprint "
                   "'0123456789abcdef', " +
                   path.string() + ":3 has 'fedcba9876543210'"),
            std::string::npos)
      << e;
}

TEST(Report, RatiosComeFromPairedSamplesWithAnIntervalAndAMarkOnlyOutsideTheNoise) {
  // Embree's samples drift from round to round (a busy machine); ours drift with them.
  const std::vector<double> embree = {8.0, 6.0, 9.0, 7.5, 8.5};
  const std::vector<double> fast = {12.1, 9.0, 13.4, 11.3, 12.8};  // about 1.5, tight
  const std::vector<double> same = {9.0, 5.5, 8.0, 8.2, 7.9};      // about 1.0, loose
  const std::vector<double> slow = {6.3, 4.8, 7.1, 6.1, 6.7};      // about 0.8, tight
  const auto path = temp_csv("intervals.csv");
  {
    CsvWriter w(path, columns_with_samples());
    auto with = [](CsvRow row, const std::vector<double>& trace) {
      row["trace_mrays_samples"] = join(trace);
      std::vector<double> sorted = trace;
      std::sort(sorted.begin(), sorted.end());
      row["trace_mrays_median"] = std::to_string(sorted[2]);
      return row;
    };
    w.append(with(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 0), embree));
    w.append(with(make_row("fast", "", "bvh2", "primary", 5.0, 1 << 20, "40", 0), fast));
    w.append(with(make_row("same", "", "bvh2", "primary", 5.0, 1 << 20, "40", 0), same));
    w.append(with(make_row("slow", "", "bvh2", "primary", 5.0, 1 << 20, "40", 0), slow));
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  const std::string md = out.str();
  const std::string f = format_ratio(paired_ratio(fast, embree)),
                    s = format_ratio(paired_ratio(same, embree)),
                    w = format_ratio(paired_ratio(slow, embree));
  EXPECT_EQ(f.substr(0, 4), "1.50") << f;
  EXPECT_EQ(s.substr(0, 4), "0.99") << s;
  EXPECT_EQ(w.substr(0, 4), "0.80") << w;
  EXPECT_NE(
      md.find("| fast | bvh2 | **5.0** | **6.0** (0.60 [0.60, 0.60] \u25B2) | **1.0** (1.00x) | **40.00** "
              "| **12.10** (" +
              f + " \u25B2) |"),
      std::string::npos)
      << md;
  EXPECT_NE(md.find("| same | bvh2 | **5.0** | **6.0** (0.60 [0.60, 0.60] \u25B2) | **1.0** (1.00x) | "
                    "**40.00** | 8.00 (" +
                    s + ") |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("(" + w + " \u25BC) |"), std::string::npos) << md;
  std::ostringstream tex;
  print_report({{path}, "", ReportFormat::kLatex}, tex);
  // LaTeX: the ratio on the line under the value, its interval as offsets, the mark after it.
  auto ratio_line = [&](const std::string& ratio) {
    const std::size_t at = tex.str().find("{\\scriptsize " + ratio.substr(0, 4) + "$^{+");
    return at == std::string::npos ? std::string() : tex.str().substr(at, tex.str().find('\n', at) - at);
  };
  EXPECT_NE(tex.str().find("\\textbf{12.10} \\\\"), std::string::npos) << tex.str();
  EXPECT_NE(ratio_line(f).find("}$\\textuparrow}"), std::string::npos) << tex.str();
  EXPECT_NE(ratio_line(s), "") << tex.str();
  EXPECT_EQ(ratio_line(s).find("arrow"), std::string::npos) << tex.str();
  EXPECT_NE(ratio_line(w).find("}$\\textdownarrow}"), std::string::npos) << tex.str();
}

TEST(Report, TheStandingCountsEachRowsCellsOverEveryTable) {
  const std::vector<double> embree = {8.0, 6.0, 9.0, 7.5, 8.5};
  const std::vector<double> fast = {12.1, 9.0, 13.4, 11.3, 12.8};  // about 1.5, tight: ahead, at 1.1
  const std::vector<double> nearly = {8.4, 6.3, 9.45, 7.9, 8.9};   // about 1.05, tight: ahead only
  const std::vector<double> same = {9.0, 5.5, 8.0, 8.2, 7.9};      // about 1.0, loose: within noise
  const std::vector<double> slow = {6.3, 4.8, 7.1, 6.1, 6.7};      // about 0.8, tight: behind
  auto with = [](CsvRow row, const std::string& scene, const std::vector<double>& trace) {
    row["scene"] = scene;
    row["trace_mrays_samples"] = join(trace);
    std::vector<double> sorted = trace;
    std::sort(sorted.begin(), sorted.end());
    row["trace_mrays_median"] = std::to_string(sorted[2]);
    return row;
  };
  // `scenes` tables (one per scene); in each, Embree 1-ray and 8-ray, and two rows of ours.
  auto write = [&](const std::string& name, int scenes) {
    const auto path = temp_csv(name);
    CsvWriter w(path, columns_with_samples());
    const std::vector<double>* ours[2][2] = {{&fast, &nearly}, {&same, &slow}};
    for (int s = 0; s < scenes; ++s) {
      const std::string scene = s == 0 ? "proc:a" : "proc:b";
      for (int r = 0; r < 2; ++r) {
        const std::string rs = r == 0 ? "primary" : "shadow";
        w.append(
            with(make_row("embree", "quality=medium", "embree_1", rs, 10.0, 1 << 20, "", 0), scene, embree));
        w.append(
            with(make_row("embree", "quality=medium", "embree_8", rs, 10.0, 1 << 20, "", 0), scene, fast));
        w.append(with(make_row("ours", "", "bvh2", rs, 5.0, 1 << 20, "40", 0), scene, *ours[s][r]));
        w.append(with(make_row("ours", "", "bvh2_packed", rs, 5.0, 1 << 20, "40", 0), scene, fast));
      }
    }
    return path;
  };
  std::ostringstream out;
  print_report({{write("standing.csv", 2)}, ""}, out);
  const std::string md = out.str();
  const std::size_t at = md.find("## Standing against Embree");
  ASSERT_NE(at, std::string::npos) << md;
  const std::string standing = md.substr(at, md.find("\nRatios are to", at) - at);  // up to the footer
  const std::string lowest = format_value(paired_ratio(slow, embree).estimate, 2),
                    highest = format_value(paired_ratio(fast, embree).estimate, 2);
  EXPECT_EQ(highest.substr(0, 4), "1.50") << highest;
  // bvh2: 4 cells, ahead 2 (at 1.1: 1), within noise 1, behind 1; Embree's own rows are not counted.
  EXPECT_NE(standing.find("| ours | bvh2 | 4 | 2 | 1 | 1 | 1 | " + lowest + " | " + highest + " |"),
            std::string::npos)
      << standing;
  EXPECT_NE(standing.find("| ours | bvh2_packed | 4 | 4 | 4 | 0 | 0 | " + highest + " | " + highest + " |"),
            std::string::npos)
      << standing;
  EXPECT_EQ(standing.find("embree_8"), std::string::npos) << standing;
  EXPECT_NE(standing.find("over the 2 tables of run r1"), std::string::npos) << standing;
  // No robust or packet anchors in this run: the legend names neither, and no column of bare ratios.
  EXPECT_EQ(standing.find("robust"), std::string::npos) << standing;
  EXPECT_EQ(standing.find("packet width"), std::string::npos) << standing;
  EXPECT_EQ(standing.find("no interval"), std::string::npos) << standing;
  // One table has no summary: it would repeat the table.
  std::ostringstream one;
  print_report({{write("standing_one.csv", 1)}, ""}, one);
  EXPECT_EQ(one.str().find("Standing against Embree"), std::string::npos) << one.str();
  // Ratios without an interval (rows without samples: medians) are counted in a column of their own and
  // in no verdict; exact kernels against Embree robust are marked and named.
  {
    const auto path = temp_csv("standing_bare.csv");
    {
      CsvWriter w(path, columns_with_samples());
      for (const std::string scene : {"proc:a", "proc:b"}) {
        auto bare = [&](CsvRow row) {
          row["scene"] = scene;
          row["trace_mrays_samples"] = "";
          return row;
        };
        w.append(bare(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 8.0)));
        w.append(bare(
            make_row("embree", "quality=medium;robust=1", "embree_1", "primary", 10.0, 1 << 20, "", 4.0)));
        w.append(bare(make_row("ours", "", "bvh8", "primary", 5.0, 1 << 20, "40", 6.0)));
      }
    }
    std::ostringstream bare_out;
    print_report({{path}, ""}, bare_out);
    const std::string text = bare_out.str();
    const std::size_t from = text.find("## Standing against Embree");
    ASSERT_NE(from, std::string::npos) << text;
    // 6 / 4 against Embree robust, twice, without intervals.
    EXPECT_NE(text.find("| ours \u2020 | 2 | 0 | 0 | 0 | 0 | 2 | 1.50 | 1.50 |", from), std::string::npos)
        << text;
    EXPECT_NE(text.find("rows marked \u2020 against Embree's robust mode", from), std::string::npos) << text;
    EXPECT_NE(text.find("No interval: a ratio from one round or from medians", from), std::string::npos)
        << text;
  }
  // LaTeX and HTML carry it too.
  std::ostringstream tex;
  print_report({{write("standing_tex.csv", 2)}, "", ReportFormat::kLatex}, tex);
  EXPECT_NE(tex.str().find("\\label{tab:standing}"), std::string::npos) << tex.str();
}

TEST(Report, RowsWithoutSamplesFallBackToTheRatioOfMediansWithoutAnInterval) {
  const auto path = temp_csv("no_samples.csv");
  {
    std::vector<std::string> columns = design_columns();
    std::erase_if(columns, [](const std::string& c) { return c.ends_with("_samples"); });
    CsvWriter w(path, columns);
    for (CsvRow row : {make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 8.0),
                       make_row("binned_sah", "bins=8", "bvh2", "primary", 5.0, 1 << 20, "40.5", 2.0)}) {
      std::erase_if(row, [&](const auto& kv) {
        return std::find(columns.begin(), columns.end(), kv.first) == columns.end();
      });
      w.append(row);
    }
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("| binned_sah | bvh2 | **5.0** |"), std::string::npos) << md;
  EXPECT_NE(md.find("2.00 (0.25 [medians]) |"), std::string::npos) << md;
  EXPECT_EQ(md.find("\u25BC)"), std::string::npos) << "no interval, no mark\n" << md;
  // A paper table says so too: the ratio is marked, and the legend tells what the mark means.
  std::ostringstream tex;
  print_report({{path}, "", ReportFormat::kLatex}, tex);
  EXPECT_NE(tex.str().find("0.25$^{\\mathrm{med}}$"), std::string::npos) << tex.str();
  EXPECT_NE(tex.str().find("one marked med the ratio of the medians"), std::string::npos) << tex.str();
}

TEST(Report, BadSamplesAreAnErrorNamingFileLineAndColumn) {
  const auto path = temp_csv("bad_samples.csv");
  {
    CsvWriter w(path, columns_with_samples());
    w.append(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 8.0));
    CsvRow bad = make_row("binned_sah", "bins=8", "bvh2", "primary", 5.0, 1 << 20, "40.5", 2.0);
    bad["trace_mrays_samples"] = "2.0;abc;2.0";
    w.append(bad);
  }
  const std::string e = error_of([&] { print_report({{path}, ""}, std::cout); });
  EXPECT_NE(e.find(path.string() + ":3: column 'trace_mrays_samples': sample 'abc' is not a number"),
            std::string::npos)
      << e;
}

// What compare refuses, report refuses too, rather than printing it as a result: a metric that is not a
// number, the same cell twice, a rate of zero, a negative time (a time may round to 0.0000 ms). A CSV with
// comment lines before its header is read.
TEST(Report, BadDataIsAnErrorAsInCompare) {
  auto report_of = [](CsvRow changed, const std::string& name, bool twice = false) {
    const auto path = temp_csv(name);
    {
      CsvWriter w(path, columns_with_samples());
      w.append(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 8.0));
      w.append(changed);
      if (twice) w.append(changed);
    }
    return error_of([&] {
      std::ostringstream out;
      print_report({{path}, ""}, out);
    });
  };
  const CsvRow good = make_row("binned_sah", "bins=8", "bvh2", "primary", 5.0, 1 << 20, "40.5", 9.0);
  CsvRow bad = good;
  bad["sah_cost"] = "abc";
  EXPECT_NE(report_of(bad, "abc_sah.csv").find("abc_sah.csv:3: column 'sah_cost': 'abc' is not a number"),
            std::string::npos);
  bad["sah_cost"] = "nan";
  EXPECT_NE(report_of(bad, "nan_sah.csv").find("column 'sah_cost': 'nan' is not finite"), std::string::npos);
  EXPECT_NE(report_of(good, "dup.csv", true)
                .find("dup.csv:3 and " + temp_csv("dup.csv").string() + ":4 are the same cell"),
            std::string::npos);
  bad = good;
  bad["trace_mrays_median"] = "0";
  bad["trace_mrays_samples"] = "0;0;0";
  EXPECT_NE(report_of(bad, "zero_rate.csv").find("column 'trace_mrays_median': 0 is not a positive rate"),
            std::string::npos);
  bad = good;
  bad["build_ms_median"] = "-1";
  EXPECT_NE(report_of(bad, "negative_build.csv").find("column 'build_ms_median': -1 is a negative time"),
            std::string::npos);

  const auto commented = temp_csv("commented.csv");
  {
    CsvWriter w(commented, columns_with_samples());
    w.append(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 8.0));
    w.append(good);
  }
  std::stringstream text;
  text << std::ifstream(commented).rdbuf();
  std::ofstream(commented) << "# a note before the header\n" << text.str();
  std::ostringstream out;
  print_report({{commented}, ""}, out);
  EXPECT_NE(out.str().find("| binned_sah |"), std::string::npos) << out.str();
}

TEST(Report, FewerCellsThanAnotherRunOfTheSameFingerprintAreNoted) {
  const auto path = temp_csv("fewer.csv");
  {
    CsvWriter w(path, columns_with_samples());
    auto in_run = [](CsvRow row, const std::string& run, const std::string& fingerprint,
                     const std::string& scene = "proc:soup") {
      row["run_id"] = run;
      row["run_fingerprint"] = fingerprint;
      row["scene"] = scene;
      return row;
    };
    // r0: the same config and build, every cell, and a second scene; r1: another fingerprint, more cells;
    // r2 (reported): without the sweep's shadow cell and the second scene.
    for (const std::string rs : {"primary", "shadow"}) {
      w.append(in_run(make_row("embree", "quality=medium", "embree_1", rs, 10.0, 1 << 20, "", 8.0), "r0",
                      "aaaaaaaaaaaaaaaa"));
      w.append(in_run(make_row("sweep_sah", "max_leaf=8", "bvh2", rs, 5.0, 1 << 20, "40", 8.0), "r0",
                      "aaaaaaaaaaaaaaaa"));
      w.append(in_run(make_row("embree", "quality=medium", "embree_1", rs, 10.0, 1 << 20, "", 8.0), "r0",
                      "aaaaaaaaaaaaaaaa", "proc:other"));
    }
    for (const std::string rs : {"primary", "shadow", "ao"})
      w.append(in_run(make_row("embree", "quality=medium", "embree_1", rs, 10.0, 1 << 20, "", 8.0), "r1",
                      "bbbbbbbbbbbbbbbb"));
    for (const std::string rs : {"primary", "shadow"})
      w.append(in_run(make_row("embree", "quality=medium", "embree_1", rs, 10.0, 1 << 20, "", 8.0), "r2",
                      "aaaaaaaaaaaaaaaa"));
    w.append(in_run(make_row("sweep_sah", "max_leaf=8", "bvh2", "primary", 5.0, 1 << 20, "40", 8.0), "r2",
                    "aaaaaaaaaaaaaaaa"));
  }
  for (const auto format : {ReportFormat::kMarkdown, ReportFormat::kLatex}) {
    std::ostringstream out;
    print_report({{path}, "", format}, out);
    const std::string text = out.str();
    EXPECT_NE(
        text.find("Note: this run has 3 cells here, run r0 of the same fingerprint had 4; missing: sweep"),
        std::string::npos)
        << text;
    EXPECT_EQ(text.find("run r1"), std::string::npos) << "another fingerprint\n" << text;
    EXPECT_NE(text.find("Note: Run r2 has no cells of proc:other at 2 threads (2 cells in run r0)"),
              std::string::npos)
        << text;
  }
  std::ostringstream md;
  print_report({{path}, ""}, md);
  EXPECT_NE(md.str().find("missing: sweep_sah [max_leaf=8] bvh2 shadow."), std::string::npos) << md.str();
  // The full run has nothing missing.
  std::ostringstream full;
  print_report({{path}, "r0"}, full);
  EXPECT_EQ(full.str().find("Note:"), std::string::npos) << full.str();
}

}  // namespace
}  // namespace sahbench

namespace sahbench {
namespace {

TEST(ReportPredictors, SpearmanOfPerfectReversedAndTiedOrders) {
  const std::vector<double> x = {1, 2, 3, 4, 5};
  EXPECT_DOUBLE_EQ(*spearman(x, std::vector<double>{10, 20, 30, 40, 50}), 1.0);
  EXPECT_DOUBLE_EQ(*spearman(x, std::vector<double>{5, 4, 3, 2, 1}), -1.0);
  // Monotone but not linear: ranks agree exactly.
  EXPECT_DOUBLE_EQ(*spearman(x, std::vector<double>{1, 8, 27, 64, 1000}), 1.0);
  // Ties take the mean rank: y ranks 1.5 1.5 3 4 5 against 1..5.
  EXPECT_NEAR(*spearman(x, std::vector<double>{1, 1, 2, 3, 4}), 9.5 / std::sqrt(10.0 * 9.5), 1e-12);
  // Nothing to order: a constant side, fewer than two pairs, or sizes that differ.
  EXPECT_FALSE(spearman(x, std::vector<double>{2, 2, 2, 2, 2}));
  EXPECT_FALSE(spearman(std::vector<double>{1}, std::vector<double>{1}));
  EXPECT_FALSE(spearman(x, std::vector<double>{1, 2}));
}

TEST(ReportPredictors, PearsonIsLinearCorrelation) {
  const std::vector<double> x = {1, 2, 3, 4, 5};
  EXPECT_NEAR(*pearson(x, std::vector<double>{3, 5, 7, 9, 11}), 1.0, 1e-12);
  EXPECT_NEAR(*pearson(x, std::vector<double>{-1, -2, -3, -4, -5}), -1.0, 1e-12);
  // Monotone but not linear: below 1, where Spearman's is 1.
  EXPECT_LT(*pearson(x, std::vector<double>{1, 8, 27, 64, 1000}), 0.9);
  EXPECT_FALSE(pearson(x, std::vector<double>{2, 2, 2, 2, 2}));
  EXPECT_FALSE(pearson(x, std::vector<double>{1, 2}));
}

// Times made of 0.3 SAH + 0.7 EPO exactly, over costs that are not proportional: the fit finds w = 0.70
// with r = 1; where SAH alone explains the times, w = 0; fewer than three builders, no fit.
TEST(ReportPredictors, FittedEpoWeightRecoversTheBlendOfTheTimes) {
  const std::vector<double> sah = {70, 80, 75, 90, 60}, epo = {20, 5, 12, 9, 30};
  std::vector<double> time(sah.size());
  for (std::size_t i = 0; i < sah.size(); ++i) time[i] = 0.3 * sah[i] + 0.7 * epo[i];
  const auto fit = fit_epo_weight(sah, epo, time);
  ASSERT_TRUE(fit);
  EXPECT_NEAR(fit->weight, 0.70, 1e-9);
  EXPECT_NEAR(fit->r, 1.0, 1e-12);
  const auto sah_only = fit_epo_weight(sah, epo, sah);
  ASSERT_TRUE(sah_only);
  EXPECT_EQ(sah_only->weight, 0.0);
  EXPECT_NEAR(sah_only->r, 1.0, 1e-12);
  EXPECT_FALSE(
      fit_epo_weight(std::vector<double>{1, 2}, std::vector<double>{2, 1}, std::vector<double>{1, 1}));
}

// Four builders with EPO whose time per ray is 0.3 SAH + 0.7 EPO: the table prints the weight fitted to the
// time per ray (1 / rays/s), not to rays/s.
TEST(ReportPredictors, TablePrintsTheWeightFittedToTheTimePerRay) {
  const auto path = temp_csv("predictors_fit.csv");
  {
    CsvWriter w(path, columns_with_predictors());
    w.append(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 9.0));
    const std::vector<double> sah = {70, 80, 75, 90}, epo = {20, 5, 12, 9};
    for (std::size_t i = 0; i < sah.size(); ++i) {
      const double mrays = 1.0 / (0.3 * sah[i] + 0.7 * epo[i]);
      CsvRow row = make_row("binned_sah", "bins=" + std::to_string(8 << i), "bvh2", "primary", 5.0, 1 << 20,
                            fmt::format("{:.6f}", sah[i]), mrays);
      row["trace_mrays_median"] = fmt::format("{:.9g}", mrays);
      row["epo_cost"] = fmt::format("{:.6f}", epo[i]);
      w.append(row);
    }
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  EXPECT_NE(out.str().find("| 0.70 (1.00) |"), std::string::npos) << out.str();
}

// Four builders whose SAH orders them exactly as their speed on bvh2, whose cost per ray orders them in
// reverse, and whose EPO only two have; two builders on bvh4, too few to rank; Embree takes no part.
TEST(ReportPredictors, EachTableIsFollowedByTheCorrelationsOfItsCosts) {
  const auto path = temp_csv("predictors.csv");
  {
    CsvWriter w(path, columns_with_predictors());
    w.append(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 9.0));
    const std::vector<double> speed = {4.0, 1.0, 3.0, 2.0};
    for (std::size_t i = 0; i < speed.size(); ++i) {
      CsvRow row = make_row("binned_sah", "bins=" + std::to_string(8 << i), "bvh2", "primary", 5.0, 1 << 20,
                            std::to_string(100.0 - 10.0 * speed[i]), speed[i]);
      row["cost_per_ray"] = std::to_string(10.0 * speed[i]);
      if (i < 2) row["epo_cost"] = std::to_string(1.0 / speed[i]);
      w.append(row);
    }
    for (const std::string bins : {"8", "16"})
      w.append(make_row("wide_binned_sah", "bins=" + bins, "bvh4", "primary", 5.0, 1 << 20, "30.0", 3.0));
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("### How well the costs predict rays/s: proc:soup at 2 threads"), std::string::npos)
      << md;
  EXPECT_NE(md.find("| layout | ray set | builders | SAH | EPO | SAH+EPO | cost/ray | fitted w (r) |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| bvh2 | primary | 4 | 1.00 | - | - | -1.00 | - |"), std::string::npos) << md;
  EXPECT_NE(md.find("Not ranked, fewer than 3 builders (layout, ray set, builders): bvh4 primary (2)."),
            std::string::npos)
      << md;

  std::ostringstream tex;
  print_report({{path}, "", ReportFormat::kLatex}, tex);
  // Each layout a heading row, its ray sets under it with their builder counts.
  EXPECT_NE(tex.str().find(
                "\\multicolumn{6}{l}{bvh2} \\\\\n    \\quad primary (4) & 1.00 & - & - & -1.00 & - \\\\"),
            std::string::npos)
      << tex.str();
}

// A table with nothing to rank (two builders at most in every layout and ray set, as in a claim run's
// tables) gets one short line, not a list of every layout and ray set.
TEST(ReportPredictors, ATableWithNothingToRankGetsOneShortLine) {
  const auto path = temp_csv("predictors_none.csv");
  {
    CsvWriter w(path, columns_with_predictors());
    w.append(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 9.0));
    for (const char* layout : {"bvh2", "bvh4", "bvh8"})
      for (const char* bins : {"8", "16"})
        w.append(make_row("binned_sah", std::string("bins=") + bins, layout, "primary", 5.0, 1 << 20, "30.0",
                          bins[0] == '8' ? 3.0 : 4.0));
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("Costs against rays/s, proc:soup at 2 threads: not ranked, no layout and ray set has 3 "
                    "builders or more (at most 2)."),
            std::string::npos)
      << md;
  EXPECT_EQ(md.find("bvh4 primary (2)"), std::string::npos) << md;
  EXPECT_EQ(md.find("### How well the costs predict rays/s"), std::string::npos) << md;
}

// SAH costs under other constants are on another scale (c_trav = 3 about doubles them): each set of
// constants is ranked apart, never against the others.
TEST(ReportPredictors, CostsUnderOtherConstantsAreRankedApart) {
  const auto path = temp_csv("predictors_models.csv");
  {
    CsvWriter w(path, columns_with_models());
    auto with_model = [](CsvRow row, const std::string& c_trav) {
      return sahbench::with_model(row, c_trav, "1");
    };
    w.append(make_row("embree", "quality=medium", "embree_1", "primary", 10.0, 1 << 20, "", 9.0));
    const std::vector<std::pair<double, double>> plain = {{15.0, 10.0}, {16.0, 9.0}, {17.0, 8.0}};
    for (std::size_t i = 0; i < plain.size(); ++i)
      w.append(with_model(make_row("binned_sah", "bins=" + std::to_string(8 << i), "bvh2", "primary", 5.0,
                                   1 << 20, std::to_string(plain[i].first), plain[i].second),
                          "1"));
    // The fastest tree, whose cost is the largest number only because it is under c_trav = 3.
    w.append(
        with_model(make_row("binned_sah", "c_trav=3", "bvh2", "primary", 5.0, 1 << 20, "36.3", 11.0), "3"));
  }
  std::ostringstream out;
  print_report({{path}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("| bvh2 | primary [c_trav=1, c_isect=1, block=1] | 3 | 1.00 |"), std::string::npos) << md;
  EXPECT_NE(md.find("bvh2 primary [c_trav=3, c_isect=1, block=1] (1)"), std::string::npos) << md;
}

}  // namespace
}  // namespace sahbench
