// sahbench compare: a run against itself passes; injected regressions (a worse split, an extra node
// visit, slower tracing relative to Embree, a lost cell) are caught; noise within the margin is not.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include "harness/compare.h"
#include "harness/csv.h"
#include "harness/runner.h"

namespace sahbench {
namespace {

// One directory per process: ctest runs each test in its own process, in parallel, and every one of
// them makes the shared baseline.
std::filesystem::path dir() {
  const auto d =
      std::filesystem::temp_directory_path() / ("sahbench_test_compare_" + std::to_string(getpid()));
  std::filesystem::create_directories(d);
  return d;
}

// A small real run with Embree medium as the anchor, made once.
const std::filesystem::path& baseline() {
  static const std::filesystem::path csv = [] {
    const auto path = dir() / "baseline.csv";
    std::filesystem::remove(path);
    const auto config = dir() / "baseline.toml";
    std::ofstream(config) << "[experiment]\nname = \"cmp\"\noutput = \"" << path.string() << "\"\n"
                          << "scenes = [\"proc:sphere:tris=2000\"]\nreference = \"brute_force\"\n"
                          << "[repetitions]\nbuild = 3\nbuild_warmup = 0\ntrace = 3\ntrace_warmup = 0\n"
                          << "[[builder]]\nname = \"binned_sah\"\n[[builder]]\nname = \"embree\"\n"
                          << "[[ray_set]]\nkind = \"primary\"\nwidth = 32\nheight = 32\n";
    std::ostringstream log;
    run_experiment({config, false, "", std::nullopt}, log);
    return path;
  }();
  return csv;
}

// Copies `source` with `edit` applied to the binned_sah row and `all` to every row.
std::filesystem::path edited(
    const std::string& name, const std::function<void(CsvRow&)>& edit,
    const std::function<void(CsvRow&)>& all = [](CsvRow&) {},
    const std::filesystem::path& source = baseline()) {
  const auto rows = read_csv(source);
  const auto path = dir() / (name + ".csv");
  std::filesystem::remove(path);
  std::vector<std::string> columns = design_columns();
  for (const auto& [k, v] : rows.front())
    if (std::find(columns.begin(), columns.end(), k) == columns.end()) columns.push_back(k);
  CsvWriter w(path, columns);
  for (CsvRow r : rows) {
    all(r);
    if (r.at("builder") == "binned_sah") edit(r);
    w.append(r);
  }
  return path;
}

CompareResult run_compare(const std::filesystem::path& current, bool deterministic_only = false,
                          const std::filesystem::path& base = baseline()) {
  std::ostringstream out;
  return compare_results({base, current, deterministic_only, std::nullopt, 0.10}, out);
}

// Timings with no spread (min = max = median), so the margin is the 10% floor: the tiny test run's
// own spread (1024 rays trace in ~0.1 ms) is too large to tell a 2x slowdown from noise, rightly.
void calm(CsvRow& row) {
  for (const char* p : {"trace_mrays", "build_ms"})
    if (!row[std::string(p) + "_median"].empty())
      row[std::string(p) + "_min"] = row[std::string(p) + "_max"] = row[std::string(p) + "_median"];
}

std::string times(const std::string& v, double f) {
  return std::to_string(std::stod(v) * f);
}

TEST(HarnessCompare, ARunAgainstItselfPasses) {
  const CompareResult r = run_compare(baseline());
  EXPECT_EQ(r.regressions, 0);
  EXPECT_EQ(r.compared_cells, 1);
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

TEST(HarnessCompare, ABetterSplitIsAnImprovementNotARegression) {
  const CompareResult r = run_compare(
      edited("better_sah", [](CsvRow& row) { row["sah_cost"] = times(row["sah_cost"], 0.99); }), true);
  EXPECT_EQ(r.regressions, 0);
  EXPECT_EQ(r.improvements, 1);
}

TEST(HarnessCompare, SlowerTracingRelativeToEmbreeIsCaughtAndNoiseIsNot) {
  auto slower = [](double f) {
    return [f](CsvRow& row) {
      for (const char* c : {"trace_mrays_median", "trace_mrays_min", "trace_mrays_max"})
        row[c] = times(row[c], f);
    };
  };
  const auto calm_base = edited(
      "calm", [](CsvRow&) {}, calm);
  EXPECT_EQ(run_compare(edited("half_speed", slower(0.5), calm), false, calm_base).regressions, 1);
  EXPECT_EQ(run_compare(edited("noise", slower(0.97), calm), false, calm_base).regressions, 0);
  EXPECT_EQ(run_compare(edited("half_speed_det", slower(0.5), calm), true, calm_base).regressions, 0)
      << "timings ignored";
  // With the measured spread of a real run as the margin, what the noise could explain is not flagged.
  // Here: half speed, but with a measured spread of 60%: within the noise.
  EXPECT_EQ(run_compare(edited(
                            "wide_spread",
                            [&](CsvRow& row) {
                              slower(0.5)(row);
                              row["trace_mrays_min"] = times(row["trace_mrays_median"], 0.4);
                            },
                            calm),
                        false, calm_base)
                .regressions,
            0);
}

TEST(HarnessCompare, ALostCellIsARegression) {
  const auto current = edited("lost", [](CsvRow& row) { row["ray_set"] = "renamed"; });
  std::ostringstream out;
  const CompareResult r = compare_results({baseline(), current, true, std::nullopt, 0.10}, out);
  EXPECT_EQ(r.missing_cells, 1);
  EXPECT_GE(r.regressions, 1);
  EXPECT_NE(out.str().find("Cells in the baseline but not in the new run"), std::string::npos) << out.str();
}

TEST(HarnessCompare, JsonForDashboards) {
  std::ostringstream out;
  const auto json = dir() / "bench.json";
  compare_results({baseline(), baseline(), false, json, 0.10}, out);
  std::ifstream in(json);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"unit\": \"sah_cost\""), std::string::npos) << text;
  std::ifstream bigger(dir() / "bench-bigger.json");
  const std::string big((std::istreambuf_iterator<char>(bigger)), std::istreambuf_iterator<char>());
  EXPECT_NE(big.find("trace_mrays/embree"), std::string::npos) << big;
}

}  // namespace
}  // namespace sahbench
