// The harness end to end: a small config runs, writes one row per cell with the reference check, resumes
// without redoing cells, filters with --only, and the report and trace commands read and write what
// they say.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <memory>
#include <sstream>

#include "builders/registry.h"
#include "cli/trace_command.h"
#include "core/error.h"
#include "harness/embree/embree_layouts.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "harness/report/compare.h"
#include "harness/report/report.h"
#include "harness/run/csv.h"
#include "harness/run/environment.h"
#include "harness/run/runner.h"
#include "scenes/load.h"
#include "scenes/ray_file.h"
#include "tests/support/error_of.h"
#include "tests/support/hit_check.h"
#include "tests/support/process_temp_dir.h"
#include "tests/support/test_scenes.h"
#include "traversal/brute_force.h"
#include "traversal/kernel_variant.h"

namespace sahbench {
namespace {

std::filesystem::path temp_dir() {
  return test::process_temp_dir("run");
}

std::filesystem::path write_config(const std::string& name, const std::string& extra_builders) {
  const auto dir = temp_dir();
  const auto csv = dir / (name + ".csv");
  std::filesystem::remove(csv);
  const auto path = dir / (name + ".toml");
  std::ofstream(path) << "[experiment]\nname = \"" << name << "\"\noutput = \"" << csv.string() << "\"\n"
                      << "threads = [1, 2]\nscenes = [\"proc:sphere:tris=3000\", \"proc:soup:tris=2000\"]\n"
                      << "layouts = [\"bvh2\", \"bvh2_packed\"]\nreference = \"brute_force\"\n"
                      << "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 2\ntrace_warmup = 0\n"
                      << "[[builder]]\nname = \"binned_sah\"\nbins = [8, 16]\n"
                      << extra_builders << "[[ray_set]]\nkind = \"primary\"\nwidth = 24\nheight = 24\n"
                      << "[[ray_set]]\nkind = \"shadow\"\nwidth = 24\nheight = 24\n";
  return path;
}

// A layout the CPU cannot run (16-ray packets without AVX-512) is skipped with a line naming it and why, as
// Embree's packets are, and the run measures the rest; where the CPU has AVX-512 it is measured.
TEST(HarnessRun, LayoutsTheCpuCannotRunAreSkippedNotFatal) {
  const auto dir = temp_dir();
  const auto csv = dir / "run_packets16.csv";
  std::filesystem::remove(csv);
  const auto path = dir / "run_packets16.toml";
  std::ofstream(path) << "[experiment]\nname = \"packets16\"\noutput = \"" << csv.string() << "\"\n"
                      << "scenes = [\"proc:sphere:tris=2000\"]\nreference = \"brute_force\"\n"
                      << "layouts = [\"bvh8\", \"bvh8:packet=16\"]\n"
                      << "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
                      << "[[builder]]\nname = \"wide_collapse\"\n"
                      << "[[ray_set]]\nkind = \"primary\"\nwidth = 16\nheight = 16\n";
  std::ostringstream log;
  ASSERT_EQ(run_experiment({path, false, "", std::nullopt}, log), 0) << log.str();
  std::map<std::string, std::string> mismatches;  // our layouts' rows
  for (const auto& row : read_csv(csv))
    if (row.at("builder") != "embree") mismatches[row.at("layout")] = row.at("mismatches");
  EXPECT_EQ(mismatches["bvh8"], "0") << log.str();
  const bool skipped =
      log.str().find("skipping layout bvh8:packet=16: 16-ray packets need AVX-512") != std::string::npos;
  EXPECT_EQ(skipped, !kernel_isa_available(KernelIsa::kAvx512)) << log.str();
  EXPECT_EQ(mismatches.count("bvh8:packet=16"), skipped ? 0u : 1u) << log.str();
  if (!skipped) {
    EXPECT_EQ(mismatches["bvh8:packet=16"], "0");
  }
}

TEST(HarnessRun, EveryCellWritesARowWithNoMismatchesAndResumeSkipsThem) {
  const auto config = write_config("run_small", "");
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
  const auto csv = temp_dir() / "run_small.csv";
  const auto rows = read_csv(csv);
  // 2 scenes x 2 builder runs x 2 layouts x 2 thread counts x 2 ray sets.
  ASSERT_EQ(rows.size(), 32u) << log.str();
  for (const auto& row : rows) {
    EXPECT_EQ(row.at("mismatches"), "0")
        << row.at("scene") << " " << row.at("layout") << " " << row.at("ray_set");
    EXPECT_EQ(row.at("reference"), "brute_force");
    EXPECT_GT(std::stod(row.at("trace_mrays_median")), 0.0);
    EXPECT_GT(std::stod(row.at("nodes_per_ray")), 0.0);
    EXPECT_FALSE(row.at("git_commit").empty());
    EXPECT_FALSE(row.at("isa").empty());
    // The compile target, which report captions give as "built for" (it had been left empty, and the
    // captions named the first row's kernel ISA instead).
    EXPECT_EQ(row.at("build_isa"), current_environment().isa);
    EXPECT_EQ(row.at("sah_c_trav"), "1");
  }
  EXPECT_NE(log.str().find("[32/32]"), std::string::npos) << log.str();
  // Same input, same parameters: the same tree and traversal whatever the thread count (DESIGN.md), so
  // every deterministic column of a 2-thread row equals its 1-thread twin's.
  std::vector<std::string> deterministic = {"hit_fraction", "arity", "ray_count", "scene_triangles"};
  for (const MetricRule& rule : deterministic_metrics()) deterministic.push_back(rule.column);
  std::map<std::string, std::map<std::string, const CsvRow*>> by_threads;  // cell without threads -> threads
  for (const auto& row : rows)
    by_threads[row.at("scene") + "|" + row.at("builder") + "|" + row.at("builder_params") + "|" +
               row.at("layout") + "|" + row.at("ray_set")][row.at("threads")] = &row;
  ASSERT_EQ(by_threads.size(), 16u);
  for (const auto& [cell, rows_of] : by_threads) {
    ASSERT_EQ(rows_of.size(), 2u) << cell;
    const CsvRow &one = *rows_of.at("1"), &two = *rows_of.at("2");
    for (const std::string& column : deterministic) {
      EXPECT_FALSE(one.at(column).empty()) << cell << " " << column;
      EXPECT_EQ(one.at(column), two.at(column)) << cell << " " << column;
    }
  }

  // Resume: nothing left to do, nothing appended.
  std::ostringstream again;
  ASSERT_EQ(run_experiment({config, true, "", std::nullopt}, again), 0);
  EXPECT_EQ(read_csv(csv).size(), 32u);
  EXPECT_NE(again.str().find("0 cells to run"), std::string::npos) << again.str();
}

// A pass's rows give the SAH of the tree it started from beside its own: here binned_sah bins=8's, which
// the config also runs.
TEST(HarnessRun, PassRowsRecordTheirSourcesSah) {
  const auto config = write_config(
      "run_pass", "[[builder]]\nname = \"reinsert\"\nsource = { name = \"binned_sah\", bins = 8 }\n");
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
  const auto rows = read_csv(temp_dir() / "run_pass.csv");
  std::map<std::string, std::string> binned_sah;  // scene -> sah_cost of binned_sah bins=8
  for (const auto& row : rows)
    if (row.at("builder") == "binned_sah" && row.at("builder_params").find("bins=8;") == 0)
      binned_sah[row.at("scene")] = row.at("sah_cost");
  ASSERT_EQ(binned_sah.size(), 2u);
  std::size_t passes = 0;
  for (const auto& row : rows) {
    if (row.at("builder") != "reinsert") {
      EXPECT_EQ(row.at("source_sah_cost"), "") << row.at("builder");
      continue;
    }
    ++passes;
    EXPECT_EQ(row.at("source_sah_cost"), binned_sah.at(row.at("scene")));
    EXPECT_LE(std::stod(row.at("sah_cost")), std::stod(row.at("source_sah_cost")));
  }
  EXPECT_EQ(passes, 16u);
}

// experiment.epo: our rows carry the tree's EPO cost and its blend with SAH; every row of ours the cost per
// ray from its counting pass (c_trav nodes + c_isect primitives); Embree's rows, whose tree is not in the
// common format and which have no counting pass, neither.
TEST(HarnessRun, EpoAndCostPerRayColumns) {
  for (const bool epo : {true, false}) {
    const std::string name = epo ? "run_epo" : "run_no_epo";
    const auto dir = temp_dir();
    const auto csv = dir / (name + ".csv");
    std::filesystem::remove(csv);
    const auto config = dir / (name + ".toml");
    std::ofstream(config) << "[experiment]\nname = \"" << name << "\"\noutput = \"" << csv.string()
                          << "\"\nscenes = [\"proc:soup:tris=2000\"]\nlayouts = [\"bvh2\", \"bvh4\"]\n"
                          << "reference = \"none\"\nepo = " << (epo ? "true" : "false") << "\n"
                          << "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
                          << "[[builder]]\nname = \"binned_sah\"\nc_trav = 1.5\n"
                          << "[[builder]]\nname = \"sbvh\"\n"
                          << "[[builder]]\nname = \"wide_binned_sah\"\narity = 4\n"
                          << "[[builder]]\nname = \"embree\"\n"
                          << "[[ray_set]]\nkind = \"primary\"\nwidth = 24\nheight = 24\n";
    std::ostringstream log;
    ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
    const auto rows = read_csv(csv);
    ASSERT_FALSE(rows.empty());
    std::size_t ours = 0;
    for (const auto& row : rows) {
      const std::string what = row.at("builder") + " " + row.at("layout");
      if (row.at("builder") == "embree") {
        EXPECT_EQ(row.at("epo_cost"), "") << what;
        EXPECT_EQ(row.at("sah_epo_cost"), "") << what;
        EXPECT_EQ(row.at("cost_per_ray"), "") << what;
        EXPECT_EQ(row.at("leaves_per_ray"), "") << what;
        continue;
      }
      ++ours;
      const double expected = std::stod(row.at("sah_c_trav")) * std::stod(row.at("nodes_per_ray")) +
                              std::stod(row.at("sah_c_isect")) * std::stod(row.at("prims_per_ray"));
      // Each count is printed to 3 decimals, and so is the cost.
      EXPECT_NEAR(std::stod(row.at("cost_per_ray")), expected, 0.002 * std::stod(row.at("sah_c_trav")))
          << what;
      // At least one leaf per ray that reaches a triangle.
      if (std::stod(row.at("prims_per_ray")) > 0.0) {
        EXPECT_GT(std::stod(row.at("leaves_per_ray")), 0.0) << what;
      }
      if (!epo) {
        EXPECT_EQ(row.at("epo_cost"), "") << what;
        continue;
      }
      const double e = std::stod(row.at("epo_cost")), sah = std::stod(row.at("sah_cost"));
      EXPECT_GT(e, 0.0) << what;
      EXPECT_NEAR(std::stod(row.at("sah_epo_cost")), 0.29 * sah + 0.71 * e, 2e-6) << what;
    }
    EXPECT_EQ(ours, 3u);
  }
}

TEST(HarnessRun, InterleavedAndBackToBackRepetitionsGiveTheSameCellsAndCounts) {
  // Interleaving changes only when each repetition runs: the same cells, each timed `trace` times, with
  // the same counts and reference checks, and (Embree's cells included) every structure alive until its
  // cells are written.
  const std::string embree = "[[builder]]\nname = \"embree\"\nquality = \"medium\"\n";
  std::map<std::string, std::map<std::string, std::string>> by_mode[2];
  for (int interleave = 0; interleave < 2; ++interleave) {
    const std::string name = interleave ? "run_interleaved" : "run_back_to_back";
    const auto config = write_config(name, embree);
    std::stringstream text;
    text << std::ifstream(config).rdbuf();
    std::string toml = text.str();
    const auto reps = toml.find("trace_warmup = 0\n");
    ASSERT_NE(reps, std::string::npos);
    toml.insert(reps, std::string("interleave = ") + (interleave ? "true" : "false") + "\n");
    std::ofstream(config) << toml;

    std::ostringstream log;
    ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
    EXPECT_EQ(log.str().find("trace repetition") != std::string::npos, interleave == 1) << log.str();
    EXPECT_EQ(log.str().find("build repetition 1 of") != std::string::npos, interleave == 1) << log.str();
    EXPECT_NE(log.str().find(" trees, 0 warm-up and "), std::string::npos) << log.str();
    for (const auto& row : read_csv(temp_dir() / (name + ".csv"))) {
      const std::string key = row.at("scene") + "|" + row.at("builder") + "|" + row.at("builder_params") +
                              "|" + row.at("layout") + "|" + row.at("threads") + "|" + row.at("ray_set");
      EXPECT_EQ(row.at("trace_reps"), "2");
      EXPECT_GT(std::stod(row.at("trace_mrays_min")), 0.0) << key;
      by_mode[interleave][key] = {{"nodes_per_ray", row.at("nodes_per_ray")},
                                  {"prims_per_ray", row.at("prims_per_ray")},
                                  {"mismatches", row.at("mismatches")},
                                  {"sah_cost", row.at("sah_cost")}};
    }
  }
  // 2 scenes x 2 thread counts x 2 ray sets x (2 binned runs x 2 layouts + Embree's layouts).
  EXPECT_GE(by_mode[0].size(), 2u * 2u * 2u * (4u + 1u));
  EXPECT_EQ(by_mode[0], by_mode[1]);
}

TEST(HarnessRun, ResumeAfterAnInterruptedRunCompletesOnlyTheMissingCells) {
  const auto config = write_config("run_resume", "");
  const auto csv = temp_dir() / "run_resume.csv";
  std::ostringstream log;
  // A run limited to one scene stands in for one interrupted after that scene's cells; a crash in the
  // middle of writing the next row leaves a partial last line.
  ASSERT_EQ(run_experiment({config, false, "proc:soup", std::nullopt}, log), 0);
  ASSERT_EQ(read_csv(csv).size(), 16u);
  std::ofstream(csv, std::ios::app) << "run_small-cut,abc123,AMD";
  EXPECT_EQ(read_csv(csv).size(), 16u) << "a partial last line is not a row";
  ASSERT_EQ(run_experiment({config, true, "", std::nullopt}, log), 0) << log.str();
  EXPECT_NE(log.str().find("removed a partial last row"), std::string::npos) << log.str();
  const auto rows = read_csv(csv);
  EXPECT_EQ(rows.size(), 32u);
  // The resumed run continues the first one: one run id, so the report shows every cell.
  for (const auto& r : rows) EXPECT_EQ(r.at("run_id"), rows.front().at("run_id"));
  std::ostringstream report;
  print_report({{csv}, ""}, report);
  EXPECT_NE(report.str().find("## proc:soup:tris=2000"), std::string::npos) << report.str();
  EXPECT_NE(report.str().find("## proc:sphere:tris=3000"), std::string::npos) << report.str();
  std::set<std::string> keys;
  for (const auto& r : rows)
    keys.insert(cell_key(r.at("scene"), r.at("builder"), r.at("builder_params"), r.at("layout"),
                         std::stoi(r.at("threads")), r.at("ray_set"), std::stoi(r.at("frame"))));
  EXPECT_EQ(keys.size(), 32u) << "a cell was run twice";
}

TEST(HarnessRun, InvalidTreesAreReportedNotTraced) {
  // A builder that drops a primitive: its cells get rows saying why, with no trace figures, and the run
  // exits 1 rather than tracing a broken tree.
  static const bool registered = [] {
    BuilderInfo broken = find_builder("binned_sah");
    broken.name = "broken_for_test";
    auto build = broken.build;
    broken.build = [build](const BuildInput& input, const ParamSet& p) {
      Bvh bvh = build(input, p);
      for (Node& n : bvh.nodes)
        if (n.is_leaf() && n.prim_count > 1) {
          --n.prim_count;
          break;
        }
      return bvh;
    };
    register_builder(broken);
    return true;
  }();
  ASSERT_TRUE(registered);
  const auto config = write_config("run_invalid", "[[builder]]\nname = \"broken_for_test\"\n");
  std::ostringstream log;
  EXPECT_EQ(run_experiment({config, false, "broken_for_test", std::nullopt}, log), 1);
  const auto rows = read_csv(temp_dir() / "run_invalid.csv");
  ASSERT_EQ(rows.size(), 16u);
  for (const auto& r : rows) {
    EXPECT_NE(r.at("notes").find("invalid tree, not traced"), std::string::npos) << r.at("notes");
    EXPECT_EQ(r.at("trace_mrays_median"), "");
  }
}

TEST(HarnessRun, MoreThreadsThanTheMachineHasAreSaid) {
  auto config = write_config("run_oversubscribed", "");
  std::string text;
  {
    std::ifstream in(config);
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  text.replace(text.find("threads = [1, 2]"), 16, "threads = [1, 100000]");
  std::ofstream(config) << text;
  std::ostringstream log;
  // --only matching nothing stops the run before any cell, after the warning.
  EXPECT_THROW(run_experiment({config, false, "no such cell", std::nullopt}, log), Error);
  EXPECT_NE(log.str().find("warning: threads = 100000 is more than the"), std::string::npos) << log.str();
}

TEST(HarnessRun, MissingRequiredSceneFailsBeforeAnyCell) {
  const auto dir = temp_dir();
  const auto path = dir / "missing_scene.toml", csv = dir / "missing_scene.csv";
  std::filesystem::remove(csv);
  std::ofstream(path)
      << "[experiment]\nname = \"m\"\noutput = \"" << csv.string() << "\"\n"
      << "scenes = [\"proc:soup:tris=500\", \"no_such_scene_anywhere\"]\n"
      << "[[builder]]\nname = \"binned_sah\"\n[[ray_set]]\nkind = \"primary\"\nwidth = 8\nheight = 8\n";
  std::ostringstream log;
  try {
    run_experiment({path, false, "", std::nullopt}, log);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_scene_anywhere"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(csv)) << "the CSV is not touched before the scenes are known to exist";
}

// Embree stops the process on a ray beyond its range: a camera that far out is an error naming the set,
// whether Embree is a builder of the config or the reference of our rows.
TEST(HarnessRun, RaysBeyondEmbreesRangeAreAnErrorNotAnAbort) {
  const auto dir = temp_dir();
  for (const auto& [reference, embree_builder] : {std::pair{"none", true}, std::pair{"embree", false}}) {
    SCOPED_TRACE(reference);
    const auto path = dir / "far_camera.toml", csv = dir / "far_camera.csv";
    std::filesystem::remove(csv);
    std::ofstream(path)
        << "[experiment]\nname = \"far\"\noutput = \"" << csv.string() << "\"\n"
        << "scenes = [\"proc:sphere:tris=300\"]\nreference = \"" << reference << "\"\n"
        << "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
        << "[[builder]]\nname = \"binned_sah\"\n"
        << (embree_builder ? "[[builder]]\nname = \"embree\"\n" : "")
        << "[[camera]]\nscene = \"proc:sphere:tris=300\"\neye = [0, 0, 1e19]\ntarget = [0, 0, 0]\n"
        << "[[ray_set]]\nkind = \"primary\"\nwidth = 4\nheight = 4\n";
    std::ostringstream log;
    const std::string e = test::error_of([&] { run_experiment({path, false, "", std::nullopt}, log); });
    EXPECT_NE(e.find("ray set 'primary'"), std::string::npos) << e;
    EXPECT_NE(e.find("ray 0 has an origin or direction component beyond 1.844e+18"), std::string::npos) << e;
  }
}

// A procedural sphere has no lights of its own: a shadow set with light_source = "scene" takes the
// config's [[lights]]. From a light in front of the sphere, on the camera's side, the lit half's rays are
// not occluded; from one at its centre every ray is, and the rows say that the scene encloses it.
TEST(HarnessRun, ConfigLightsAreTheScenesLightsForItsShadowSets) {
  const auto dir = temp_dir();
  auto run = [&](const std::string& name, const std::string& light) {
    const auto path = dir / (name + ".toml"), csv = dir / (name + ".csv");
    std::filesystem::remove(csv);
    std::ofstream(path)
        << "[experiment]\nname = \"" << name << "\"\noutput = \"" << csv.string() << "\"\n"
        << "scenes = [\"proc:sphere:tris=3000\"]\nreference = \"brute_force\"\n"
        << "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
        << "[[builder]]\nname = \"binned_sah\"\n"
        << "[[camera]]\nscene = \"proc:sphere:tris=3000\"\neye = [0, 0, 10]\ntarget = [0, 0, 0]\n"
        << "[[lights]]\nscene = \"proc:sphere:tris=3000\"\npositions = [" << light << "]\n"
        << "[[ray_set]]\nkind = \"shadow\"\nlight_source = \"scene\"\nwidth = 16\nheight = 16\n";
    std::ostringstream log;
    EXPECT_EQ(run_experiment({path, false, "", std::nullopt}, log), 0) << log.str();
    EXPECT_NE(log.str().find("lights (" + light.substr(1, light.size() - 2) + ") from the config"),
              std::string::npos)
        << log.str();
    const auto rows = read_csv(csv);
    EXPECT_EQ(rows.size(), 1u) << log.str();
    return rows.empty() ? CsvRow{} : rows[0];
  };
  const CsvRow front = run("light_front", "[0, 0, 5]");
  EXPECT_EQ(front.at("mismatches"), "0");
  EXPECT_LT(std::stod(front.at("hit_fraction")), 0.5);
  EXPECT_NE(front.at("notes").find("lights (0, 0, 5)"), std::string::npos) << front.at("notes");
  EXPECT_EQ(front.at("notes").find("enclosed"), std::string::npos) << front.at("notes");
  const CsvRow inside = run("light_inside", "[0, 0, 0]");
  EXPECT_EQ(inside.at("hit_fraction"), "1.0000");
  EXPECT_NE(inside.at("notes").find("scene light 1 of 1 enclosed"), std::string::npos) << inside.at("notes");
}

TEST(HarnessRun, ConfigCameraGivesThePrimaryViewAndSecondarySetsFollowIt) {
  // The same scene seen from a [[camera]] that faces it, and from one that faces away: every primary ray
  // then misses, and the shadow set, which starts at the primary hits, is skipped with the reason.
  const auto dir = temp_dir();
  auto run = [&](const std::string& name, const std::string& target, bool resume = false) {
    const auto path = dir / (name + ".toml"), csv = dir / (name + ".csv");
    if (!resume) std::filesystem::remove(csv);
    std::ofstream(path) << "[experiment]\nname = \"" << name << "\"\noutput = \"" << csv.string() << "\"\n"
                        << "scenes = [\"proc:sphere:tris=3000\"]\nreference = \"brute_force\"\n"
                        << "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
                        << "[[builder]]\nname = \"binned_sah\"\n"
                        << "[[camera]]\nscene = \"proc:sphere:tris=3000\"\neye = [0, 0, 10]\ntarget = "
                        << target << "\nfov = 20\n"
                        << "[[ray_set]]\nkind = \"primary\"\nwidth = 16\nheight = 16\n"
                        << "[[ray_set]]\nkind = \"shadow\"\nwidth = 16\nheight = 16\n";
    std::ostringstream log;
    EXPECT_EQ(run_experiment({path, resume, "", std::nullopt}, log), 0) << log.str();
    if (!resume) {
      EXPECT_NE(log.str().find("camera from the config: eye (0, 0, 10)"), std::string::npos) << log.str();
    }
    return std::make_pair(read_csv(csv), log.str());
  };
  const auto [facing, facing_log] = run("camera_facing", "[0, 0, 0]");
  ASSERT_EQ(facing.size(), 2u) << facing_log;
  // A 20-degree view of the sphere from 10 units: it fills much of the picture, and every ray starts at the
  // eye.
  EXPECT_GT(std::stod(facing[0].at("nodes_per_ray")), 1.0);
  EXPECT_EQ(facing[1].at("ray_set"), "shadow");
  EXPECT_GT(std::stoi(facing[1].at("ray_count")), 16 * 16 / 4);
  // Each row names the view its rays came from; the shadow row also the automatic lights inside the sphere.
  const std::string view = "camera eye (0, 0, 10) target (0, 0, 0) up (0, 1, 0) fov 20";
  EXPECT_EQ(facing[0].at("notes"), view);
  EXPECT_TRUE(facing[1].at("notes").starts_with(view + "; automatic light")) << facing[1].at("notes");
  EXPECT_NE(facing[1].at("notes").find("enclosed by the scene"), std::string::npos) << facing[1].at("notes");

  const auto [away, away_log] = run("camera_away", "[0, 0, 20]");
  ASSERT_EQ(away.size(), 1u) << away_log;
  EXPECT_EQ(away[0].at("ray_set"), "primary");
  EXPECT_NE(away_log.find("skipping ray set 'shadow'"), std::string::npos) << away_log;

  // Resume continues only a run through the view the config has now.
  const auto [same, same_log] = run("camera_facing", "[0, 0, 0]", true);
  EXPECT_EQ(same.size(), 2u) << same_log;
  EXPECT_NE(same_log.find("0 cells to run"), std::string::npos) << same_log;
  // Another view is another run: resuming it is refused, naming the cameras.
  try {
    run("camera_facing", "[0, 1, 0]", true);
    FAIL() << "a resume through another view must be refused";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("differs in: cameras"), std::string::npos) << e.what();
  }
}

TEST(HarnessRun, OnlyFiltersCells) {
  const auto config = write_config("run_only", "");
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "bvh2_packed|2|shadow", std::nullopt}, log), 0);
  const auto rows = read_csv(temp_dir() / "run_only.csv");
  ASSERT_EQ(rows.size(), 4u);  // 2 scenes x 2 builder runs
  for (const auto& r : rows) {
    EXPECT_EQ(r.at("layout"), "bvh2_packed");
    EXPECT_EQ(r.at("ray_set"), "shadow");
  }
  // A filter that matches nothing is refused before the output (or its lock) is created.
  const auto typo = write_config("run_only_typo", "");
  const std::string e = test::error_of([&] {
    run_experiment({typo, false, "no_such_cell", std::nullopt}, log);
  });
  EXPECT_NE(e.find("--only 'no_such_cell' matches no cell"), std::string::npos) << e;
  EXPECT_FALSE(std::filesystem::exists(temp_dir() / "run_only_typo.csv"));
  EXPECT_FALSE(std::filesystem::exists(temp_dir() / "run_only_typo.csv.lock"));
}

TEST(HarnessRun, ReportPrintsATablePerSceneAndThreadCount) {
  const auto config = write_config("run_report", "[[builder]]\nname = \"embree\"\nquality = \"medium\"\n");
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
  const auto csv = temp_dir() / "run_report.csv";
  for (const auto& row : read_csv(csv))
    if (row.at("builder") == "embree") {
      EXPECT_EQ(row.at("mismatches"), "0") << row.at("layout") << " " << row.at("ray_set");
    }
  std::ostringstream out;
  print_report({{csv}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("## proc:sphere:tris=3000 (3"), std::string::npos) << md;
  EXPECT_NE(md.find("2 threads"), std::string::npos);
  EXPECT_NE(md.find("| binned_sah [bins=8] |"), std::string::npos) << md;
  EXPECT_NE(md.find("| embree | embree_1 |"), std::string::npos) << md;
  EXPECT_NE(md.find("(1.00x)"), std::string::npos) << md;  // the anchor against itself
}

// Embree in its default and its robust mode: a row each per layout, cell names that --only tells apart,
// robust answers that agree with the watertight reference on a closed mesh, and a report that compares
// our exact layouts with the robust mode.
TEST(HarnessRun, EmbreeRobustModeIsARowOfItsOwnAndTheAnchorOfOurExactLayouts) {
  const auto config = write_config("run_robust", "[[builder]]\nname = \"embree\"\nrobust = [false, true]\n");
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
  const auto csv = temp_dir() / "run_robust.csv";
  std::map<std::string, std::size_t> embree_rows;  // builder_params|layout -> rows
  for (const auto& row : read_csv(csv)) {
    if (row.at("builder") != "embree") continue;
    ++embree_rows[row.at("builder_params") + "|" + row.at("layout")];
    EXPECT_EQ(row.at("isa").rfind("embree:", 0), 0u) << row.at("isa");
    // On the closed sphere a ray through an edge hits a triangle of either side at the same t, which is
    // no mismatch; on the soup's separate triangles a test may take an edge that another leaves.
    if (row.at("builder_params") == "quality=medium;robust=1" && row.at("scene").starts_with("proc:sphere")) {
      EXPECT_EQ(row.at("mismatches"), "0")
          << "robust mode is watertight: " << row.at("layout") << " " << row.at("ray_set");
    }
  }
  // 2 scenes x 2 thread counts x 2 ray sets per mode and Embree layout.
  EXPECT_EQ(embree_rows["quality=medium|embree_1"], 8u);
  EXPECT_EQ(embree_rows["quality=medium;robust=1|embree_1"], 8u);
  for (const auto& [key, rows] : embree_rows)
    EXPECT_TRUE(key.starts_with("quality=medium|") || key.starts_with("quality=medium;robust=1|")) << key;

  std::ostringstream out;
  print_report({{csv}, ""}, out);
  const std::string md = out.str();
  EXPECT_NE(md.find("| embree [robust=1] | embree_1 |"), std::string::npos) << md;
  EXPECT_NE(md.find(" | bvh2 \u2020 | "), std::string::npos) << md;
  EXPECT_NE(md.find(" | bvh2_packed \u2020 | "), std::string::npos) << md;

  // The robust cells alone, by their name.
  const auto only = write_config("run_robust_only", "[[builder]]\nname = \"embree\"\nrobust = true\n");
  std::ostringstream only_log;
  ASSERT_EQ(run_experiment({only, false, "|quality=medium;robust=1|embree_1|", std::nullopt}, only_log), 0)
      << only_log.str();
  const auto rows = read_csv(temp_dir() / "run_robust_only.csv");
  EXPECT_EQ(rows.size(), 8u);
  for (const auto& row : rows) EXPECT_EQ(row.at("builder_params"), "quality=medium;robust=1");
}

TEST(HarnessTrace, OutputMatchesBruteForceLineByLine) {
  const auto dir = temp_dir();
  const auto rays_path = dir / "rays.txt", out_path = dir / "hits.csv";
  std::ofstream(rays_path) << "# origin direction [tmin tmax]\n"
                           << "0 0 5 0 0 -1\n"
                           << "0 0 5, 0 0 1\n"             // away from the sphere
                           << "0.3 0.2 5 -0 0 -1 0 inf\n"  // -0 component
                           << "0 0 0 1 0 0 0 0.5\n"        // from the centre, stops short of the surface
                           << "\n";
  std::ostringstream log;
  run_trace_command({"proc:sphere:tris=2000", "binned_sah", "bvh2", rays_path, out_path}, log);
  const auto rays = read_rays(rays_path);
  const Scene scene = load_scene("proc:sphere:tris=2000");
  const auto rows = read_csv(out_path);
  ASSERT_EQ(rows.size(), 4u);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Hit ref = brute_force_closest(scene.triangles, rays[i]);
    EXPECT_EQ(rows[i].at("hit"), ref.found() ? "1" : "0") << i;
    if (ref.found()) {
      EXPECT_NEAR(std::stof(rows[i].at("t")), ref.t, 1e-5f * ref.t) << i;
    }
  }
  EXPECT_EQ(rows[0].at("hit"), "1");
  EXPECT_EQ(rows[1].at("hit"), "0");
  EXPECT_EQ(rows[3].at("hit"), "0");

  // --out - writes the same lines to standard output, and no file called "-".
  std::ostringstream captured;
  {
    // Restores std::cout's buffer however the call ends.
    const std::unique_ptr<std::streambuf, void (*)(std::streambuf*)> restore(
        std::cout.rdbuf(captured.rdbuf()), [](std::streambuf* saved) { std::cout.rdbuf(saved); });
    run_trace_command({"proc:sphere:tris=2000", "binned_sah", "bvh2", rays_path, "-"}, log);
  }
  std::ifstream written(out_path);
  const std::string file_text((std::istreambuf_iterator<char>(written)), std::istreambuf_iterator<char>());
  EXPECT_EQ(captured.str(), file_text);
  EXPECT_FALSE(std::filesystem::exists("-"));
}

TEST(HarnessTrace, UnknownBuildersAndMismatchedLayoutsAreErrorsNamingThem) {
  const auto dir = temp_dir();
  const auto rays_path = dir / "one_ray.txt", out_path = dir / "one_hit.csv";
  std::ofstream(rays_path) << "0 0 5 0 0 -1\n";
  std::ostringstream log;
  // {builder, layout, the text the error must name}
  const std::vector<std::array<std::string, 3>> cases = {
      {"no_such_builder", "bvh2", "no_such_builder"},
      {"binned_sah:bins=0", "bvh2", "bins"},
      {"embree:quality=best", "", "best"},
      {"embree:bins=8", "", "bins"},
      {"embree", "bvh2", "--layout 'bvh2'"},
      {"binned_sah", "embree_1", "--layout 'embree_1'"},
      {"binned_sah", "bvh3", "bvh3"},
  };
  for (const auto& [builder, layout, named] : cases) {
    SCOPED_TRACE(builder + " " + layout);
    const std::string what = test::error_of([&] {
      run_trace_command({"proc:sphere:tris=200", builder, layout, rays_path, out_path}, log);
    });
    EXPECT_NE(what.find(named), std::string::npos) << what;
  }
}

// A ray file of test::random_rays on `triangles` (hits, misses, bounded segments, +-0 components), written
// with 9 significant digits so that read_rays gives back the same floats.
std::vector<Ray> write_ray_file(const std::filesystem::path& path, const std::vector<Triangle>& triangles,
                                std::size_t count) {
  const auto rays = test::random_rays(triangles, count, 17);
  std::ofstream out(path);
  for (const Ray& r : rays)
    out << fmt::format("{:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g}\n", r.org.x, r.org.y, r.org.z,
                       r.dir.x, r.dir.y, r.dir.z, r.tmin, r.tmax);
  return rays;
}

// The first line of a trace output: "# builder=... layout=... isa=... query=...".
std::string first_line(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

// Relative t difference up to which a hit on the reference's primitive agrees with it.
constexpr float kTRoundingLimit = 1e-4f;

struct TraceCheck {
  std::size_t hits = 0, misses = 0, mismatches = 0;
  std::string first_mismatch;
};

// Compares a trace output line by line with brute force (watertight): hit flags for any hit; for closest
// hits the primitive and t (test::same_closest_hit) and that (u, v) are barycentrics.
TraceCheck check_trace_output(const std::filesystem::path& out_path, const std::vector<Ray>& rays,
                              const std::vector<Triangle>& tris, TraceQuery query) {
  TraceCheck c;
  const auto rows = read_csv(out_path);
  EXPECT_EQ(rows.size(), rays.size());
  for (std::size_t i = 0; i < std::min(rows.size(), rays.size()); ++i) {
    const CsvRow& row = rows[i];
    EXPECT_EQ(row.at("ray"), std::to_string(i));
    const bool hit = row.at("hit") == "1";
    hit ? ++c.hits : ++c.misses;
    ::testing::AssertionResult same = ::testing::AssertionSuccess();
    if (query == TraceQuery::kAny) {
      // Only the flag: the any-hit kernels report no primitive or distance.
      EXPECT_EQ(row.at("prim") + row.at("t") + row.at("u") + row.at("v"), "") << "ray " << i;
      if (hit != brute_force_any(tris, rays[i])) same = ::testing::AssertionFailure() << "occlusion differs";
    } else {
      Hit got;
      if (hit) {
        got.prim = static_cast<uint32_t>(std::stoul(row.at("prim")));
        got.t = std::stof(row.at("t"));
        const float u = std::stof(row.at("u")), v = std::stof(row.at("v"));
        EXPECT_TRUE(u >= -1e-4f && v >= -1e-4f && u + v <= 1.0f + 1e-4f)
            << "ray " << i << ": " << u << " " << v;
      } else {
        EXPECT_EQ(row.at("prim") + row.at("t"), "") << "ray " << i;
      }
      const Hit ref = brute_force_closest(tris, rays[i]);
      same = test::same_closest_hit(got, ref, tris, rays[i]);
      // The same primitive at a t within Möller-Trumbore's rounding of the watertight one (grazing rays
      // reach 1e-5 relative): Embree's default test, not a wrong answer.
      if (!same && got.found() && got.prim == ref.prim && std::abs(got.t - ref.t) <= kTRoundingLimit * ref.t)
        same = ::testing::AssertionSuccess();
    }
    if (!same && c.mismatches++ == 0) c.first_mismatch = "ray " + std::to_string(i) + ": " + same.message();
  }
  return c;
}

TEST(HarnessTrace, AnyHitMatchesBruteForceAndReportsOnlyTheFlag) {
  const auto dir = temp_dir();
  const std::string scene_spec = "proc:soup:tris=600";
  const Scene scene = load_scene(scene_spec);
  const auto rays_path = dir / "any_rays.txt", out_path = dir / "any_hits.csv";
  const auto rays = write_ray_file(rays_path, scene.triangles, 1500);
  for (const auto& [builder, layout] : std::vector<std::pair<std::string, std::string>>{
           {"binned_sah", "bvh2"}, {"binned_sah", "bvh2_packed"}, {"wide_binned_sah:arity=8", "bvh8"}}) {
    SCOPED_TRACE(builder + " " + layout);
    std::ostringstream log;
    run_trace_command({scene_spec, builder, layout, rays_path, out_path, TraceQuery::kAny}, log);
    EXPECT_NE(first_line(out_path).find("query=any"), std::string::npos) << first_line(out_path);
    const TraceCheck c = check_trace_output(out_path, rays, scene.triangles, TraceQuery::kAny);
    EXPECT_EQ(c.mismatches, 0u) << c.first_mismatch;
    EXPECT_GT(c.hits, rays.size() / 10);
    EXPECT_GT(c.misses, rays.size() / 10);
  }
}

// Every Embree layout this CPU runs, both queries and both modes, against brute force; one it cannot run
// is an error naming the layout. On a soup of separate triangles a ray through an edge hits whichever
// triangle's test takes the edge, and Embree's tests (Moeller-Trumbore, or Pluecker in robust mode) and
// our watertight one part on a few such rays (test_embree.cpp's kDefaultModeMismatchLimit); more would
// be a wrong answer.
TEST(HarnessTrace, EmbreeLayoutsMatchBruteForceOrAreRefusedByName) {
  const auto dir = temp_dir();
  const std::string scene_spec = "proc:soup:tris=600";
  const Scene scene = load_scene(scene_spec);
  const auto rays_path = dir / "embree_rays.txt", out_path = dir / "embree_hits.csv";
  const auto rays = write_ray_file(rays_path, scene.triangles, 1500);
  const EmbreeDevice device(1);
  std::size_t traced = 0;
  for (const bool robust : {false, true}) {
    for (const EmbreeLayout& layout : kEmbreeLayouts) {
      for (const TraceQuery query : {TraceQuery::kClosest, TraceQuery::kAny}) {
        SCOPED_TRACE(std::string(layout.name) + " " + std::string(to_string(query)) +
                     (robust ? " robust" : ""));
        const std::string builder = robust ? "embree:quality=high,robust=1" : "embree:quality=high";
        const TraceCommandOptions options{scene_spec, builder, layout.name, rays_path, out_path, query};
        std::ostringstream log;
        if (const auto why = embree_layout_unsupported(device, layout)) {
          const std::string what = test::error_of([&] { run_trace_command(options, log); });
          EXPECT_NE(what.find(std::string("--layout '") + layout.name + "'"), std::string::npos) << what;
          EXPECT_NE(what.find("packets"), std::string::npos) << what;
          continue;
        }
        run_trace_command(options, log);
        ++traced;
        const std::string named = std::string("# builder=embree:quality=high") + (robust ? ";robust=1" : "") +
                                  " layout=" + std::string(layout.name) +
                                  " isa=embree:" + embree_isa(device) +
                                  " query=" + std::string(to_string(query));
        EXPECT_EQ(first_line(out_path), named);
        EXPECT_NE(log.str().find(named.substr(2)), std::string::npos) << log.str();
        const TraceCheck c = check_trace_output(out_path, rays, scene.triangles, query);
        EXPECT_LE(static_cast<double>(c.mismatches), 0.001 * static_cast<double>(rays.size()))
            << c.first_mismatch;
        EXPECT_GT(c.hits, rays.size() / 10);
        EXPECT_GT(c.misses, rays.size() / 10);
      }
    }
  }
  EXPECT_GE(traced, 4u) << "embree_1 runs on every CPU, in both modes";
  // A ray beyond Embree's range would stop the process in its assertion: refused by name, not traced.
  // Named by its line: here the fourth, after a header and a comment.
  std::ofstream(rays_path) << "ox oy oz dx dy dz\n0 0 5 0 0 -1\n# far\n0 0 1e20 0 0 -1\n";
  const TraceCommandOptions far{scene_spec, "embree", "embree_1", rays_path, out_path, TraceQuery::kClosest};
  std::ostringstream log;
  const std::string what = test::error_of([&] { run_trace_command(far, log); });
  EXPECT_NE(what.find("embree_rays.txt:4: an origin or direction component beyond 1.844e+18"),
            std::string::npos)
      << what;
}

TEST(HarnessTrace, OutputNamesBuilderLayoutAndIsaAndKeepsItsColumns) {
  const auto dir = temp_dir();
  const auto rays_path = dir / "named_rays.txt", out_path = dir / "named_hits.csv";
  std::ofstream(rays_path) << "0 0 5 0 0 -1\n0 0 5 0 0 1\n";
  std::ostringstream log;
  run_trace_command({"proc:sphere:tris=200", "binned_sah:bins=8", "", rays_path, out_path}, log);
  const BuilderInfo& info = find_builder("binned_sah");
  const std::string params = resolve_params(info.name, info.params, {{"bins", "8"}}).to_string();
  const std::string named = "builder=binned_sah:" + params + " layout=bvh2 isa=scalar query=closest";
  EXPECT_EQ(first_line(out_path), "# " + named);
  EXPECT_NE(log.str().find(named), std::string::npos) << log.str();
  std::ifstream in(out_path);
  std::string line;
  std::getline(in, line);
  std::getline(in, line);
  EXPECT_EQ(line, "ray,hit,prim,t,u,v");
  // A SIMD layout names the ISA its kernels ran with, which isa=auto resolves.
  run_trace_command({"proc:sphere:tris=200", "wide_binned_sah:arity=4", "bvh4:tri=mtn,box=fma", rays_path,
                     out_path, TraceQuery::kAny},
                    log);
  const std::string isa(to_string(preferred_kernel_isa()));
  EXPECT_NE(first_line(out_path).find(" layout=bvh4:tri=mtn,box=fma isa=" + isa + " query=any"),
            std::string::npos)
      << first_line(out_path);
  EXPECT_EQ(parse_trace_query("any"), TraceQuery::kAny);
  EXPECT_NE(test::error_of([] { parse_trace_query("nearest"); }).find("--query 'nearest'"),
            std::string::npos);
}

TEST(HarnessTrace, RayFilesTakeHeadersCommentsAndPlusSigns) {
  const auto path = temp_dir() / "friendly_rays.txt";
  std::ofstream(path) << "ox oy oz dx dy dz tmin tmax\n"
                      << "+1 0 0 -1 0 0 0 inf  # towards the origin\n"
                      << "0, 0, 5, 0, 0, -1\n";
  const auto rays = read_rays(path);
  ASSERT_EQ(rays.size(), 2u);
  EXPECT_EQ(rays[0].org.x, 1.0f);
  EXPECT_EQ(rays[0].dir.x, -1.0f);
  EXPECT_EQ(rays[1].org.z, 5.0f);
  // A line of words after the first data line is an error, not a second header.
  std::ofstream(path) << "0 0 5 0 0 -1\nox oy oz dx dy dz\n";
  EXPECT_NE(test::error_of([&] { read_rays(path); }).find("friendly_rays.txt:2"), std::string::npos);
}

TEST(HarnessTrace, MalformedRayFilesNameTheLine) {
  const auto path = temp_dir() / "bad_rays.txt";
  std::ofstream(path) << "0 0 0 1 0 0\n0 0 zero 1 0 0\n";
  try {
    read_rays(path);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad_rays.txt:2: 'zero'"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "0 0 0 1 0\n";
  EXPECT_THROW(read_rays(path), Error);
  // Numbers beyond a float are numbers, and said to be out of range.
  std::ofstream(path) << "0 0 0 1e39 0 1\n";
  EXPECT_NE(test::error_of([&] { read_rays(path); }).find("'1e39' is outside the range of a float"),
            std::string::npos);
  std::ofstream(path) << "0 0 0 1e-50 0 1\n";
  EXPECT_NE(test::error_of([&] { read_rays(path); }).find("outside the range"), std::string::npos);
  // A NUL byte is shown, not a cut in the message.
  std::ofstream(path) << "0 0 0 1" << '\0' << "x 0 1\n";
  EXPECT_NE(test::error_of([&] { read_rays(path); }).find("'1\\x00x' is not a number"), std::string::npos);
  // A file of comments only, or a directory, has no rays.
  std::ofstream(path) << "# nothing here\n\n";
  EXPECT_NE(test::error_of([&] { read_rays(path); }).find("no rays"), std::string::npos);
  EXPECT_NE(test::error_of([&] { read_rays(temp_dir()); }).find("is a directory"), std::string::npos);
  std::ofstream(path) << "0 0 0 0 0 0\n";
  EXPECT_THROW(read_rays(path), Error);
  EXPECT_THROW(read_rays(temp_dir() / "missing.txt"), Error);
  // Rays the kernels do not answer for: NaN anywhere, an infinite origin or direction, a tmin below 0
  // (a hit behind the origin) or an infinite one, a tmax below tmin. tmax may be infinite.
  auto error_for = [&](const char* line) {
    std::ofstream(path) << "0 0 5 0 0 -1\n" << line << "\n";
    return test::error_of([&] { read_rays(path); });
  };
  EXPECT_NE(error_for("0 0 5 nan 0 -1").find("bad_rays.txt:2: 'nan' is not a number (NaN)"),
            std::string::npos);
  EXPECT_NE(error_for("0 0 5 0 0 -1 0 nan").find("'nan' is not a number (NaN)"), std::string::npos);
  EXPECT_NE(error_for("0 0 inf 0 0 -1").find("bad_rays.txt:2: the origin and the direction must be finite"),
            std::string::npos);
  EXPECT_NE(
      error_for("0 0 -3 0 0 -1 -10 10").find("bad_rays.txt:2: tmin = -10 must be finite and at least 0"),
      std::string::npos);
  EXPECT_NE(error_for("0 0 -3 0 0 -1 inf inf").find("tmin = inf must be finite"), std::string::npos);
  EXPECT_NE(error_for("0 0 5 0 0 -1 3 2").find("bad_rays.txt:2: tmax = 2 is below tmin = 3"),
            std::string::npos);
  EXPECT_NE(error_for("0 0 5 0 0 -1 0 -2").find("tmax = -2 is below tmin = 0"), std::string::npos);
  std::ofstream(path) << "0 0 5 0 0 -1 0 inf\n";
  EXPECT_EQ(read_rays(path).size(), 1u);
  // An empty comma-separated field would shift the numbers after it into other columns.
  EXPECT_NE(error_for("0,0,5,,0,-1,0").find("bad_rays.txt:2: field 4 is empty"), std::string::npos);
  EXPECT_NE(error_for(",0,0,5,0,-1,0").find("field 1 is empty"), std::string::npos);
  EXPECT_NE(error_for("0,0,5,0,-1,0,").find("field 7 is empty"), std::string::npos);
  std::ofstream(path) << "0 ,0, 5,\t0 , -1,0\n";
  EXPECT_EQ(read_rays(path).front().dir.y, -1.0f);
}

TEST(HarnessRun, BadConfigIsAnErrorNamingTheFile) {
  const auto path = temp_dir() / "broken.toml";
  std::ofstream(path) << "[experiment]\nname = \"x\"\nthreads = [1]\nscenes = "
                         "[\"proc:soup\"]\n[[builder]]\nname = \"binned\"\n"
                      << "[[ray_set]]\nkind = \"primary\"\n";
  try {
    std::ostringstream log;
    run_experiment({path, false, "", std::nullopt}, log);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("broken.toml:6"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown builder 'binned'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sahbench
