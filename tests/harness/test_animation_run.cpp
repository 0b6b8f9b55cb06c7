// Animation experiments: the [animation] table (errors named by key and line), Embree's refit scene
// (EmbreeScene::update_vertices moves the geometry it traces), and a small animation run end to end:
// rows per frame for refit and rebuild, no mismatches, static scenes skipped, resume.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <string_view>

#include "core/error.h"
#include "harness/config/config.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "harness/run/animation_runner.h"
#include "harness/run/csv.h"
#include "harness/run/runner.h"
#include "scenes/wave.h"
#include "tests/support/config_error.h"
#include "tests/support/hit_check.h"
#include "tests/support/process_temp_dir.h"
#include "tests/support/test_scenes.h"
#include "traversal/brute_force.h"

namespace sahbench {
namespace {

// The config errors of this suite come from "anim.toml".
void expect_error(std::string_view text, int line, std::initializer_list<std::string_view> parts) {
  test::expect_config_error(text, "anim.toml", line, parts);
}

// A valid static config of 9 lines; tests append from line 10 on.
const std::string kBase = test::minimal_config("a", "proc:wave:tris=1k");

ExperimentConfig parse_with(std::string_view extra) {
  return parse_experiment_config(kBase + std::string(extra), "anim.toml");
}

TEST(HarnessAnimationConfig, FramesTimesAndDefaults) {
  EXPECT_FALSE(parse_with("").animation.has_value());
  EXPECT_EQ(parse_with("[animation]\n").animation->frames, 10u);
  const auto frames = parse_with("[animation]\nframes = 4\n").animation;
  EXPECT_EQ(frames->frames, 4u);
  EXPECT_TRUE(frames->times.empty());
  const auto times = parse_with("[animation]\ntimes = [0, 0.5, 1.25]\n").animation;
  EXPECT_EQ(times->times, (std::vector<double>{0.0, 0.5, 1.25}));
  EXPECT_EQ(times->frames, 3u);
  // Embree's refit exists only where there are frames to refit to.
  const auto refit =
      parse_with("[animation]\n[[builder]]\nname = \"embree\"\nquality = [\"refit\", \"medium\"]\n");
  ASSERT_EQ(refit.builders.size(), 3u);
  EXPECT_EQ(refit.builders[1].label(), "embree[quality=refit]");
}

TEST(HarnessAnimationConfig, ErrorsNameKeyAndLine) {
  expect_error(kBase + "[animation]\nframes = 0\n", 11, {"animation.frames = 0", "[1, 10000]"});
  expect_error(kBase + "[animation]\nframes = \"ten\"\n", 11, {"animation.frames must be an integer"});
  expect_error(kBase + "[animation]\nframes = 20000\n", 11, {"animation.frames = 20000"});
  expect_error(kBase + "[animation]\ntimes = [0.5, 0.2]\n", 11,
               {"animation.times must increase", "0.2", "0.5"});
  expect_error(kBase + "[animation]\ntimes = [0, \"1\"]\n", 11,
               {"animation.times must be a list of numbers"});
  expect_error(kBase + "[animation]\ntimes = []\n", 11, {"animation.times must not be an empty list"});
  expect_error(kBase + "[animation]\ntimes = 1.5\n", 11, {"animation.times must be a list"});
  expect_error(kBase + "[animation]\nframes = 3\ntimes = [0.0]\n", 12, {"exclude each other"});
  expect_error(kBase + "[animation]\nfps = 30\n", 11, {"unknown key 'fps' in [animation]", "frames, times"});
  expect_error("animation = 3\n" + kBase, 1, {"[animation] must be a table"});
  expect_error(kBase + "[[builder]]\nname = \"embree\"\nquality = \"refit\"\n", 12,
               {"'refit'", "[animation]", "low, medium, high"});
}

// ---------------------------------------------------------------------------------------------------
// Embree's refit scene

TEST(HarnessAnimationEmbree, RefitSceneTracesTheMovedTriangles) {
  const WaveParams wave{2000, 4, 0.2, 4};
  const std::vector<Triangle> first = generate_wave(wave, 0.0);
  const std::vector<Triangle> moved = generate_wave(wave, 0.35);
  const auto rays = test::random_rays(moved, 400, 5);
  EmbreeDevice device(1);
  for (EmbreeQuality quality : {EmbreeQuality::kRefit, EmbreeQuality::kMedium}) {
    SCOPED_TRACE(to_string(quality));
    EmbreeScene scene(device, first, quality, {.robust = true});
    EXPECT_TRUE(scene.options().dynamic || quality != EmbreeQuality::kRefit)
        << "refit implies a dynamic scene";
    EXPECT_GE(scene.update_vertices(moved), 0.0);
    std::vector<Hit> hits(rays.size());
    embree_intersect1(scene, rays, hits);
    std::size_t mismatches = 0, found = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const Hit ref = brute_force_closest(moved, rays[i]);
      found += ref.found();
      mismatches += !test::same_closest_hit(hits[i], ref, moved, rays[i]);
    }
    EXPECT_GT(found, rays.size() / 10) << "rays must hit the sheet for the check to mean anything";
    EXPECT_EQ(mismatches, 0u);
  }
  EmbreeScene scene(device, first, EmbreeQuality::kRefit);
  EXPECT_THROW(scene.update_vertices(std::span<const Triangle>(moved).first(10)), Error);
}

// ---------------------------------------------------------------------------------------------------
// A run

std::filesystem::path temp_dir() {
  return test::process_temp_dir("animation_run");
}

std::filesystem::path write_config(const std::string& name) {
  const auto dir = temp_dir();
  const auto csv = dir / (name + ".csv");
  std::filesystem::remove(csv);
  const auto path = dir / (name + ".toml");
  std::ofstream(path)
      << "[experiment]\nname = \"" << name << "\"\noutput = \"" << csv.string() << "\"\n"
      << "threads = [1, 2]\nscenes = [\"proc:wave:tris=1500,amplitude=0.2\", \"proc:sphere:tris=500\"]\n"
      << "layouts = [\"bvh2\", \"bvh2_packed\"]\nreference = \"brute_force\"\n"
      << "[repetitions]\nbuild = 2\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
      << "[animation]\nframes = 3\n"
      << "[[builder]]\nname = \"binned_sah\"\n"
      << "[[builder]]\nname = \"embree\"\nquality = [\"refit\", \"medium\"]\nrobust = [false, true]\n"
      << "[[ray_set]]\nkind = \"primary\"\nwidth = 20\nheight = 20\n"
      << "[[ray_set]]\nkind = \"shadow\"\nwidth = 20\nheight = 20\n";
  return path;
}

TEST(HarnessAnimationRun, RowsPerFrameForRefitAndRebuildWithoutMismatches) {
  const auto config = write_config("animation_small");
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
  EXPECT_NE(log.str().find("skipping scene proc:sphere:tris=500: static"), std::string::npos) << log.str();
  const auto csv = temp_dir() / "animation_small.csv";
  const auto rows = read_csv(csv);

  std::map<std::string, std::size_t> per_builder;
  std::set<std::string> frames, keys, embree_params;
  std::map<std::string, std::string> sah;  // builder|frame|threads -> SAH cost
  for (const auto& row : rows) {
    const std::string what = row.at("builder") + " " + row.at("builder_params") + " " + row.at("layout") +
                             " frame " + row.at("frame") + " " + row.at("ray_set");
    EXPECT_EQ(row.at("scene"), "proc:wave:tris=1500,amplitude=0.2");
    EXPECT_EQ(row.at("mismatches"), "0") << what;
    EXPECT_EQ(row.at("reference"), "brute_force");
    EXPECT_GT(std::stod(row.at("trace_mrays_median")), 0.0) << what;
    EXPECT_GE(std::stod(row.at("build_ms_median")), 0.0) << what;
    ++per_builder[row.at("builder")];
    if (row.at("builder") == "embree") embree_params.insert(row.at("builder_params"));
    frames.insert(row.at("frame") + "@" + row.at("frame_time"));
    EXPECT_TRUE(
        keys.insert(cell_key(row.at("scene"), row.at("builder"), row.at("builder_params"), row.at("layout"),
                             std::stoi(row.at("threads")), row.at("ray_set"), std::stoi(row.at("frame"))))
            .second)
        << "one row per cell: " << what;
    if (row.at("builder") != "embree") {
      EXPECT_NE(row.at("sah_cost"), "") << what;
      sah[row.at("builder") + "|" + row.at("frame") + "|" + row.at("threads")] = row.at("sah_cost");
    }
  }
  // 3 frames x 2 thread counts x 2 layouts x 2 ray sets, for the rebuild and for the refit.
  EXPECT_EQ(per_builder["binned_sah"], 24u);
  EXPECT_EQ(per_builder["refit(binned_sah)"], 24u);
  // 2 qualities x 2 modes x as many Embree layouts as the CPU has; the refit in robust mode too.
  EXPECT_EQ(per_builder["embree"] % 48, 0u);
  EXPECT_GE(per_builder["embree"], 48u);
  EXPECT_EQ(embree_params, (std::set<std::string>{"quality=refit", "quality=refit;robust=1", "quality=medium",
                                                  "quality=medium;robust=1"}));
  EXPECT_EQ(frames, (std::set<std::string>{"0@0", "1@0.5", "2@1"}));
  // On the first frame the refitted tree is the built one; later its cost departs from a fresh build's.
  EXPECT_EQ(sah["refit(binned_sah)|0|1"], sah["binned_sah|0|1"]);
  EXPECT_NE(sah["refit(binned_sah)|1|1"], sah["binned_sah|1|1"]);
  // The same trees whatever the thread count.
  EXPECT_EQ(sah["refit(binned_sah)|1|1"], sah["refit(binned_sah)|1|2"]);
  EXPECT_NE(log.str().find("summary: proc:wave"), std::string::npos) << log.str();

  // Resume: every cell is done.
  std::ostringstream again;
  ASSERT_EQ(run_experiment({config, true, "", std::nullopt}, again), 0);
  EXPECT_EQ(read_csv(csv).size(), rows.size());
}

// A [[camera]] gives every frame its view: the rows name it, before the refit note of the refit rows.
TEST(HarnessAnimationRun, ConfigCameraViewsEveryFrame) {
  const auto dir = temp_dir();
  const auto config = dir / "animation_camera.toml", csv = dir / "animation_camera.csv";
  std::filesystem::remove(csv);
  std::ofstream(config)
      << "[experiment]\nname = \"animation_camera\"\noutput = \"" << csv.string() << "\"\n"
      << "scenes = [\"proc:wave:tris=1500\"]\nreference = \"brute_force\"\n"
      << "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
      << "[animation]\nframes = 2\n[[builder]]\nname = \"binned_sah\"\n"
      << "[[camera]]\nscene = \"proc:wave:tris=1500\"\neye = [0, 5, 0]\ntarget = [0, 10, 0]\n"
      << "up = [0, 0, 1]\n[[ray_set]]\nkind = \"primary\"\nwidth = 8\nheight = 8\n";
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
  const auto rows = read_csv(csv);
  ASSERT_EQ(rows.size(), 4u) << log.str();  // 2 frames x (rebuild, refit)
  const std::string view = "camera eye (0, 5, 0) target (0, 10, 0) up (0, 0, 1) fov 45";
  for (const auto& row : rows) {
    // Looking up, away from the wave: every primary ray misses, on every frame.
    EXPECT_EQ(std::stod(row.at("nodes_per_ray")), 0.0) << row.at("builder") << " frame " << row.at("frame");
    if (row.at("builder") == "refit(binned_sah)")
      EXPECT_EQ(row.at("notes"), view + "; tree and layout of frame 0 refitted");
    else
      EXPECT_EQ(row.at("notes"), view);
  }
}

// Passes and their chains refit like any tree; a tree with repeated references (a pass over sbvh) is refitted
// too, and its rows and the log say that its leaves lose the build's clipping.
TEST(HarnessAnimationRun, ComposedTreesRefitAndTreesWithSplitsSaySo) {
  const auto dir = temp_dir();
  const auto config = dir / "animation_passes.toml", csv = dir / "animation_passes.csv";
  std::filesystem::remove(csv);
  std::ofstream(config)
      << "[experiment]\nname = \"animation_passes\"\noutput = \"" << csv.string() << "\"\n"
      << "scenes = [\"proc:wave:tris=1500,amplitude=0.2\"]\nreference = \"brute_force\"\n"
      << "layouts = [\"bvh2\", \"bvh8\"]\n"
      << "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
      << "[animation]\nframes = 2\n"
      << "[[builder]]\nname = \"wide_collapse\"\nsource = { name = \"treelet\", source = \"reinsert\" }\n"
      << "[[builder]]\nname = \"reinsert\"\nsource = { name = \"sbvh\", alpha = 0, max_leaf = 1 }\n"
      << "[[ray_set]]\nkind = \"primary\"\nwidth = 16\nheight = 16\n"
      << "[[ray_set]]\nkind = \"shadow\"\nwidth = 16\nheight = 16\n";
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
  const auto rows = read_csv(csv);
  ASSERT_EQ(rows.size(), 16u) << log.str();  // 2 builders x (rebuild, refit) x 2 frames x 2 ray sets
  const std::string splits = "references repeat (spatial splits)";
  for (const auto& row : rows) {
    const std::string what = row.at("builder") + " frame " + row.at("frame") + " " + row.at("ray_set");
    EXPECT_EQ(row.at("mismatches"), "0") << what;
    const bool over_sbvh = row.at("builder").find("reinsert") != std::string::npos;
    if (over_sbvh) {
      EXPECT_GT(std::stod(row.at("refs_per_prim")), 1.0) << what;
    }
    const bool noted = row.at("notes").find(splits) != std::string::npos;
    EXPECT_EQ(noted, over_sbvh && row.at("builder").starts_with("refit(")) << what;
  }
  EXPECT_NE(log.str().find("refit(reinsert[source=sbvh,source.alpha=0,source.max_leaf=1]): " + splits),
            std::string::npos)
      << log.str();
}

// The refit cells trace their layouts refitted in place (bvh2: the common format's copy; bvh8: wide
// nodes and triangle blocks), timed into layout_refit_ms; the rebuild cells compile theirs (layout_ms).
TEST(HarnessAnimationRun, RefitCellsRefitTheirLayoutsInPlace) {
  const auto dir = temp_dir();
  const auto csv = dir / "animation_layout_refit.csv";
  std::filesystem::remove(csv);
  const auto config = dir / "animation_layout_refit.toml";
  std::ofstream(config) << "[experiment]\nname = \"layout_refit\"\noutput = \"" << csv.string() << "\"\n"
                        << "scenes = [\"proc:wave:tris=1500,amplitude=0.3\"]\n"
                        << "layouts = [\"bvh2\", \"bvh8\"]\nreference = \"brute_force\"\n"
                        << "[repetitions]\nbuild = 3\nbuild_warmup = 1\ntrace = 1\ntrace_warmup = 0\n"
                        << "[animation]\nframes = 4\n"
                        << "[[builder]]\nname = \"binned_sah\"\n"
                        << "[[builder]]\nname = \"wide_binned_sah\"\narity = 8\n"
                        << "[[ray_set]]\nkind = \"primary\"\nwidth = 24\nheight = 24\n"
                        << "[[ray_set]]\nkind = \"shadow\"\nwidth = 16\nheight = 16\n";
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();

  std::set<std::string> refit_cells, rebuild_cells;      // layout|frame|ray set
  std::map<std::string, double> rebuild_sah, refit_sah;  // layout|frame
  for (const auto& row : read_csv(csv)) {
    const std::string cell = row.at("layout") + "|" + row.at("frame") + "|" + row.at("ray_set");
    const std::string what = row.at("builder") + " " + cell;
    EXPECT_EQ(row.at("mismatches"), "0") << what;
    EXPECT_EQ(row.at("reference"), "brute_force") << what;
    const bool refit = row.at("builder").starts_with("refit(");
    if (refit) {
      refit_cells.insert(cell);
      ASSERT_NE(row.at("layout_refit_ms"), "") << what;
      EXPECT_GT(std::stod(row.at("layout_refit_ms")), 0.0) << what;
      EXPECT_EQ(row.at("layout_ms"), "") << what << ": compiled once, on the first frame";
      refit_sah[row.at("layout") + "|" + row.at("frame")] = std::stod(row.at("sah_cost"));
    } else {
      rebuild_cells.insert(cell);
      EXPECT_NE(row.at("layout_ms"), "") << what;
      EXPECT_EQ(row.at("layout_refit_ms"), "") << what;
      rebuild_sah[row.at("layout") + "|" + row.at("frame")] = std::stod(row.at("sah_cost"));
    }
  }
  // Every frame, both layouts, both ray sets: refits and rebuilds alike.
  std::set<std::string> expected;
  for (const char* layout : {"bvh2", "bvh8"})
    for (int frame = 0; frame < 4; ++frame)
      for (const char* set : {"primary", "shadow"})
        expected.insert(std::string(layout) + "|" + std::to_string(frame) + "|" + set);
  EXPECT_EQ(refit_cells, expected);
  EXPECT_EQ(rebuild_cells, expected);
  // The wave moves: the refitted trees drift from fresh builds, so stale layout boxes would be wrong boxes.
  for (const char* layout : {"bvh2", "bvh8"}) {
    EXPECT_EQ(refit_sah[std::string(layout) + "|0"], rebuild_sah[std::string(layout) + "|0"]) << layout;
    EXPECT_NE(refit_sah[std::string(layout) + "|2"], rebuild_sah[std::string(layout) + "|2"]) << layout;
  }
  // The summary adds the layout's refit to the tree's, and the compile to the build.
  EXPECT_NE(log.str().find("refit = tree refit + layout refit"), std::string::npos) << log.str();
  EXPECT_NE(log.str().find(", bvh2: refit "), std::string::npos) << log.str();
  EXPECT_NE(log.str().find(", bvh8: refit "), std::string::npos) << log.str();
}

TEST(HarnessAnimationRun, OnlyFiltersByBuilderAndFrame) {
  const auto config = write_config("animation_only");
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "refit(binned_sah)|", std::nullopt}, log), 0) << log.str();
  const auto rows = read_csv(temp_dir() / "animation_only.csv");
  EXPECT_EQ(rows.size(), 24u);
  for (const auto& row : rows) EXPECT_EQ(row.at("builder"), "refit(binned_sah)");
  // A filter that matches nothing is refused before the output is created.
  const auto typo = write_config("animation_only_typo");
  try {
    run_experiment({typo, false, "no_such_cell", std::nullopt}, log);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--only 'no_such_cell' matches no cell"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(temp_dir() / "animation_only_typo.csv"));
}

}  // namespace
}  // namespace sahbench
