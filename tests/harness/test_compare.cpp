// sahbench compare: a run against itself passes; injected regressions (a worse split, an extra node
// visit, slower tracing or building relative to Embree, a lost cell) are caught; noise, whose interval
// contains no change, is not; and bad data (a renamed column, a field that is not a number, a cell twice,
// two runs under one run id, a missing key column, missing samples) is an Error naming file, column and
// line.

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "core/error.h"
#include "harness/report/compare.h"
#include "harness/report/ratio_stats.h"
#include "harness/run/csv.h"
#include "harness/run/runner.h"

namespace sahbench {
namespace {

// One directory per process: ctest runs each test in its own process, in parallel.
std::filesystem::path dir() {
  const auto d =
      std::filesystem::temp_directory_path() / ("sahbench_test_compare_" + std::to_string(getpid()));
  std::filesystem::create_directories(d);
  return d;
}

const std::vector<std::string>& columns() {
  static const std::vector<std::string> c = {"run_id",
                                             "run_fingerprint",
                                             "scene",
                                             "threads",
                                             "frame",
                                             "builder",
                                             "builder_params",
                                             "layout",
                                             "ray_set",
                                             "build_ms_median",
                                             "build_ms_samples",
                                             "trace_mrays_median",
                                             "trace_mrays_samples",
                                             "sah_cost",
                                             "nodes",
                                             "leaves",
                                             "max_depth",
                                             "nodes_per_ray",
                                             "prims_per_ray",
                                             "leaves_per_ray",
                                             "mem_bytes",
                                             "refs_per_prim",
                                             "mismatches",
                                             "notes"};
  return c;
}

// Samples and medians are written with 4 decimals, as the runner writes them.
std::string fmt_4(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.4f", v);
  return buffer;
}

std::string join(const std::vector<double>& samples) {
  std::string out;
  for (const double s : samples) {
    if (!out.empty()) out += ';';
    out += fmt_4(s);
  }
  return out;
}

// A run's timings per round: Embree's and ours for the build and per ray set, with a drift of the machine
// common to every cell of a round (which pairing cancels) and lognormal noise of each sample's own.
struct RunSpec {
  std::uint64_t seed = 1;
  int rounds = 10;
  double noise = 0.005;                           // sd of each sample's log
  double trace_factor = 1.0, build_factor = 1.0;  // ours, for the primary ray set's cell
  std::string run_id = "r1", fingerprint = "0123456789abcdef";
};

struct Samples {
  std::vector<double> build, trace;
};

std::vector<CsvRow> make_run(const RunSpec& spec) {
  std::mt19937_64 rng(spec.seed);
  std::normal_distribution<double> noise(0.0, spec.noise);
  std::uniform_real_distribution<double> drift(0.8, 1.2);
  // True figures: Embree builds in 10 ms and traces 4 (primary) and 8 (shadow) Mrays/s; ours builds in
  // 8 ms and traces 5 and 6.
  Samples embree[2], ours[2];
  for (int r = 0; r < spec.rounds; ++r) {
    const double machine = drift(rng);
    for (int s = 0; s < 2; ++s) {
      const bool primary = s == 0;  // the primary cell is the one slowed or sped up
      embree[s].build.push_back(10.0 * machine * std::exp(noise(rng)));
      embree[s].trace.push_back((primary ? 4.0 : 8.0) / machine * std::exp(noise(rng)));
      ours[s].build.push_back(8.0 * (primary ? spec.build_factor : 1.0) * machine * std::exp(noise(rng)));
      ours[s].trace.push_back((primary ? 5.0 : 6.0) * (primary ? spec.trace_factor : 1.0) / machine *
                              std::exp(noise(rng)));
    }
  }
  auto row = [&](const std::string& builder, const std::string& params, const std::string& layout, int set,
                 const Samples& t) {
    auto rounded = [](std::vector<double> v) {
      for (double& x : v) x = std::stod(fmt_4(x));
      return v;
    };
    const bool embree_row = builder == "embree";
    CsvRow r = {{"run_id", spec.run_id},
                {"run_fingerprint", spec.fingerprint},
                {"scene", "proc:sphere"},
                {"threads", "2"},
                {"frame", "0"},
                {"builder", builder},
                {"builder_params", params},
                {"layout", layout},
                {"ray_set", set == 0 ? "primary" : "shadow"},
                {"build_ms_median", fmt_4(median_of(rounded(t.build)))},
                {"build_ms_samples", join(t.build)},
                {"trace_mrays_median", fmt_4(median_of(rounded(t.trace)))},
                {"trace_mrays_samples", join(t.trace)}};
    if (!embree_row) {
      r["sah_cost"] = "38.937587";
      r["nodes"] = "21713";
      r["leaves"] = "10857";
      r["max_depth"] = "16";
      r["nodes_per_ray"] = set == 0 ? "8.492" : "19.689";
      r["prims_per_ray"] = set == 0 ? "1.306" : "4.299";
      r["leaves_per_ray"] = set == 0 ? "2.104" : "5.311";
      r["mem_bytes"] = "774896";
      r["refs_per_prim"] = "1.0000";
      r["mismatches"] = "0";
    }
    return r;
  };
  std::vector<CsvRow> rows;
  for (int s = 0; s < 2; ++s) {
    rows.push_back(row("embree", "quality=medium", "embree_1", s, embree[s]));
    rows.push_back(row("binned_sah", "bins=8", "bvh2", s, ours[s]));
  }
  return rows;
}

// Rows 0..3 of make_run are on lines 2..5: embree primary, binned primary, embree shadow, binned shadow.
constexpr int kBinnedPrimaryLine = 3;

std::filesystem::path write(const std::string& name, const std::vector<CsvRow>& rows,
                            std::vector<std::string> header = columns()) {
  const auto path = dir() / (name + ".csv");
  std::filesystem::remove(path);
  CsvWriter w(path, header);
  for (CsvRow r : rows) {
    std::erase_if(
        r, [&](const auto& kv) { return std::find(header.begin(), header.end(), kv.first) == header.end(); });
    w.append(r);
  }
  return path;
}

// `make_run(spec)` with `edit` applied to the binned primary row.
std::filesystem::path edited(const std::string& name, const std::function<void(CsvRow&)>& edit,
                             const RunSpec& spec = {}) {
  auto rows = make_run(spec);
  edit(rows[1]);
  return write(name, rows);
}

const std::filesystem::path& baseline() {
  static const std::filesystem::path path = write("baseline", make_run({}));
  return path;
}

CompareResult run_compare(const std::filesystem::path& current, bool deterministic_only = false,
                          const std::filesystem::path& base = baseline(), std::string* text = nullptr) {
  std::ostringstream out;
  const CompareResult r = compare_results({base, current, deterministic_only, std::nullopt, 0.02}, out);
  if (text) *text = out.str();
  return r;
}

// The Error that comparing `current` against the baseline throws; the test fails when there is none.
std::string compare_error(const std::filesystem::path& current, bool deterministic_only = false,
                          const std::filesystem::path& base = baseline()) {
  try {
    run_compare(current, deterministic_only, base);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no Error for " << current;
  return "";
}

std::string at_line(const std::filesystem::path& path, int line) {
  return path.string() + ":" + std::to_string(line);
}

std::string times(const std::string& v, double f) {
  return std::to_string(std::stod(v) * f);
}

// The change and its interval's bounds (in %) of the finding on `metric` in compare's table.
struct PrintedChange {
  double change, lo, hi;
};
std::optional<PrintedChange> printed_change(const std::string& text, const std::string& metric) {
  // After the metric: "| baseline | new | change | [lo, hi] |".
  const std::size_t at = text.find("| " + metric + " |");
  if (at == std::string::npos) return std::nullopt;
  PrintedChange p{};
  double baseline = 0, current = 0;
  if (std::sscanf(text.c_str() + at + metric.size() + 4, "%lf | %lf | %lf%% | [%lf%%, %lf%%]", &baseline,
                  &current, &p.change, &p.lo, &p.hi) != 5)
    return std::nullopt;
  return p;
}

TEST(HarnessCompare, ARunAgainstItselfPasses) {
  const CompareResult r = run_compare(baseline());
  EXPECT_EQ(r.regressions, 0);
  EXPECT_EQ(r.improvements, 0);
  EXPECT_EQ(r.compared_cells, 2);
}

// Another run of the same build: other rounds, other noise, the same true ratios.
TEST(HarnessCompare, AnotherRunOfTheSameBuildPasses) {
  RunSpec spec;
  spec.seed = 2;
  spec.run_id = "r2";
  spec.fingerprint = "fedcba9876543210";
  const CompareResult r = run_compare(write("rerun", make_run(spec)));
  EXPECT_EQ(r.regressions, 0);
  EXPECT_EQ(r.improvements, 0);
}

TEST(HarnessCompare, AWorseSplitIsCaught) {
  const CompareResult r = run_compare(
      edited("worse_sah", [](CsvRow& row) { row["sah_cost"] = times(row["sah_cost"], 1.001); }), true);
  EXPECT_EQ(r.regressions, 1);
}

TEST(HarnessCompare, AnExtraNodeVisitIsCaught) {
  const CompareResult r = run_compare(
      edited(
          "extra_visit",
          [](CsvRow& row) { row["nodes_per_ray"] = std::to_string(std::stod(row["nodes_per_ray"]) + 1.0); }),
      true);
  EXPECT_EQ(r.regressions, 1);
}

TEST(HarnessCompare, AnExtraLeafVisitIsCaught) {
  const CompareResult r = run_compare(edited("extra_leaf",
                                             [](CsvRow& row) {
                                               row["leaves_per_ray"] =
                                                   std::to_string(std::stod(row["leaves_per_ray"]) + 0.5);
                                             }),
                                      true);
  EXPECT_EQ(r.regressions, 1);
}

// leaves_per_ray came after the first committed baselines: a baseline without it still gates every
// other metric, and the summary says which column was not compared.
TEST(HarnessCompare, ABaselineFromBeforeLeavesPerRayGatesTheRest) {
  std::vector<std::string> header = columns();
  std::erase(header, std::string("leaves_per_ray"));
  const auto old_baseline = write("before_leaves", make_run({}), header);
  std::string text;
  const CompareResult same = run_compare(baseline(), true, old_baseline, &text);
  EXPECT_EQ(same.regressions, 0);
  EXPECT_EQ(same.compared_cells, 2);
  EXPECT_NE(text.find("Not compared: leaves_per_ray, which the baseline " + old_baseline.string() +
                      " has no column for"),
            std::string::npos)
      << text;
  const auto worse = edited("worse_sah_with_leaves", [](CsvRow& row) {
    row["sah_cost"] = times(row["sah_cost"], 1.001);
    row["leaves_per_ray"] = "99.0";
  });
  EXPECT_EQ(run_compare(worse, true, old_baseline).regressions, 1);  // the SAH; leaves_per_ray not compared
  EXPECT_EQ(run_compare(worse, true).regressions, 2);                // both, against a baseline that has it
  // Excused in the baseline only: a new run that lost the column is refused, not passed unchecked.
  const std::string e = compare_error(old_baseline, true);
  EXPECT_NE(e.find(old_baseline.string() + ":1: the header has no column 'leaves_per_ray' (the baseline " +
                   baseline().string() + " has it)"),
            std::string::npos)
      << e;
}

// Deterministic metrics are reproduced to the bit: one that improved says the baseline is out of date,
// which fails the gate (a later regression below the old value would pass), without being a regression.
TEST(HarnessCompare, ABetterSplitIsAnImprovementThatOutdatesTheBaseline) {
  std::string text;
  const CompareResult r =
      run_compare(edited("better_sah", [](CsvRow& row) { row["sah_cost"] = times(row["sah_cost"], 0.99); }),
                  true, baseline(), &text);
  EXPECT_EQ(r.regressions, 0);
  EXPECT_EQ(r.improvements, 1);
  EXPECT_EQ(r.out_of_date, 1);
  EXPECT_TRUE(r.failed());
  EXPECT_NE(text.find("the baseline is out of date"), std::string::npos) << text;
  EXPECT_NE(text.find("| improved (out of date) |"), std::string::npos) << text;
  // A faster trace is no such thing: timings move from run to run.
  RunSpec fast;
  fast.seed = 5;
  fast.trace_factor = 1.25;
  const CompareResult f = run_compare(write("faster_only", make_run(fast)));
  EXPECT_EQ(f.improvements, 1);
  EXPECT_FALSE(f.failed());
}

// 0 to 1 mismatches is a change of one, not of 1e14 percent.
TEST(HarnessCompare, AChangeFromZeroIsPrintedAsADifference) {
  std::string text;
  const CompareResult r =
      run_compare(edited("one_mismatch", [](CsvRow& row) { row["mismatches"] = std::to_string(1); }), true,
                  baseline(), &text);
  EXPECT_EQ(r.regressions, 1);
  EXPECT_NE(text.find("| mismatches | 0 | 1 | +1 | - | - |"), std::string::npos) << text;
}

// Cells of the new run the baseline lacks are listed, not passed over in silence.
TEST(HarnessCompare, NewCellsAreListed) {
  auto rows = make_run({});
  CsvRow extra = rows[1];
  extra["builder_params"] = "bins=16";
  rows.push_back(extra);
  std::string text;
  const CompareResult r = run_compare(write("new_cell", rows), true, baseline(), &text);
  EXPECT_EQ(r.new_cells, 1);
  EXPECT_FALSE(r.failed());
  EXPECT_NE(text.find("1 new cells (not gated)"), std::string::npos) << text;
  EXPECT_NE(text.find("Cells in the new run but not in the baseline"), std::string::npos) << text;
  EXPECT_NE(text.find("binned_sah|bins=16|bvh2"), std::string::npos) << text;
}

// Runs of different inputs measure different things under the same cell names: refused, naming what
// differs; the build, repetitions and the lists of builders and layouts may differ.
TEST(HarnessCompare, RunsOfDifferentInputsAreNotCompared) {
  std::vector<std::string> header = columns();
  header.push_back("fingerprint_parts");
  header.push_back("scene_triangles");
  header.push_back("ray_count");
  auto with_parts = [&](const std::string& name, const std::string& parts, const std::string& triangles) {
    auto rows = make_run({});
    for (auto& r : rows) {
      r["fingerprint_parts"] = parts;
      r["scene_triangles"] = triangles;
      r["ray_count"] = "4096";
    }
    return write(name, rows, header);
  };
  // fingerprint_parts with every part's hash "00000000" but those given.
  auto parts = [](const std::map<std::string, std::string>& changed) {
    std::string out;
    for (const char* part : {"seed", "repetitions", "scenes", "builders", "layouts", "threads", "ray_sets",
                             "cameras", "reference", "animation", "build"}) {
      const auto it = changed.find(part);
      out +=
          fmt::format("{}{}={}", out.empty() ? "" : ";", part, it == changed.end() ? "00000000" : it->second);
    }
    return out;
  };
  const auto base = with_parts("inputs_base", parts({}), "20020");
  // Another build, other repetitions, other builder and layout lists: compared.
  std::string text;
  const auto other_build = with_parts("inputs_build",
                                      parts({{"build", "ffffffff"},
                                             {"repetitions", "ffffffff"},
                                             {"builders", "ffffffff"},
                                             {"layouts", "ffffffff"}}),
                                      "20020");
  EXPECT_FALSE(run_compare(other_build, true, base, &text).failed()) << text;
  EXPECT_EQ(text.find("Inputs not checked"), std::string::npos) << text;
  for (const std::string part : {"seed", "scenes", "ray_sets", "cameras", "reference"}) {
    const auto other = with_parts("inputs_" + part, parts({{part, "ffffffff"}}), "20020");
    const std::string e = compare_error(other, true, base);
    EXPECT_NE(e.find("measure different inputs, so their cells are not comparable: their fingerprint_parts "
                     "differ in " +
                     part),
              std::string::npos)
        << e;
  }
  // Without fingerprint_parts (an older CSV) the cells' own sizes are still held to the baseline's.
  header.erase(std::find(header.begin(), header.end(), "fingerprint_parts"));
  auto rows = make_run({});
  for (auto& r : rows) {
    r["scene_triangles"] = "200";
    r["ray_count"] = "4096";
  }
  const auto old_other = write("inputs_old_other", rows, header);
  const std::string e = compare_error(old_other, true, base);
  EXPECT_NE(e.find("column 'scene_triangles' is '200', where"), std::string::npos) << e;
  EXPECT_NE(e.find("measures another input than its baseline"), std::string::npos) << e;
  for (auto& r : rows) r["scene_triangles"] = "20020";
  EXPECT_FALSE(run_compare(write("inputs_old_same", rows, header), true, base, &text).failed()) << text;
  EXPECT_NE(text.find("Inputs not checked"), std::string::npos) << text;
}

TEST(HarnessCompare, IntervalGateFlagsARealSlowdownAndNotNoise) {
  RunSpec slow;
  slow.seed = 3;
  slow.trace_factor = 0.8;  // 20% fewer rays/s, tight samples
  std::string text;
  const CompareResult r = run_compare(write("slower", make_run(slow)), false, baseline(), &text);
  EXPECT_EQ(r.regressions, 1) << text;
  EXPECT_EQ(r.improvements, 0) << text;
  EXPECT_NE(
      text.find(
          "| REGRESSION | proc:sphere\\|binned_sah\\|bins=8\\|bvh2\\|2\\|primary\\|0 | trace_mrays/embree |"),
      std::string::npos)
      << text;
  EXPECT_NE(text.find("95% interval of the change"), std::string::npos) << text;
  const auto printed = printed_change(text, "trace_mrays/embree");
  ASSERT_TRUE(printed) << text;
  EXPECT_NEAR(printed->change, -20.0, 1.5) << text;
  EXPECT_LT(printed->lo, printed->change) << text;
  EXPECT_GT(printed->hi, printed->change) << text;
  EXPECT_LT(printed->hi, -2.0) << text;  // wholly on the worse side, and beyond the margin
  EXPECT_EQ(run_compare(write("slower_det", make_run(slow)), true).regressions, 0) << "timings ignored";

  RunSpec slow_build;
  slow_build.seed = 4;
  slow_build.build_factor = 1.25;  // builds 25% longer
  const CompareResult b = run_compare(write("slower_build", make_run(slow_build)), false, baseline(), &text);
  EXPECT_EQ(b.regressions, 1) << text;
  EXPECT_NE(text.find("build_ms/embree"), std::string::npos) << text;

  RunSpec fast;
  fast.seed = 5;
  fast.trace_factor = 1.25;
  const CompareResult f = run_compare(write("faster", make_run(fast)), false, baseline(), &text);
  EXPECT_EQ(f.regressions, 0) << text;
  EXPECT_EQ(f.improvements, 1) << text;

  // Noisy samples (20% per sample, 4 rounds), and no change or even a real 5% one: the interval
  // contains no change, so nothing is flagged, however large the point change happens to be.
  for (const double factor : {1.0, 0.95}) {
    RunSpec noisy;
    noisy.seed = 6;
    noisy.rounds = 4;
    noisy.noise = 0.2;
    noisy.trace_factor = factor;
    const CompareResult n = run_compare(write("noisy", make_run(noisy)), false, baseline(), &text);
    EXPECT_EQ(n.regressions, 0) << text;
    EXPECT_EQ(n.improvements, 0) << text;
  }
  // A real 1% slowdown with very tight samples: outside the noise, but below the 2% margin.
  RunSpec small;
  small.seed = 7;
  small.rounds = 30;
  small.noise = 0.0005;
  small.trace_factor = 0.99;
  RunSpec small_base = small;
  small_base.seed = 8;
  small_base.trace_factor = 1.0;
  const auto small_base_path = write("small_base", make_run(small_base));
  EXPECT_EQ(run_compare(write("small", make_run(small)), false, small_base_path).regressions, 0);
  small.trace_factor = 0.97;  // 3%: beyond the margin, and flagged
  EXPECT_EQ(run_compare(write("small3", make_run(small)), false, small_base_path).regressions, 1);
}

TEST(HarnessCompare, OneRoundCannotBeToldFromNoise) {
  RunSpec one;
  one.rounds = 1;
  one.trace_factor = 0.5;
  std::string text;
  const CompareResult r = run_compare(write("one_round", make_run(one)), false, baseline(), &text);
  EXPECT_EQ(r.regressions, 0) << text;
  EXPECT_EQ(r.timings_without_interval, 4) << text;
  EXPECT_NE(text.find("4 timing ratios come from one round"), std::string::npos) << text;
}

TEST(HarnessCompare, ALostCellIsARegression) {
  const auto current = edited("lost", [](CsvRow& row) { row["ray_set"] = "renamed"; });
  std::string text;
  const CompareResult r = run_compare(current, true, baseline(), &text);
  EXPECT_EQ(r.missing_cells, 1);
  EXPECT_GE(r.regressions, 1);
  EXPECT_NE(text.find("Cells in the baseline but not in the new run"), std::string::npos) << text;
}

TEST(HarnessCompare, ANewRunWithoutItsEmbreeAnchorIsARegressionNotAPass) {
  // A run with --only that left Embree out: its timings cannot be compared, which is no pass.
  std::vector<CsvRow> rows = make_run({});
  std::erase_if(rows, [](const CsvRow& r) { return r.at("builder") == "embree"; });
  std::string text;
  const CompareResult r = run_compare(write("no_anchor", rows), false, baseline(), &text);
  EXPECT_EQ(r.missing_anchors, 2);
  EXPECT_GE(r.regressions, 2);
  EXPECT_NE(text.find("Cells whose new run has no Embree anchor"), std::string::npos) << text;
  EXPECT_NE(text.find("2 missing (each a regression; 2 of them cells whose Embree anchor alone is missing)"),
            std::string::npos)
      << text;
  // Deterministic metrics alone need no anchor.
  EXPECT_EQ(run_compare(write("no_anchor_det", rows), true).regressions, 0);
  // Nor does a baseline without anchors pass: its timings were never compared.
  const auto unanchored = write("no_anchor_base", rows);
  const std::string message = compare_error(baseline(), false, unanchored);
  EXPECT_NE(message.find("the baseline has no Embree anchor (embree [quality=medium] in its default mode, "
                         "embree_1) for any of its"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("--deterministic-only"), std::string::npos) << message;
  EXPECT_EQ(run_compare(baseline(), true, unanchored).regressions, 0);
  // One whose anchors cover some cells compares those and lists the others, which are no regression.
  std::vector<CsvRow> partly = make_run({});
  const auto first_embree =
      std::find_if(partly.begin(), partly.end(), [](const CsvRow& r) { return r.at("builder") == "embree"; });
  ASSERT_NE(first_embree, partly.end());
  const std::string lost_set = first_embree->at("ray_set");
  partly.erase(first_embree);
  std::string partial_text;
  const CompareResult partial =
      run_compare(baseline(), false, write("partly_anchored", partly), &partial_text);
  EXPECT_EQ(partial.regressions, 0) << partial_text;
  EXPECT_NE(partial_text.find("Cells whose baseline has no Embree anchor"), std::string::npos)
      << partial_text;
  EXPECT_NE(partial_text.find(lost_set), std::string::npos) << partial_text;
}

TEST(HarnessCompare, JsonForDashboards) {
  std::ostringstream out;
  const auto json = dir() / "bench.json";
  compare_results({baseline(), baseline(), false, json, 0.02}, out);
  const nlohmann::json smaller = nlohmann::json::parse(std::ifstream(json));
  ASSERT_TRUE(smaller.is_array());
  EXPECT_TRUE(std::any_of(smaller.begin(), smaller.end(), [](const auto& e) {
    return e["unit"] == "sah_cost";
  })) << smaller.dump(2);
  const nlohmann::json bigger = nlohmann::json::parse(std::ifstream(dir() / "bench-bigger.json"));
  // The value is the new run's ratio: the geometric mean of the per-round ratios.
  const auto rows = make_run({});
  const RatioInterval ratio = paired_ratio(parse_samples(rows[1].at("trace_mrays_samples")),
                                           parse_samples(rows[0].at("trace_mrays_samples")));
  const auto entry = std::find_if(bigger.begin(), bigger.end(), [](const auto& e) {
    return e["name"].template get<std::string>().ends_with("primary|0 trace_mrays/embree");
  });
  ASSERT_NE(entry, bigger.end()) << bigger.dump(2);
  EXPECT_EQ((*entry)["unit"], "ratio");
  EXPECT_DOUBLE_EQ((*entry)["value"].get<double>(), ratio.estimate);
}

// A scene path with quotes and backslashes is a JSON string like any other.
TEST(HarnessCompare, JsonEscapesCellNames) {
  auto rows = make_run({});
  for (auto& r : rows) r["scene"] = R"(C:\scenes\"mesh".obj)";
  const auto path = write("quoted", rows);
  std::ostringstream out;
  const auto json = dir() / "quoted.json";
  compare_results({path, path, false, json, 0.02}, out);
  const nlohmann::json parsed = nlohmann::json::parse(std::ifstream(json));
  ASSERT_FALSE(parsed.empty());
  EXPECT_TRUE(parsed[0]["name"].get<std::string>().starts_with(R"(C:\scenes\"mesh".obj|)")) << parsed.dump();
}

// A `sahbench stress` CSV has cases, not cells of a run: refused by name, not by a missing fingerprint.
TEST(HarnessCompare, AStressResultIsRefusedByName) {
  std::vector<std::string> header = {"run_id", "case", "false_misses", "leaks"};
  const auto path =
      write("stress", {{{"run_id", "s"}, {"case", "c"}, {"false_misses", "0"}, {"leaks", "0"}}}, header);
  const std::string e = compare_error(path, true, path);
  EXPECT_NE(e.find(path.string() + ": a `sahbench stress` result, which compare does not gate"),
            std::string::npos)
      << e;
}

// --- Bad data: each an Error naming the file, the column and the line ---

TEST(HarnessCompare, ARenamedMetricColumnIsAnError) {
  std::vector<std::string> header = columns();
  std::replace(header.begin(), header.end(), std::string("sah_cost"), std::string("sah_cost_v2"));
  auto rows = make_run({});
  for (auto& r : rows)
    if (r.count("sah_cost")) r["sah_cost_v2"] = r["sah_cost"];
  const auto path = write("renamed", rows, header);
  for (const bool deterministic_only : {true, false}) {
    const std::string e = compare_error(path, deterministic_only);
    EXPECT_NE(e.find(at_line(path, 1) + ": the header has no column 'sah_cost'"), std::string::npos) << e;
  }
}

TEST(HarnessCompare, EveryMissingKeyColumnIsAnError) {
  for (const std::string column : {"scene", "builder", "builder_params", "layout", "threads", "ray_set",
                                   "frame", "run_id", "run_fingerprint"}) {
    std::vector<std::string> header = columns();
    std::erase(header, column);
    const auto path = write("no_" + column, make_run({}), header);
    const std::string e = compare_error(path, true);
    EXPECT_NE(e.find(at_line(path, 1) + ": the header has no column '" + column + "'"), std::string::npos)
        << e;
    // In either file.
    const std::string as_base = compare_error(baseline(), true, path);
    EXPECT_NE(as_base.find(path.string()), std::string::npos) << as_base;
  }
}

TEST(HarnessCompare, AMetricThatIsNotANumberIsAnError) {
  for (const std::string bad : {"abc", "nan", "inf", "12abc"}) {
    const auto path = edited("bad_" + bad, [&](CsvRow& row) { row["sah_cost"] = bad; });
    const std::string e = compare_error(path, true);
    EXPECT_NE(e.find(at_line(path, kBinnedPrimaryLine) + ": column 'sah_cost': '" + bad + "'"),
              std::string::npos)
        << e;
    const std::string as_base = compare_error(baseline(), true, path);
    EXPECT_NE(as_base.find(at_line(path, kBinnedPrimaryLine) + ": column 'sah_cost'"), std::string::npos)
        << as_base;
  }
}

TEST(HarnessCompare, AnEmptyMetricIsAllowedOnlyWhereTheBaselineHasNone) {
  const auto empty = edited("empty_mismatches", [](CsvRow& row) { row["mismatches"] = ""; });
  const std::string e = compare_error(empty, true);
  EXPECT_NE(e.find(at_line(empty, kBinnedPrimaryLine) + ": column 'mismatches': empty, but " +
                   at_line(baseline(), kBinnedPrimaryLine) + " has '0'"),
            std::string::npos)
      << e;
  EXPECT_EQ(run_compare(empty, true, empty).regressions,
            0);  // empty in both: no reference, nothing to compare
}

TEST(HarnessCompare, ACellTwiceIsAnError) {
  auto rows = make_run({});
  rows.push_back(rows[1]);
  const auto path = write("twice", rows);
  const std::string e = compare_error(path, true);
  EXPECT_NE(e.find(path.string() + ": lines 3 and 6 of run 'r1' are the same cell (columns scene, builder, "
                                   "builder_params, layout, threads, ray_set, frame: "
                                   "proc:sphere|binned_sah|bins=8|bvh2|2|primary|0)"),
            std::string::npos)
      << e;
}

TEST(HarnessCompare, TwoFingerprintsInOneRunAreAnError) {
  auto rows = make_run({});
  rows[3]["run_fingerprint"] = "00000000deadbeef";
  const auto path = write("two_fingerprints", rows);
  const std::string e = compare_error(path, true);
  EXPECT_NE(e.find(path.string() + ": lines 2 and 5 of run 'r1' differ in column 'run_fingerprint' "
                                   "('0123456789abcdef' and '00000000deadbeef')"),
            std::string::npos)
      << e;
  const auto malformed = edited("bad_fingerprint", [](CsvRow& row) { row["run_fingerprint"] = "XYZ"; });
  EXPECT_NE(compare_error(malformed, true)
                .find(at_line(malformed, kBinnedPrimaryLine) +
                      ": column 'run_fingerprint': 'XYZ' is not 16 lowercase hex digits"),
            std::string::npos);
  // An earlier run in the file with another fingerprint is not the run compared, and is fine.
  auto two_runs = make_run({.seed = 9, .run_id = "r0", .fingerprint = "1111111111111111"});
  for (const auto& r : make_run({})) two_runs.push_back(r);
  EXPECT_EQ(run_compare(write("two_runs", two_runs), true).regressions, 0);
}

TEST(HarnessCompare, AKeyThatIsNotAnIntegerIsAnError) {
  const auto path = edited("bad_threads", [](CsvRow& row) { row["threads"] = "two"; });
  EXPECT_NE(compare_error(path, true).find(at_line(path, kBinnedPrimaryLine) + ": column 'threads': 'two'"),
            std::string::npos);
}

TEST(HarnessCompare, TimingsWithoutSamplesAreAnError) {
  std::vector<std::string> header = columns();
  std::erase(header, std::string("trace_mrays_samples"));
  const auto old = write("old_format", make_run({}), header);
  const std::string e = compare_error(old);
  EXPECT_NE(e.find(at_line(old, 1) + ": the header has no column 'trace_mrays_samples'"), std::string::npos)
      << e;
  EXPECT_EQ(run_compare(old, true, old).regressions, 0) << "deterministic metrics need no samples";

  const auto empty = edited("empty_samples", [](CsvRow& row) { row["build_ms_samples"] = ""; });
  const std::string f = compare_error(empty);
  EXPECT_NE(f.find(at_line(empty, kBinnedPrimaryLine) +
                   ": column 'build_ms_samples': empty, while build_ms_median"),
            std::string::npos)
      << f;
  const auto bad = edited("bad_samples", [](CsvRow& row) { row["trace_mrays_samples"] += ";nan"; });
  const std::string g = compare_error(bad);
  EXPECT_NE(g.find(at_line(bad, kBinnedPrimaryLine) + ": column 'trace_mrays_samples': sample 'nan'"),
            std::string::npos)
      << g;
  // Samples that are not the median column's: one of the two was edited.
  const auto off = edited(
      "off_median", [](CsvRow& row) { row["trace_mrays_median"] = times(row["trace_mrays_median"], 0.5); });
  const std::string h = compare_error(off);
  EXPECT_NE(h.find(at_line(off, kBinnedPrimaryLine) + ": column 'trace_mrays_samples': the samples' median"),
            std::string::npos)
      << h;
}

// The runner's own output: a small real run with Embree medium as the anchor, against itself.
TEST(HarnessCompare, ARealRunAgainstItselfPasses) {
  const auto path = dir() / "real.csv";
  std::filesystem::remove(path);
  const auto config = dir() / "real.toml";
  std::ofstream(config) << "[experiment]\nname = \"cmp\"\noutput = \"" << path.string() << "\"\n"
                        << "scenes = [\"proc:sphere:tris=2000\"]\nreference = \"brute_force\"\n"
                        << "[repetitions]\nbuild = 3\nbuild_warmup = 0\ntrace = 3\ntrace_warmup = 0\n"
                        << "[[builder]]\nname = \"binned_sah\"\n[[builder]]\nname = \"embree\"\n"
                        << "[[ray_set]]\nkind = \"primary\"\nwidth = 32\nheight = 32\n";
  std::ostringstream log;
  run_experiment({config, false, "", std::nullopt}, log);
  std::string text;
  const CompareResult r = run_compare(path, false, path, &text);
  EXPECT_EQ(r.regressions, 0) << text;
  EXPECT_EQ(r.compared_cells, 1) << text;
}

}  // namespace
}  // namespace sahbench
