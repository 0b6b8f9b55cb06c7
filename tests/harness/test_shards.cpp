// Sharded sweeps (harness/run/shard_plan.h, shard_merge.h): the plan is deterministic; for any number of
// shards their union is the config's cell set with no cell twice, and Embree's anchors are in every
// shard that measures their scene and thread count; shards run and merged equal one process in every
// deterministic metric, and report and compare pair each row with its own shard's anchor; merge refuses
// shards of different fingerprints, a missing shard and a duplicated cell, naming them.

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "harness/config/config.h"
#include "harness/embree/embree_layouts.h"
#include "harness/report/compare.h"
#include "harness/report/report.h"
#include "harness/run/csv.h"
#include "harness/run/run_session.h"
#include "harness/run/runner.h"
#include "harness/run/shard_merge.h"
#include "harness/run/shard_plan.h"
#include "tests/support/error_of.h"

namespace sahbench {
namespace {

using test::error_of;

// One directory per process: ctest runs each test in its own process, in parallel.
std::filesystem::path dir() {
  const auto d =
      std::filesystem::temp_directory_path() / ("sahbench_test_shards_" + std::to_string(getpid()));
  std::filesystem::create_directories(d);
  return d;
}

// Three scenes of different sizes, two thread counts, our builders and Embree in both modes: units of
// work of many sizes, and anchors (default and robust) in every group.
const char* kPlanConfig = R"(
[experiment]
name = "shards"
threads = [1, 2]
scenes = ["proc:sphere:tris=30k", "proc:soup:tris=5k", "proc:needles:tris=1k"]
layouts = ["bvh2", "bvh2_packed", "bvh8"]
[[builder]]
name = "binned_sah"
bins = [8, 32]
[[builder]]
name = "sweep_sah"
[[builder]]
name = "wide_collapse"
[[builder]]
name = "embree"
quality = ["medium", "high"]
[[builder]]
name = "embree"
robust = true
[[ray_set]]
kind = "primary"
width = 32
height = 32
[[ray_set]]
kind = "shadow"
width = 32
height = 32
)";

ExperimentConfig plan_config() {
  return parse_experiment_config(kPlanConfig, "shards.toml");
}

// Every layout of the config and every one of Embree's, whatever this CPU runs.
RunLayouts all_layouts(const ExperimentConfig& cfg) {
  return {cfg.layouts, std::vector<EmbreeLayout>(std::begin(kEmbreeLayouts), std::end(kEmbreeLayouts))};
}

TEST(ShardPlan, IsDeterministic) {
  const ExperimentConfig cfg = plan_config();
  for (int n = 1; n <= 7; ++n) {
    const ShardPlan a = plan_shards(cfg, cfg.scenes, all_layouts(cfg), n),
                    b = plan_shards(cfg, cfg.scenes, all_layouts(cfg), n);
    EXPECT_EQ(a.owners, b.owners) << n << " shards";
    for (int k = 0; k < n; ++k) EXPECT_EQ(a.keys_of(k), b.keys_of(k));
  }
}

TEST(ShardPlan, ShardsCoverTheCellSetWithNoCellTwiceAndCarryTheirAnchors) {
  const ExperimentConfig cfg = plan_config();
  const std::vector<PlannedCell> all = static_cells(cfg, cfg.scenes, all_layouts(cfg));
  std::set<std::string> keys;
  for (const auto& c : all) keys.insert(c.key);
  ASSERT_EQ(keys.size(), all.size());
  for (int n = 1; n <= 7; ++n) {
    const ShardPlan plan = plan_shards(cfg, cfg.scenes, all_layouts(cfg), n);
    ASSERT_EQ(plan.cells.size(), all.size());
    std::map<std::string, int> times;  // non-anchor cell -> shards that run it
    std::set<std::string> covered;
    // (scene, threads) -> shards that measure a cell of ours or a non-anchor Embree cell there
    std::map<std::pair<std::string, int>, std::set<int>> measuring;
    for (int k = 0; k < n; ++k)
      for (const auto& key : plan.keys_of(k)) covered.insert(key);
    EXPECT_EQ(covered, keys) << n << " shards";
    for (std::size_t i = 0; i < plan.cells.size(); ++i) {
      const PlannedCell& c = plan.cells[i];
      ASSERT_FALSE(plan.owners[i].empty()) << c.key;
      if (is_anchor_cell(cfg, c)) continue;
      EXPECT_EQ(plan.owners[i].size(), 1u) << c.key << " in " << n << " shards";
      measuring[{c.scene, c.threads}].insert(plan.owners[i].front());
    }
    // Every anchor is in exactly the shards that measure its scene and thread count.
    std::size_t anchors = 0;
    for (std::size_t i = 0; i < plan.cells.size(); ++i) {
      const PlannedCell& c = plan.cells[i];
      if (!is_anchor_cell(cfg, c)) continue;
      ++anchors;
      const auto& want = measuring[{c.scene, c.threads}];
      EXPECT_EQ(std::set<int>(plan.owners[i].begin(), plan.owners[i].end()), want) << c.key;
    }
    // Default and robust mode, 3 Embree layouts, 2 ray sets, 3 scenes, 2 thread counts.
    EXPECT_EQ(anchors, 2u * 3 * 2 * 3 * 2);
    // The cost is spread: no shard empty (42 units of work here, more than shards).
    for (int k = 0; k < n; ++k) {
      EXPECT_FALSE(plan.keys_of(k).empty()) << k << "/" << n;
    }
  }
}

TEST(ShardPlan, ShardSpecIsKOfNFromZero) {
  EXPECT_EQ(parse_shard_spec("0/4"), (ShardSpec{0, 4}));
  EXPECT_EQ(parse_shard_spec("3/4").text(), "3/4");
  EXPECT_NE(error_of([] { parse_shard_spec("4/4"); }).find("--shard '4/4': K must lie in 0..N-1"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_shard_spec("1-4"); }).find("no '/'"), std::string::npos);
  EXPECT_NE(error_of([] { parse_shard_spec("a/4"); }).find("'a' is not a whole number"), std::string::npos);
  EXPECT_NE(error_of([] { parse_shard_spec("0/0"); }).find("N must be at least 1"), std::string::npos);
  EXPECT_EQ(shard_output_path("results/ci.csv", {2, 4}),
            std::filesystem::path("results/ci-shard-2-of-4.csv"));
}

// A small sweep run for real: two scenes, two builder runs of ours and Embree's anchor.
std::filesystem::path write_run_config(const std::string& name, int seed) {
  const auto path = dir() / (name + ".toml");
  std::ofstream(path) << fmt::format(R"([experiment]
name = "{}"
output = "{}"
seed = {}
scenes = ["proc:sphere:tris=2000", "proc:soup:tris=1000"]
layouts = ["bvh2", "bvh2_packed"]
reference = "brute_force"
[repetitions]
build = 2
build_warmup = 0
trace = 2
trace_warmup = 0
[[builder]]
name = "binned_sah"
bins = [8, 16]
[[builder]]
name = "sweep_sah"
[[builder]]
name = "embree"
[[ray_set]]
kind = "primary"
width = 16
height = 16
[[ray_set]]
kind = "shadow"
width = 16
height = 16
)",
                                     name, (dir() / (name + ".csv")).string(), seed);
  return path;
}

// Runs shards 0..n-1 of `config` (each to its default path) and returns their CSVs.
std::vector<std::filesystem::path> run_shards(const std::filesystem::path& config, int n) {
  std::vector<std::filesystem::path> out;
  for (int k = 0; k < n; ++k) {
    RunOptions options{config, false, "", std::nullopt};
    options.shard = ShardSpec{k, n};
    const auto csv = shard_output_path(load_experiment_config(config).output, *options.shard);
    std::filesystem::remove(csv);
    std::ostringstream log;
    EXPECT_EQ(run_experiment(options, log), 0) << log.str();
    out.push_back(csv);
  }
  return out;
}

TEST(ShardMerge, MergedShardsEqualOneProcessAndPairRowsWithTheirShardsAnchor) {
  const auto config = write_run_config("merge_ok", 3);
  const auto single = dir() / "merge_ok.csv";
  std::filesystem::remove(single);
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
  const auto shards = run_shards(config, 3);
  const auto merged = dir() / "merge_ok_merged.csv";
  const MergeSummary summary = merge_shards({merged, shards, std::nullopt}, log);
  EXPECT_EQ(summary.shards, 3);

  const auto one = read_csv(single), rows = read_csv(merged);
  std::set<std::string> run_ids, shard_names;
  std::size_t ours = 0;
  for (const auto& r : rows) {
    run_ids.insert(r.at("run_id"));
    shard_names.insert(r.at("shard"));
    EXPECT_FALSE(r.at("shard_run_id").empty());
    ours += r.at("builder") != "embree";
  }
  EXPECT_EQ(run_ids.size(), 1u);
  EXPECT_EQ(*run_ids.begin(), summary.run_id);
  EXPECT_EQ(shard_names.size(), 3u);
  std::size_t ours_single = 0;
  for (const auto& r : one) ours_single += r.at("builder") != "embree";
  EXPECT_EQ(ours, ours_single);
  EXPECT_EQ(rows.size(), summary.rows);

  // Every deterministic metric as in one process.
  std::ostringstream out;
  CompareOptions det{single, merged, true, std::nullopt, 0.02};
  const CompareResult same = compare_results(det, out);
  EXPECT_EQ(same.regressions, 0) << out.str();
  EXPECT_EQ(same.missing_cells, 0) << out.str();
  EXPECT_EQ(static_cast<std::size_t>(same.compared_cells), ours_single) << out.str();
  // Timings: every row of ours finds its anchor in its own shard (merged against itself: no
  // anchor missing, no cell twice though Embree's anchor is there once per shard).
  CompareOptions timed{merged, merged, false, std::nullopt, 0.02};
  const CompareResult self = compare_results(timed, out);
  EXPECT_EQ(self.missing_anchors, 0) << out.str();
  EXPECT_EQ(self.regressions, 0) << out.str();
  // The report reads the merged file as one run.
  ReportOptions report;
  report.inputs = {merged};
  std::ostringstream text;
  run_report_command(report, text);
  EXPECT_NE(text.str().find("# sahbench report: run " + summary.run_id), std::string::npos) << text.str();
}

TEST(ShardMerge, ReportRatiosUseTheRowsOwnShardAnchor) {
  // Two shards whose anchors differ tenfold in rays/s: each row's ratio is to its own shard's.
  const auto path = dir() / "pairs.csv";
  std::filesystem::remove(path);
  {
    CsvWriter csv(path, result_columns());
    auto row = [](const std::string& shard, const std::string& builder, const std::string& params,
                  const std::string& layout, const std::string& mrays) {
      CsvRow r;
      r["run_id"] = "m";
      r["run_fingerprint"] = "0123456789abcdef";
      r["shard"] = shard;
      r["scene"] = "s";
      r["threads"] = "1";
      r["frame"] = "0";
      r["builder"] = builder;
      r["builder_params"] = params;
      r["layout"] = layout;
      r["ray_set"] = "primary";
      r["trace_mrays_median"] = mrays;
      return r;
    };
    csv.append(row("0/2", "embree", "quality=medium", "embree_1", "10.0000"));
    csv.append(row("0/2", "binned_sah", "bins=8", "bvh2", "20.0000"));
    csv.append(row("1/2", "embree", "quality=medium", "embree_1", "1.0000"));
    csv.append(row("1/2", "sweep_sah", "", "bvh2", "20.0000"));
  }
  ReportOptions report;
  report.inputs = {path};
  std::ostringstream text;
  run_report_command(report, text);
  const std::string t = text.str();
  // binned_sah: 20 / 10 (its shard's anchor); sweep_sah: 20 / 1.
  const auto binned = t.find("binned_sah"), sweep = t.find("sweep_sah");
  ASSERT_NE(binned, std::string::npos) << t;
  ASSERT_NE(sweep, std::string::npos) << t;
  EXPECT_NE(t.substr(binned, t.find('\n', binned) - binned).find("(2.00"), std::string::npos) << t;
  EXPECT_NE(t.substr(sweep, t.find('\n', sweep) - sweep).find("(20.00"), std::string::npos) << t;
}

TEST(ShardMerge, RefusesDifferentFingerprintsMissingShardsAndDuplicatedCells) {
  const auto config = write_run_config("merge_bad", 5);
  const auto shards = run_shards(config, 3);
  const auto merged = dir() / "merge_bad_merged.csv";
  std::ostringstream log;

  // A missing shard: named with its cell count.
  const std::string missing = error_of([&] {
    merge_shards({merged, {shards[0], shards[2]}, std::nullopt}, log);
  });
  EXPECT_NE(missing.find("missing shards:\n  shard 1/3 ("), std::string::npos) << missing;

  // A duplicated cell: a row of shard 2 written twice is named, with its shard and file.
  const auto twice = dir() / "merge_bad_twice.csv";
  std::filesystem::copy_file(shards[2], twice, std::filesystem::copy_options::overwrite_existing);
  const auto rows = read_csv(twice);
  ASSERT_FALSE(rows.empty());
  {
    CsvWriter csv(twice, result_columns());
    csv.append(rows.front());
  }
  const std::string key =
      fmt::format("{}|{}|{}|{}|{}|{}|0", rows.front().at("scene"), rows.front().at("builder"),
                  rows.front().at("builder_params"), rows.front().at("layout"), rows.front().at("threads"),
                  rows.front().at("ray_set"));
  const std::string duplicated = error_of([&] {
    merge_shards({merged, {shards[0], shards[1], twice}, std::nullopt}, log);
  });
  EXPECT_NE(duplicated.find("1 duplicated cells:\n  " + key + " (shard 2/3, " + twice.string()),
            std::string::npos)
      << duplicated;

  // A shard given twice.
  const std::string again = error_of([&] {
    merge_shards({merged, {shards[0], shards[1], shards[2], shards[2]}, std::nullopt}, log);
  });
  EXPECT_NE(again.find("shard 2/3 is given twice"), std::string::npos) << again;

  // A shard of another run (another seed): the two files and the differing part are named.
  const auto other_config = write_run_config("merge_other", 6);
  RunOptions options{other_config, false, "", std::nullopt};
  options.shard = ShardSpec{1, 3};
  const auto other = dir() / "merge_other_shard1.csv";
  std::filesystem::remove(other);
  options.output = other;
  ASSERT_EQ(run_experiment(options, log), 0) << log.str();
  const std::string different = error_of([&] {
    merge_shards({merged, {shards[0], other, shards[2]}, std::nullopt}, log);
  });
  EXPECT_NE(different.find(shards[0].string() + " (shard 0/3) has run fingerprint"), std::string::npos)
      << different;
  EXPECT_NE(different.find(other.string() + " (shard 1/3) has"), std::string::npos) << different;
  EXPECT_NE(different.find("they differ in: seed"), std::string::npos) << different;
  EXPECT_FALSE(std::filesystem::exists(merged));
}

// A merge replaces its output: an earlier merge may be made again, but rows of a run are never lost, and
// an output a run is writing is refused.
TEST(ShardMerge, ReplacesOnlyAnEarlierMergeOfTheSameSweep) {
  const auto config = write_run_config("merge_over", 7);
  const auto shards = run_shards(config, 2);
  const auto merged = dir() / "merge_over_merged.csv";
  std::filesystem::remove(merged);
  std::ostringstream log;
  const MergeSummary first = merge_shards({merged, shards, std::nullopt}, log);
  const MergeSummary again = merge_shards({merged, shards, std::nullopt}, log);
  EXPECT_EQ(again.rows, first.rows);
  EXPECT_EQ(read_csv(merged).size(), first.rows);

  // A run's rows: refused, and the file keeps them.
  const auto run_rows = dir() / "merge_over_run.csv";
  std::filesystem::copy_file(shards[0], run_rows, std::filesystem::copy_options::overwrite_existing);
  const std::size_t kept = read_csv(run_rows).size();
  const std::string refused = error_of([&] { merge_shards({run_rows, shards, std::nullopt}, log); });
  EXPECT_NE(refused.find("merge: the output " + run_rows.string() + " holds rows of a run"),
            std::string::npos)
      << refused;
  EXPECT_NE(refused.find("merge into a new file"), std::string::npos) << refused;
  EXPECT_EQ(read_csv(run_rows).size(), kept);

  // Locked by a run that is writing it.
  const auto busy = dir() / "merge_over_busy.csv";
  std::filesystem::remove(busy);
  const OutputLock writing(busy);
  const std::string locked = error_of([&] { merge_shards({busy, shards, std::nullopt}, log); });
  EXPECT_NE(locked.find(busy.string()), std::string::npos) << locked;
  EXPECT_FALSE(std::filesystem::exists(busy));
}

// Shards run on CPUs that skip a layout (16-ray packets without AVX-512) merge without its cells; a
// layout every CPU runs is planned all the same, so its cells are missing when its rows are.
TEST(ShardMerge, TakesLayoutsTheShardsCpuSkippedAsSkipped) {
  const auto config = dir() / "merge_skipped.toml";
  std::ofstream(config) << fmt::format(R"([experiment]
name = "merge_skipped"
output = "{}"
scenes = ["proc:sphere:tris=1500"]
layouts = ["bvh8", "bvh8:packet=8"]
reference = "brute_force"
[repetitions]
build = 1
build_warmup = 0
trace = 1
trace_warmup = 0
[[builder]]
name = "wide_collapse"
[[builder]]
name = "embree"
[[ray_set]]
kind = "primary"
width = 16
height = 16
)",
                                       (dir() / "merge_skipped.csv").string());
  const auto shards = run_shards(config, 2);
  // The shards as a CPU without the layout would have written them: without its rows.
  const auto without = [&](const std::string& layout) {
    std::vector<std::filesystem::path> out;
    for (std::size_t k = 0; k < shards.size(); ++k) {
      const auto rows = read_csv(shards[k]);
      const auto path = dir() / fmt::format("merge_skipped_without_{}.csv", k);
      std::filesystem::remove(path);
      CsvWriter csv(path, result_columns());
      for (const CsvRow& row : rows)
        if (row.at("layout") != layout) csv.append(row);
      out.push_back(path);
    }
    return out;
  };
  const auto merged = dir() / "merge_skipped_merged.csv";
  std::filesystem::remove(merged);
  std::ostringstream log;
  merge_shards({merged, without("bvh8:packet=8"), std::nullopt}, log);
  EXPECT_NE(log.str().find("layout bvh8:packet=8: no rows in any shard, taken as skipped"), std::string::npos)
      << log.str();
  for (const CsvRow& row : read_csv(merged)) EXPECT_NE(row.at("layout"), "bvh8:packet=8");
  std::filesystem::remove(merged);
  const std::string missing = error_of([&] { merge_shards({merged, without("bvh8"), std::nullopt}, log); });
  EXPECT_NE(missing.find("missing"), std::string::npos) << missing;
  EXPECT_NE(missing.find("|bvh8|"), std::string::npos) << missing;
}

TEST(ShardRun, ResumeContinuesOnlyItsOwnShard) {
  const auto config = write_run_config("resume_shard", 7);
  const auto shards = run_shards(config, 2);
  // Shard 1 resumed in shard 0's file: refused, naming both.
  RunOptions options{config, true, "", shards[0]};
  options.shard = ShardSpec{1, 2};
  std::ostringstream log;
  const std::string msg = error_of([&] { run_experiment(options, log); });
  EXPECT_NE(msg.find("from shard 0/2, not from shard 1/2"), std::string::npos) << msg;
  // Its own file: nothing left to do, no row added.
  const auto before = read_csv(shards[1]).size();
  options.output = shards[1];
  EXPECT_EQ(run_experiment(options, log), 0) << log.str();
  EXPECT_EQ(read_csv(shards[1]).size(), before);
}

}  // namespace
}  // namespace sahbench
