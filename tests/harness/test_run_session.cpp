// A run's identity and integrity: resume only the run of the same fingerprint (and say what differs
// otherwise), the full cell set under one id after a killed rerun, one writer per CSV, SIGINT between
// cells, the shuffled round order, the samples columns, and an invalid tree's row instead of a crash.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <set>
#include <sstream>

#include "builders/registry.h"
#include "core/error.h"
#include "harness/run/csv.h"
#include "harness/run/round_order.h"
#include "harness/run/run_session.h"
#include "harness/run/runner.h"
#include "harness/run/timing.h"
#include "tests/support/process_temp_dir.h"

namespace sahbench {
namespace {

std::filesystem::path temp_dir() {
  return test::process_temp_dir("run_session");
}

// A config of 2 scenes x 2 builder runs (+ `extra`) x 2 layouts x 2 thread counts x 2 ray sets.
std::filesystem::path write_config(const std::string& name, uint64_t seed = 1, int trace_reps = 3,
                                   const std::string& extra = "", bool keep_csv = false) {
  const auto dir = temp_dir();
  const auto csv = dir / (name + ".csv");
  if (!keep_csv) std::filesystem::remove(csv);
  const auto path = dir / (name + ".toml");
  std::ofstream(path) << "[experiment]\nname = \"" << name << "\"\noutput = \"" << csv.string() << "\"\n"
                      << "seed = " << seed << "\n"
                      << "threads = [1, 2]\nscenes = [\"proc:sphere:tris=3000\", \"proc:soup:tris=2000\"]\n"
                      << "layouts = [\"bvh2\", \"bvh8\"]\nreference = \"brute_force\"\n"
                      << "[repetitions]\nbuild = 2\nbuild_warmup = 0\ntrace = " << trace_reps
                      << "\ntrace_warmup = 0\n"
                      << "[[builder]]\nname = \"binned_sah\"\n[[builder]]\nname = \"wide_collapse\"\n"
                      << extra << "[[ray_set]]\nkind = \"primary\"\nwidth = 16\nheight = 16\n"
                      << "[[ray_set]]\nkind = \"shadow\"\nwidth = 16\nheight = 16\n";
  return path;
}

std::string key_of(const CsvRow& r) {
  return cell_key(r.at("scene"), r.at("builder"), r.at("builder_params"), r.at("layout"),
                  std::stoi(r.at("threads")), r.at("ray_set"), std::stoi(r.at("frame")));
}

std::vector<double> split_samples(const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ';');) out.push_back(std::stod(item));
  return out;
}

TEST(RunSession, RowsCarryTheFingerprintSamplesBuildPlusLayoutAndHitFraction) {
  const auto config = write_config("session_columns");
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
  const auto rows = read_csv(temp_dir() / "session_columns.csv");
  ASSERT_EQ(rows.size(), 16u) << log.str();  // wide_collapse only on bvh8, binned_sah only on bvh2
  for (const auto& row : rows) {
    EXPECT_EQ(row.at("run_fingerprint").size(), 16u);
    EXPECT_EQ(row.at("run_fingerprint"), rows.front().at("run_fingerprint"));
    EXPECT_NE(row.at("fingerprint_parts").find("seed="), std::string::npos);
    for (const char* prefix : {"trace_mrays", "build_ms"}) {
      const std::vector<double> samples = split_samples(row.at(std::string(prefix) + "_samples"));
      ASSERT_EQ(samples.size(), std::string(prefix) == "build_ms" ? 2u : 3u) << prefix;
      // The median column is the samples' median, to the 4 decimals both are written with.
      EXPECT_NEAR(summarize(samples).median, std::stod(row.at(std::string(prefix) + "_median")), 1e-4)
          << prefix;
    }
    const double build = std::stod(row.at("build_ms_median"));
    EXPECT_GE(std::stod(row.at("build_layout_ms_median")), build - 1e-4);
    const double hits = std::stod(row.at("hit_fraction"));
    EXPECT_GT(hits, 0.0);
    EXPECT_LE(hits, 1.0);
  }
}

TEST(RunSession, ResumeWithAChangedConfigRefusesAndNamesWhatDiffers) {
  const auto config = write_config("session_changed");
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "proc:soup", std::nullopt}, log), 0) << log.str();
  // Another seed and other repetitions: the finished cells measured something else.
  write_config("session_changed", 2, 4, "", true);
  try {
    run_experiment({config, true, "", std::nullopt}, log);
    FAIL() << "a resume of a changed config must be refused";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("session_changed.csv: --resume"), std::string::npos) << what;
    EXPECT_NE(what.find("differs in: seed, repetitions"), std::string::npos) << what;
  }
  EXPECT_EQ(read_csv(temp_dir() / "session_changed.csv").size(), 8u) << "a refused resume writes nothing";
}

TEST(RunSession, ResumeAfterAKilledRerunGivesTheFullSetUnderOneRunId) {
  const auto config = write_config("session_rerun");
  const auto csv = temp_dir() / "session_rerun.csv";
  std::ostringstream log;
  // Run A stops after one scene; rerun B, without --resume, stops after a few cells of the other one.
  ASSERT_EQ(run_experiment({config, false, "proc:soup", std::nullopt}, log), 0);
  ASSERT_EQ(run_experiment({config, false, "sphere:tris=3000|binned_sah", std::nullopt}, log), 0);
  const auto before = read_csv(csv);
  ASSERT_EQ(before.size(), 8u + 4u);
  const std::string rerun_id = before.back().at("run_id");
  EXPECT_NE(rerun_id, before.front().at("run_id")) << "two runs, two ids";
  ASSERT_EQ(run_experiment({config, true, "", std::nullopt}, log), 0) << log.str();
  std::set<std::string> keys;
  for (const auto& r : read_csv(csv))
    if (r.at("run_id") == rerun_id) {
      EXPECT_TRUE(keys.insert(key_of(r)).second) << "twice: " << key_of(r);
    }
  EXPECT_EQ(keys.size(), 16u) << "the resumed run holds every cell once\n" << log.str();
}

TEST(RunSession, ASecondWriterIsRefusedWhileTheFirstHoldsTheLock) {
  const auto config = write_config("session_locked");
  const auto csv = temp_dir() / "session_locked.csv";
  {
    const OutputLock first(csv);
    std::ostringstream log;
    try {
      run_experiment({config, false, "", std::nullopt}, log);
      FAIL() << "a second writer must be refused";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(csv.string()), std::string::npos) << what;
      EXPECT_NE(what.find("pid " + std::to_string(::getpid())), std::string::npos) << what;
    }
    EXPECT_FALSE(std::filesystem::exists(csv)) << "the refused writer touched the file";
  }
  // Released: the next writer runs.
  std::ostringstream log;
  EXPECT_EQ(run_experiment({config, false, "proc:soup", std::nullopt}, log), 0) << log.str();
}

TEST(RunSession, RunIdsDifferWithinOneSecond) {
  std::set<std::string> ids;
  for (int i = 0; i < 20; ++i) ids.insert(make_run_id("x"));
  EXPECT_GT(ids.size(), 15u) << "four random hex digits repeat 20 times in a row only by a bug";
}

TEST(RunSession, SigintBetweenCellsKeepsWholeRowsAndSaysHowToContinue) {
  // A builder that raises SIGINT during its first build on the second scene, once.
  static bool raised = false;
  static const bool registered = [] {
    BuilderInfo interrupting = find_builder("binned_sah");
    interrupting.name = "interrupting_for_test";
    auto build = interrupting.build;
    interrupting.build = [build](const BuildInput& input, const ParamSet& p) {
      if (!raised && input.size() < 2500) {  // the soup, not the sphere
        raised = true;
        std::raise(SIGINT);
      }
      return build(input, p);
    };
    register_builder(interrupting);
    return true;
  }();
  ASSERT_TRUE(registered);
  const auto config = write_config("session_sigint", 1, 3, "[[builder]]\nname = \"interrupting_for_test\"\n");
  const auto csv = temp_dir() / "session_sigint.csv";
  std::ostringstream log;
  try {
    run_experiment({config, false, "", std::nullopt}, log);
    FAIL() << "expected Interrupted";
  } catch (const Interrupted& e) {
    // The first scene's 24 cells were finished and written; the second scene's were dropped.
    EXPECT_EQ(std::string(e.what()), "interrupted after 12 of 24 cells; continue with: sahbench run " +
                                         config.string() + " --resume")
        << log.str();
  }
  const auto rows = read_csv(csv);
  EXPECT_EQ(rows.size(), 12u);
  for (const auto& r : rows) EXPECT_EQ(r.at("scene"), "proc:sphere:tris=3000");
  ASSERT_EQ(run_experiment({config, true, "", std::nullopt}, log), 0) << log.str();
  const auto all = read_csv(csv);
  EXPECT_EQ(all.size(), 24u);
  for (const auto& r : all) EXPECT_EQ(r.at("run_id"), all.front().at("run_id"));
}

TEST(RunSession, TheContinueCommandKeepsOutputAndOnlyQuotedForAShell) {
  const RunOptions options{"configs/paper.toml", false, "crytek_sponza|it's", "out dir/r.csv"};
  EXPECT_EQ(
      resume_command(options),
      "sahbench run configs/paper.toml --resume --output 'out dir/r.csv' --only 'crytek_sponza|it'\\''s'");
  EXPECT_EQ(resume_command({"c.toml", false, "", std::nullopt}), "sahbench run c.toml --resume");
}

TEST(RunSession, AnOutOfRangeChildGivesAnInvalidTreeRowNotACrash) {
  static const bool registered = [] {
    BuilderInfo broken = find_builder("binned_sah");
    broken.name = "child_out_of_range_for_test";
    auto build = broken.build;
    broken.build = [build](const BuildInput& input, const ParamSet& p) {
      Bvh bvh = build(input, p);
      bvh.nodes[0].first = static_cast<uint32_t>(bvh.nodes.size() + 1000);  // the root's children
      return bvh;
    };
    register_builder(broken);
    return true;
  }();
  ASSERT_TRUE(registered);
  const auto config =
      write_config("session_out_of_range", 1, 3, "[[builder]]\nname = \"child_out_of_range_for_test\"\n");
  std::ostringstream log;
  EXPECT_EQ(run_experiment({config, false, "child_out_of_range", std::nullopt}, log), 1);
  const auto rows = read_csv(temp_dir() / "session_out_of_range.csv");
  ASSERT_EQ(rows.size(), 8u);
  for (const auto& r : rows) {
    EXPECT_NE(r.at("notes").find("invalid tree, not traced"), std::string::npos) << r.at("notes");
    EXPECT_EQ(r.at("sah_cost"), "") << "no statistics of a tree that failed validation";
  }
}

TEST(RoundOrder, IsAPermutationFixedBySeedAndRoundAndDiffersBetweenRounds) {
  const uint64_t seed = order_seed(1, "proc:sphere", 2, "trace");
  EXPECT_NE(seed, order_seed(2, "proc:sphere", 2, "trace"));
  EXPECT_NE(seed, order_seed(1, "proc:sphere", 1, "trace"));
  EXPECT_NE(seed, order_seed(1, "proc:sphere", 2, "build"));
  std::set<std::vector<std::size_t>> orders;
  for (int round = 0; round < 10; ++round) {
    const auto order = round_order(seed, 12, round);
    EXPECT_EQ(order, round_order(seed, 12, round)) << "the same seed and round give the same order";
    auto sorted = order;
    std::sort(sorted.begin(), sorted.end());
    std::vector<std::size_t> expected(12);
    std::iota(expected.begin(), expected.end(), std::size_t{0});
    EXPECT_EQ(sorted, expected) << "a permutation of the cells";
    orders.insert(order);
  }
  EXPECT_EQ(orders.size(), 10u) << "every round its own order";
  // No cell always follows the same one: over the rounds each cell has several predecessors.
  std::vector<std::set<std::size_t>> before(12);
  for (int round = 0; round < 10; ++round) {
    const auto order = round_order(seed, 12, round);
    for (std::size_t i = 1; i < order.size(); ++i) before[order[i]].insert(order[i - 1]);
  }
  for (const auto& b : before) EXPECT_GE(b.size(), 3u);
}

}  // namespace
}  // namespace sahbench
