#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <set>
#include <sstream>
#include <string>
#include <string_view>

#include "builders/registry.h"
#include "core/error.h"
#include "harness/config/config.h"
#include "harness/embree/embree_bvh_builder.h"
#include "harness/run/tree_file_builder.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "tests/support/config_error.h"
#include "tests/support/error_of.h"
#include "tests/support/prerequisites.h"

namespace sahbench {
namespace {

// The config errors of this suite come from "test.toml".
void expect_error(std::string_view text, int line, std::initializer_list<std::string_view> parts) {
  test::expect_config_error(text, "test.toml", line, parts);
}

// A minimal valid config (lines 1-9); tests append [[builder]] or [[ray_set]] tables from line 10 on.
const std::string kBase = test::minimal_config("t", "proc:soup:tris=1k");

ExperimentConfig parse_with(std::string_view extra) {
  return parse_experiment_config(kBase + std::string(extra), "test.toml");
}

std::vector<std::string> labels(const ExperimentConfig& config) {
  std::vector<std::string> out;
  for (const auto& run : config.builders) out.push_back(run.label());
  return out;
}

TEST(HarnessConfigParse, FullConfigRoundTrip) {
  const auto config = parse_experiment_config(R"([experiment]
name = "full-1"
output = "out/full.csv"
seed = 42
threads = [1, 4]
scenes = ["proc:soup:tris=100k", "scenes/a.obj"]
optional_scenes = ["crytek_sponza"]
layouts = ["bvh2", "bvh2_packed:tri=mt"]
reference = "auto"
brute_force_max_triangles = 5000

[repetitions]
build = 7
build_warmup = 0
trace = 3
trace_warmup = 2
interleave = false

[[builder]]
name = "binned_sah"
bins = [8, 16]
max_leaf = 4

[[builder]]
name = "sweep_sah"

[[builder]]
name = "embree"
quality = "high"

[[ray_set]]
kind = "primary"
width = 640
height = 480

[[ray_set]]
name = "sun"
kind = "shadow"
lights = 2
count = 1000

[[ray_set]]
kind = "shadow"
light_source = "scene"

[[ray_set]]
kind = "diffuse"
width = 64
height = 32

[[ray_set]]
kind = "ao"
ao_radius = 0.25

[[ray_set]]
kind = "random"
count = 99
)",
                                              "full.toml");
  ExperimentConfig expected;
  expected.path = "full.toml";
  expected.name = "full-1";
  expected.output = "out/full.csv";
  expected.seed = 42;
  expected.threads = {1, 4};
  expected.scenes = {"proc:soup:tris=100k", "scenes/a.obj"};
  expected.optional_scenes = {"crytek_sponza"};
  expected.layouts = {parse_layout_spec("bvh2"), parse_layout_spec("bvh2_packed:tri=mt")};
  expected.reference = ReferencePolicy::kAuto;
  expected.brute_force_max_triangles = 5000;
  expected.reps = {7, 0, 3, 2, false};
  expected.builders = {{"binned_sah", {{"bins", "8"}, {"max_leaf", "4"}}},
                       {"binned_sah", {{"bins", "16"}, {"max_leaf", "4"}}},
                       {"sweep_sah", {}},
                       {"embree", {{"quality", "high"}}}};
  RaySetConfig primary{.name = "primary", .kind = RayKind::kPrimary, .width = 640, .height = 480};
  RaySetConfig sun{.name = "sun", .kind = RayKind::kShadow, .count = 1000, .lights = 2};
  RaySetConfig scene_lights{.name = "shadow", .kind = RayKind::kShadow, .light_source = "scene"};
  RaySetConfig diffuse{.name = "diffuse", .kind = RayKind::kDiffuse, .width = 64, .height = 32};
  RaySetConfig ao{.name = "ao", .kind = RayKind::kAmbientOcclusion, .ao_radius = 0.25f};
  RaySetConfig random{.name = "random", .kind = RayKind::kRandom, .count = 99};
  expected.ray_sets = {primary, sun, scene_lights, diffuse, ao, random};
  EXPECT_EQ(config, expected);
  EXPECT_EQ(labels(config),
            (std::vector<std::string>{"binned_sah[bins=8,max_leaf=4]", "binned_sah[bins=16,max_leaf=4]",
                                      "sweep_sah", "embree[quality=high]"}));
}

// A run built in code reaches no runner unresolved: resolve() sets what the runners read.
TEST(HarnessConfigParse, UnresolvedBuilderRunsAreRefused) {
  BuilderRun ours{"binned_sah", {{"bins", "8"}}};
  EXPECT_THROW(require_resolved(ours), Error);
  resolve(ours);
  EXPECT_NO_THROW(require_resolved(ours));
  EXPECT_EQ(ours.values.get_uint("bins"), 8u);
  BuilderRun embree = parse_builder_run("embree_high");
  EXPECT_THROW(require_resolved(embree), Error);  // it would build at the default quality
  resolve(embree);
  EXPECT_NO_THROW(require_resolved(embree));
  EXPECT_EQ(embree.quality, EmbreeQuality::kHigh);
}

TEST(HarnessConfigParse, ReferencePolicies) {
  const std::pair<std::string, ReferencePolicy> cases[] = {{"auto", ReferencePolicy::kAuto},
                                                           {"embree", ReferencePolicy::kEmbree},
                                                           {"brute_force", ReferencePolicy::kBruteForce},
                                                           {"none", ReferencePolicy::kNone}};
  for (const auto& [text, policy] : cases) {
    const std::string toml = "[experiment]\nname = \"r\"\nscenes = [\"s\"]\nreference = \"" + text +
                             "\"\n[[builder]]\nname = \"sweep_sah\"\n[[ray_set]]\nkind = \"primary\"\n";
    const auto config = parse_experiment_config(toml, "r.toml");
    EXPECT_EQ(config.reference, policy) << text;
    EXPECT_EQ(to_string(config.reference), text);
  }
}

// The example at the top of config.h is the schema's documentation: it must stay a valid config.
TEST(HarnessConfigParse, HeaderExampleIsValid) {
  std::ifstream in(std::filesystem::path(SAHBENCH_SOURCE_DIR) / "harness" / "config" / "config.h");
  ASSERT_TRUE(in) << "cannot read harness/config/config.h";
  std::string line, toml;
  bool inside = false;
  while (std::getline(in, line)) {
    if (line.find("A complete example") != std::string::npos) {
      inside = true;
      continue;
    }
    if (!inside) continue;
    if (line.rfind("// Keys by ray-set kind", 0) == 0) break;
    ASSERT_EQ(line.rfind("//", 0), 0u) << line;
    toml += (line.size() > 5 ? line.substr(5) : "") + "\n";
  }
  const auto config = parse_experiment_config(toml, "config.h example");
  EXPECT_EQ(config.name, "default");
  EXPECT_EQ(
      labels(config),
      (std::vector<std::string>{
          "binned_sah[bins=8,max_leaf=8]", "binned_sah[bins=16,max_leaf=8]", "binned_sah[bins=32,max_leaf=8]",
          "reinsert[iterations=4,source=treelet,source.source=binned_sah,source.source.max_leaf=4]",
          "embree[quality=medium]", "embree[quality=high]"}));
  EXPECT_EQ(config.ray_sets.size(), 4u);
  EXPECT_EQ(config.threads, (std::vector<int>{1, 2}));
  ASSERT_EQ(config.cameras.size(), 1u);
  EXPECT_EQ(config.cameras[0].scene, "crytek_sponza");
  ASSERT_EQ(config.lights.size(), 1u);
  EXPECT_EQ(config.lights[0].positions.size(), 2u);
}

TEST(HarnessConfigDefaults, OptionalKeysMissing) {
  const auto config = parse_experiment_config(kBase, "min.toml");
  EXPECT_EQ(config.path, "min.toml");
  EXPECT_EQ(config.name, "t");
  EXPECT_EQ(config.output, "results/t.csv");
  EXPECT_EQ(config.seed, 1u);
  EXPECT_EQ(config.threads, std::vector<int>{1});
  EXPECT_EQ(config.scenes, std::vector<std::string>{"proc:soup:tris=1k"});
  EXPECT_TRUE(config.optional_scenes.empty());
  EXPECT_EQ(config.layouts, std::vector<LayoutSpec>{parse_layout_spec("bvh2")});
  EXPECT_EQ(config.reps, Repetitions{});
  EXPECT_EQ(config.reps, (Repetitions{5, 1, 5, 1, true}));
  EXPECT_EQ(config.reference, ReferencePolicy::kAuto);
  EXPECT_EQ(config.brute_force_max_triangles, 20000u);
  ASSERT_EQ(config.builders.size(), 1u);
  EXPECT_EQ(config.builders[0], (BuilderRun{"binned_sah", {}}));
  EXPECT_EQ(config.builders[0].label(), "binned_sah");
  ASSERT_EQ(config.ray_sets.size(), 1u);
  EXPECT_EQ(config.ray_sets[0], (RaySetConfig{.name = "primary", .kind = RayKind::kPrimary}));
  EXPECT_EQ(config.ray_sets[0].width, 512u);
  EXPECT_EQ(config.ray_sets[0].height, 512u);
}

TEST(HarnessConfigDefaults, RaySetsPerKind) {
  const auto config = parse_with(R"(
[[ray_set]]
kind = "shadow"
[[ray_set]]
kind = "diffuse"
[[ray_set]]
kind = "ao"
[[ray_set]]
kind = "random"
)");
  ASSERT_EQ(config.ray_sets.size(), 5u);
  const auto& shadow = config.ray_sets[1];
  EXPECT_EQ(shadow.name, "shadow");
  EXPECT_EQ(shadow.kind, RayKind::kShadow);
  EXPECT_EQ(shadow.count, 0u);
  EXPECT_EQ(shadow.lights, 4u);
  EXPECT_EQ(shadow.light_source, "auto");
  EXPECT_EQ(config.ray_sets[2].name, "diffuse");
  EXPECT_EQ(config.ray_sets[3].name, "ao");
  EXPECT_EQ(config.ray_sets[3].kind, RayKind::kAmbientOcclusion);
  EXPECT_FLOAT_EQ(config.ray_sets[3].ao_radius, 0.05f);
  EXPECT_EQ(config.ray_sets[4].name, "random");
  EXPECT_EQ(config.ray_sets[4].count, kDefaultRandomRays);
}

TEST(HarnessConfigDefaults, OnlyOptionalScenesAndSingleThreadCount) {
  const auto config = parse_experiment_config(R"([experiment]
name = "o"
threads = 8
optional_scenes = ["crytek_sponza"]
[[builder]]
name = "sweep_sah"
[[ray_set]]
kind = "random"
)",
                                              "o.toml");
  EXPECT_TRUE(config.scenes.empty());
  EXPECT_EQ(config.optional_scenes, std::vector<std::string>{"crytek_sponza"});
  EXPECT_EQ(config.threads, std::vector<int>{8});
}

TEST(HarnessConfigSweep, CartesianProductLastKeyFastest) {
  const auto config = parse_with(R"(
[[builder]]
name = "binned_sah"
bins = [8, 16]
max_leaf = [4, 8]
)");
  ASSERT_EQ(config.builders.size(), 5u);  // the base's plain binned_sah first
  EXPECT_EQ(labels(config),
            (std::vector<std::string>{"binned_sah", "binned_sah[bins=8,max_leaf=4]",
                                      "binned_sah[bins=8,max_leaf=8]", "binned_sah[bins=16,max_leaf=4]",
                                      "binned_sah[bins=16,max_leaf=8]"}));
  EXPECT_EQ(config.builders[3].params, (ParamOverrides{{"bins", "16"}, {"max_leaf", "4"}}));
}

// Keys vary in the order they are written, not alphabetically.
TEST(HarnessConfigSweep, FileOrderOfKeysAndTables) {
  const auto config = parse_with(R"(
[[builder]]
name = "sweep_sah"
max_leaf = [2, 3]
c_trav = 0.5
min_leaf = [1, 2]

[[builder]]
name = "binned_sah"
bins = 4
)");
  EXPECT_EQ(labels(config),
            (std::vector<std::string>{"binned_sah", "sweep_sah[max_leaf=2,c_trav=0.5,min_leaf=1]",
                                      "sweep_sah[max_leaf=2,c_trav=0.5,min_leaf=2]",
                                      "sweep_sah[max_leaf=3,c_trav=0.5,min_leaf=1]",
                                      "sweep_sah[max_leaf=3,c_trav=0.5,min_leaf=2]", "binned_sah[bins=4]"}));
}

TEST(HarnessConfigSweep, TooManyRunsIsAnError) {
  // 11 x 11 x 11 x 11 = 14641 runs > kMaxSweepRuns.
  expect_error(kBase + R"(
[[builder]]
name = "binned_sah"
bins = [4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14]
max_leaf = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]
min_leaf = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]
c_trav = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]
)",
               11, {"binned_sah", "10000", "bins: 11"});
}

TEST(HarnessConfigSweep, DuplicateRunsAreAnError) {
  // Setting a parameter to its default measures the same as the base's plain binned_sah.
  const auto& bins = find_builder("binned_sah").params;
  const auto spec =
      std::find_if(bins.begin(), bins.end(), [](const ParamSpec& p) { return p.name == "bins"; });
  ASSERT_NE(spec, bins.end());
  const std::string default_bins = std::to_string(static_cast<int>(spec->default_value));
  expect_error(kBase + "\n[[builder]]\nname = \"binned_sah\"\nbins = [8, " + default_bins + "]\n", 11,
               {"binned_sah[bins=" + default_bins + "]", "'binned_sah' (line 5)"});
  expect_error(kBase + R"(
[[builder]]
name = "sweep_sah"
max_leaf = [4, 4.0]
)",
               11, {"sweep_sah[max_leaf=4]", "line 11"});
}

TEST(HarnessConfigValues, BooleansFloatsAndStrings) {
  const auto config = parse_with(R"(
[[builder]]
name = "binned_sah"
adaptive_bins = [true, false]
c_trav = 0.1
c_isect = 2.0
bins = 32
max_leaf = 1e1
)");
  ASSERT_EQ(config.builders.size(), 3u);
  EXPECT_EQ(
      config.builders[1].params,
      (ParamOverrides{
          {"adaptive_bins", "1"}, {"c_trav", "0.1"}, {"c_isect", "2"}, {"bins", "32"}, {"max_leaf", "10"}}));
  EXPECT_EQ(config.builders[2].params[0], (std::pair<std::string, std::string>{"adaptive_bins", "0"}));
  const auto tiny = parse_with("[[builder]]\nname = \"sweep_sah\"\nc_trav = 1.25e-7\n");
  EXPECT_EQ(tiny.builders[1].label(), "sweep_sah[c_trav=1.25e-07]");
}

TEST(HarnessConfigValues, BadValuesNameKeyAndLine) {
  expect_error(kBase + R"(
[[builder]]
name = "binned_sah"
bins = [8,
        2]
)",
               14, {"bins", "'2'", "outside [4, 256]"});
  expect_error(kBase + "[[builder]]\nname = \"binned_sah\"\nmax_leaf = 2.5\n", 12,
               {"max_leaf", "2.5", "not an integer"});
  expect_error(kBase + "[[builder]]\nname = \"binned_sah\"\nbins = \"many\"\n", 12,
               {"bins", "many", "takes a number, not the string"});
  expect_error(kBase + "[[builder]]\nname = \"binned_sah\"\nbins = []\n", 12, {"bins", "empty list"});
  expect_error(kBase + "[[builder]]\nname = \"binned_sah\"\nbins = [[8]]\n", 12, {"bins", "nest"});
  expect_error(kBase + "[[builder]]\nname = \"binned_sah\"\nbins = 1979-05-27\n", 12, {"bins", "a date"});
}

TEST(HarnessConfigValues, ParameterCombinationsAreCheckedWhenLoading) {
  // Each value is in range, but together they cannot build: caught at load, not when the cell runs.
  expect_error(kBase + "[[builder]]\nname = \"binned_sah\"\nmin_leaf = 8\nmax_leaf = 4\n", 10,
               {"max_leaf = 4", "below min_leaf = 8"});
}

// Lines 1-7, with a layout for wide trees; tests append from line 8 on.
const std::string kWideBase =
    "[experiment]\nname = \"t\"\nscenes = [\"proc:soup:tris=1k\"]\nlayouts = [\"bvh2\", \"bvh8\"]\n\n"
    "[[ray_set]]\nkind = \"primary\"\n";

TEST(HarnessConfigSource, TablesInlineTablesAndTheCommandLineSpellOneChain) {
  const auto config = parse_experiment_config(kWideBase + R"(
[[builder]]
name = "wide_collapse"
source = { name = "reinsert", iterations = [1, 2], source = { name = "binned_sah", max_leaf = 4 } }

[[builder]]
name = "treelet"
[builder.source]
name = "reinsert"
iterations = 3
source = "sweep_sah"
)",
                                              "test.toml");
  ASSERT_EQ(config.builders.size(), 3u);
  EXPECT_EQ(config.builders[0].params, (ParamOverrides{{"source", "reinsert"},
                                                       {"source.iterations", "1"},
                                                       {"source.source", "binned_sah"},
                                                       {"source.source.max_leaf", "4"}}));
  EXPECT_EQ(config.builders[1].params[1], (std::pair<std::string, std::string>{"source.iterations", "2"}));
  BuilderRun cli = parse_builder_run(
      "wide_collapse:source=reinsert,source.iterations=1,source.source=binned_sah,source.source.max_leaf=4");
  resolve(cli);
  EXPECT_EQ(cli.params_text(), config.builders[0].params_text());
  EXPECT_EQ(cli.arity, 8u);
  EXPECT_NE(cli.params_text().find(";source=reinsert(source=binned_sah(bins=32;adaptive_bins=1;min_leaf=1;"
                                   "max_leaf=4;c_trav=1;c_isect=1;size_split=1;sah_block=1);iterations=1;"),
            std::string::npos)
      << cli.params_text();
  const SourceSpec& reinsert = config.builders[2].values.get_source("source");
  EXPECT_EQ(reinsert.params->get_uint("iterations"), 3u);
  EXPECT_EQ(reinsert.params->get_source("source").name(), "sweep_sah");

  // A name alone: the source's defaults, or for wide_collapse's three shared sources its own parameters,
  // written as before sources nested.
  const auto plain =
      parse_experiment_config(kWideBase +
                                  "[[builder]]\nname = \"wide_collapse\"\nsource = { name = \"sweep_sah\" }\n"
                                  "[[builder]]\nname = \"binned_sah\"\n",
                              "test.toml");
  EXPECT_EQ(plain.builders[0].params, (ParamOverrides{{"source", "sweep_sah"}}));
  EXPECT_TRUE(plain.builders[0].values.get_source("source").shared());
  EXPECT_NE(plain.builders[0].params_text().find(";source=sweep_sah;"), std::string::npos);
}

TEST(HarnessConfigSource, NumbersAreNumbersAndBooleansOnlySwitch) {
  auto ploc = [](const std::string& extra) {
    return kWideBase +
           "[[builder]]\nname = \"wide_collapse\"\nsource = \"ploc\"\n[[builder]]\nname = "
           "\"ploc\"\n" +
           extra;
  };
  // Lines: 8 and 11 [[builder]], 12 name, 13 the extra.
  expect_error(ploc("radius = \"16\"\n"), 13,
               {"ploc: parameter 'radius' takes a number, not the string \"16\""});
  expect_error(ploc("radius = true\n"), 13, {"ploc: parameter 'radius' takes a number, not true"});
  expect_error(ploc("radius = [8, \"16\"]\n"), 13, {"not the string \"16\""});
  // A path or a name is a string: `path = 5` is no file called "5".
  register_tree_file_builder();  // as sahbench does at startup (a repeated call is a no-op)
  expect_error(kWideBase + "[[builder]]\nname = \"file\"\npath = 5\n", 10,
               {"file: parameter 'path' takes a file path in quotes, not the number 5"});
  expect_error(kWideBase + "[[builder]]\nname = \"wide_collapse\"\nmethod = 2\n", 10,
               {"wide_collapse: parameter 'method' takes a name in quotes, not the number 2"});
  // A 0/1 switch takes a boolean, and names stay strings.
  const auto ok = parse_experiment_config(kWideBase +
                                              "[[builder]]\nname = \"binned_sah\"\nadaptive_bins = "
                                              "false\n[[builder]]\nname = \"wide_collapse\"\n",
                                          "test.toml");
  EXPECT_NE(ok.builders[0].params_text().find("adaptive_bins=0"), std::string::npos);
}

TEST(HarnessConfigSource, BadSourcesNameKeyAndLine) {
  auto wide = [](const std::string& extra) {
    return kWideBase + "[[builder]]\nname = \"wide_collapse\"\n" + extra;
  };
  // Lines: 8 [[builder]], 9 name, 10 on the extra.
  expect_error(wide("source = { name = \"reinsert\", iteratons = 2 }\n"), 10,
               {"tree source 'source'", "unknown parameter 'iteratons'", "iterations"});
  expect_error(wide("[builder.source]\nname = \"binned\"\n"), 11, {"'source'", "unknown builder 'binned'"});
  expect_error(wide("[builder.source]\niterations = 2\n"), 10, {"tree source 'source' has no name"});
  expect_error(wide("[builder.source]\nname = \"wide_binned_sah\"\n"), 11, {"8-wide", "binary tree"});
  expect_error(wide("[builder.source]\nname = \"wide_binned_sah\"\narity = [2, 4]\n"), 8,
               {"source.arity=4", "4-wide"});
  expect_error(wide("bins = { name = \"binned_sah\" }\n"), 10, {"'bins'", "not a table"});
  expect_error(wide("[builder.source]\nname = \"reinsert\"\nsource = { name = \"binned_sah\", bins = 2 }\n"),
               12, {"tree source 'source.source'", "'bins' = '2'", "outside [4, 256]"});
  expect_error(wide("[builder.source]\nname = \"reinsert\"\nsource.name = \"treelet\"\nsource.size = 3\n"),
               13, {"unknown parameter 'size'", "treelet_size"});
  // Checked together where the values are single, at the source's name; each run of a sweep at the table.
  expect_error(wide("[builder.source]\nname = \"binned_sah\"\nmin_leaf = 8\nmax_leaf = 4\n"), 11,
               {"below min_leaf = 8"});
  expect_error(wide("[builder.source]\nname = \"binned_sah\"\nmin_leaf = [1, 8]\nmax_leaf = 4\n"), 8,
               {"builder run", "below min_leaf = 8"});
  // wide_collapse's shared parameters mean nothing to a source with parameters of its own.
  expect_error(wide("bins = 16\nsource = \"treelet\"\n"), 8,
               {"bins applies only to the collapse's own build of a source named alone (binned_sah, "
                "sbvh)"});
}

TEST(HarnessConfigEmbree, QualitySweepAndDefault) {
  const auto config = parse_with(R"(
[[builder]]
name = "embree"
quality = ["low", "high"]

[[builder]]
name = "sweep_sah"

[[builder]]
name = "embree"
)");
  EXPECT_EQ(labels(config),
            (std::vector<std::string>{"binned_sah", "embree[quality=low]", "embree[quality=high]",
                                      "sweep_sah", "embree[quality=medium]"}))
      << "a plain embree is its default quality, medium";
}

TEST(HarnessConfigEmbree, DefaultQualityDuplicatesExplicitMedium) {
  expect_error(
      kBase + "[[builder]]\nname = \"embree\"\nquality = \"medium\"\n\n[[builder]]\nname = \"embree\"\n", 14,
      {"embree[quality=medium]", "line 10"});
}

TEST(HarnessConfigEmbree, OnlyKnownQualities) {
  expect_error(kBase + "[[builder]]\nname = \"embree\"\nquality = [\"high\", \"refit\"]\n", 12,
               {"refit", "low, medium, high"});
  expect_error(kBase + "[[builder]]\nname = \"embree\"\n\nbins = 8\n", 13,
               {"embree", "unknown parameter 'bins'", "quality"});
}

// Embree's robust mode is a row of its own; its default mode keeps the builder_params text it always had,
// so that the cells of older runs and of the CI baseline keep their names.
TEST(HarnessConfigEmbree, RobustModeIsARowOfItsOwn) {
  const auto config = parse_with(R"(
[[builder]]
name = "embree"
robust = [false, true]

[[builder]]
name = "embree"
robust = true
quality = "high"
)");
  EXPECT_EQ(labels(config),
            (std::vector<std::string>{"binned_sah", "embree[quality=medium]", "embree[quality=medium,robust]",
                                      "embree[quality=high,robust]"}));
  std::vector<std::string> texts;
  for (const auto& run : config.builders)
    if (run.is_embree()) texts.push_back(run.params_text());
  EXPECT_EQ(texts,
            (std::vector<std::string>{"quality=medium", "quality=medium;robust=1", "quality=high;robust=1"}))
      << "quality first, whatever the file's order; robust only when on";
  ASSERT_EQ(config.builders.size(), 4u);
  EXPECT_FALSE(config.builders[1].robust);
  EXPECT_FALSE(config.builders[1].embree_options().robust);
  EXPECT_TRUE(config.builders[2].robust);
  EXPECT_TRUE(config.builders[2].embree_options().robust);
  EXPECT_EQ(config.builders[2].quality, EmbreeQuality::kMedium);
  EXPECT_EQ(config.builders[3].quality, EmbreeQuality::kHigh);
  EXPECT_TRUE(config.builders[3].robust);

  // robust = false is Embree's default mode: the same run as a plain embree, with the same text.
  const auto off = parse_with("[[builder]]\nname = \"embree\"\nrobust = false\n");
  ASSERT_EQ(off.builders.size(), 2u);
  EXPECT_EQ(off.builders[1].params_text(), "quality=medium");
  EXPECT_EQ(off.builders[1].label(), "embree[quality=medium]");
  EXPECT_FALSE(off.builders[1].robust);
  expect_error(kBase + "[[builder]]\nname = \"embree\"\nrobust = false\n\n[[builder]]\nname = \"embree\"\n",
               14, {"embree[quality=medium]", "same parameter values", "line 10"});
}

TEST(HarnessConfigEmbree, RobustTakesOnlyTrueOrFalse) {
  expect_error(kBase + "[[builder]]\nname = \"embree\"\nrobust = \"yes\"\n", 12,
               {"embree: robust = 'yes'", "true, false"});
  expect_error(kBase + "[[builder]]\nname = \"embree\"\nrobust = 2\n", 12, {"robust = '2'", "true, false"});
  expect_error(kBase + "[[builder]]\nname = \"embree\"\nrobust = [true,\n  \"maybe\"]\n", 13,
               {"robust = 'maybe'"});
  expect_error(kBase + "[[builder]]\nname = \"embree\"\nrobust = []\n", 12, {"robust", "empty list"});
  expect_error(kBase + "[[builder]]\nname = \"embree\"\nrobustness = true\n", 12,
               {"unknown parameter 'robustness'", "quality, robust"});
}

TEST(HarnessConfigEmbree, CommandLineSpellsRobustModeAsTheConfig) {
  const std::pair<std::string, std::string> cases[] = {
      {"embree:robust=1", "quality=medium;robust=1"},
      {"embree:quality=high,robust=true", "quality=high;robust=1"},
      {"embree:robust=1,quality=low", "quality=low;robust=1"},
      {"embree:robust=0", "quality=medium"},
      {"embree:robust=false,quality=medium", "quality=medium"},
      {"embree_medium", "quality=medium"},
  };
  for (const auto& [text, params] : cases) {
    BuilderRun run = parse_builder_run(text);
    EXPECT_EQ(run.params_text(), params) << text;
    resolve(run);
    EXPECT_NO_THROW(require_resolved(run)) << text;
    EXPECT_EQ(run.robust, params.ends_with("robust=1")) << text;
  }
  // Robust but not resolved: the runner would build Embree's default mode.
  BuilderRun unresolved = parse_builder_run("embree:robust=1");
  EXPECT_THROW(require_resolved(unresolved), Error);
  EXPECT_EQ(unresolved.label(), "embree[quality=medium,robust]");

  for (const auto& [text, part] : {std::pair<std::string, std::string>{"embree:robust=yes", "robust = 'yes'"},
                                   {"embree:robust", "not of the form key=value"},
                                   {"embree_high:robust=1", "takes no parameters"},
                                   {"embree:fast=1", "unknown parameter 'fast' (known: quality, robust)"}}) {
    const std::string message = test::error_of([&] { parse_builder_run(text); });
    EXPECT_NE(message.find(part), std::string::npos) << text << ": " << message;
  }
}

TEST(HarnessConfigErrors, TomlSyntax) {
  expect_error("[experiment]\nname = \"x\"\nthreads = [1,\n", 3, {"TOML syntax error"});
  expect_error("[experiment]\nname = \"x\"\nname = \"y\"\n", 3, {"TOML syntax error", "name"});
}

TEST(HarnessConfigErrors, UnknownTablesAndKeys) {
  expect_error(kBase + "\n[repetition]\nbuild = 2\n", 11,
               {"unknown table [repetition]", "experiment, repetitions, builder, ray_set"});
  expect_error(kBase + "[[rayset]]\nkind = \"primary\"\n", 10, {"unknown table [[rayset]]"});
  expect_error(kBase + "[repetitions]\nbuild = 2\nwarmup = 1\n", 12,
               {"unknown key 'warmup' in [repetitions]", "build, build_warmup, trace, trace_warmup"});
  expect_error(R"([experiment]
name = "t"
thread = 2
scenes = ["s"]
)",
               3, {"unknown key 'thread' in [experiment]", "threads", "brute_force_max_triangles"});
  expect_error("top = 1\n" + kBase, 1, {"unknown key 'top'"});
  expect_error(kBase + "[[ray_set]]\nkind = \"primary\"\nname = \"p2\"\nlights = 3\n", 13,
               {"unknown key 'lights' in [[ray_set]] of kind primary", "name, kind, width, height"});
  expect_error(kBase + "[[ray_set]]\nkind = \"random\"\nwidth = 3\n", 12,
               {"unknown key 'width' in [[ray_set]] of kind random"});
  expect_error(kBase + "[[ray_set]]\nkind = \"shadow\"\nlight_source = \"scene\"\nlights = 2\n", 13,
               {"lights", "light_source = \"auto\""});
  expect_error(kBase + "[[ray_set]]\nkind = \"beam\"\n", 11, {"ray_set.kind", "beam", "primary | shadow"});
}

TEST(HarnessConfigErrors, WrongTypes) {
  const auto experiment = [](const std::string& line) {
    return "[experiment]\nname = \"t\"\nscenes = [\"s\"]\n" + line +
           "\n[[builder]]\nname = \"binned_sah\"\n"
           "[[ray_set]]\nkind = \"primary\"\n";
  };
  expect_error(experiment("threads = \"2\""), 4,
               {"threads must be an integer or a list of integers", "a string"});
  expect_error(experiment("threads = [1, 2.5]"), 4,
               {"threads must be an integer or a list of integers", "a float"});
  expect_error(experiment("seed = 1.5"), 4, {"experiment.seed must be an integer", "a float"});
  expect_error(experiment("seed = -1"), 4, {"experiment.seed = -1"});
  expect_error(experiment("output = 3"), 4, {"experiment.output must be a string"});
  expect_error(experiment("layouts = \"bvh2\""), 4,
               {"experiment.layouts must be a list of strings", "a string"});
  expect_error(experiment("optional_scenes = [\"a\", 2]"), 4, {"optional_scenes", "an integer"});
  expect_error(experiment("reference = \"reference\""), 4,
               {"experiment.reference", "auto | embree | brute_force | none"});
  expect_error(experiment("reference = \"none\"\nbrute_force_max_triangles = 10"), 5,
               {"brute_force_max_triangles", "reference = \"auto\""});
  expect_error("experiment = 1\n", 1, {"[experiment] must be a table", "an integer"});
  expect_error("builder = 3\n[experiment]\nname = \"t\"\nscenes = [\"s\"]\n", 1,
               {"[[builder]]", "an integer"});
  expect_error(kBase + "[[ray_set]]\nkind = \"ao\"\nao_radius = \"far\"\n", 12,
               {"ao_radius must be a number", "a string"});
  expect_error(kBase + "[[ray_set]]\nkind = \"ao\"\nao_radius = 0\n", 12, {"ao_radius = 0", "positive"});
  expect_error(kBase + "[[ray_set]]\nkind = \"random\"\ncount = 0\n", 12, {"ray_set.count = 0"});
  expect_error(kBase + "[[ray_set]]\nkind = \"diffuse\"\nwidth = 100000\n", 12,
               {"ray_set.width = 100000", "16384"});
  // Counts that would ask for gigabytes of rays, or minutes of light set-up, are refused where read.
  expect_error(kBase + "[[ray_set]]\nkind = \"random\"\ncount = 4000000000\n", 12,
               {"ray_set.count = 4000000000", "268435456"});
  expect_error(kBase + "[[ray_set]]\nkind = \"shadow\"\nlights = 100000000\n", 12,
               {"ray_set.lights = 100000000", "65536"});
}

// A listed layout that no builder's trees fit would give no row: refused at its line, as a builder
// whose trees no layout traces is.
TEST(HarnessConfigErrors, LayoutThatNoBuilderFits) {
  const auto config = [](const std::string& layouts, const std::string& builder) {
    return "[experiment]\nname = \"t\"\nscenes = [\"s\"]\nlayouts = [" + layouts + "]\n\n[[builder]]\n" +
           builder + "\n\n[[builder]]\nname = \"embree\"\n\n[[ray_set]]\nkind = \"primary\"\n";
  };
  expect_error(config("\"bvh2\",\n  \"bvh8:tri=mt\"", "name = \"binned_sah\""), 5,
               {"experiment.layouts: \"bvh8:tri=mt\" traces 8-wide trees", "no [[builder]]",
                "wide_collapse with arity = 8"});
  expect_error(config("\"bvh2_packed\", \"bvh8\"", "name = \"wide_collapse\"\narity = 8"), 4,
               {"\"bvh2_packed\" traces 2-wide trees", "a binary builder"});
  // Embree's builders alone: no layout of ours traces anything, listed or not.
  EXPECT_NO_THROW(parse_experiment_config(
      "[experiment]\nname = \"t\"\nscenes = [\"s\"]\nlayouts = [\"bvh8\"]\n[[builder]]\nname = "
      "\"embree\"\n[[ray_set]]\nkind = \"primary\"\n",
      "test.toml"));
  // Each layout with a builder of its arity, the combinations that do not fit left out as before.
  EXPECT_NO_THROW(parse_experiment_config(
      config("\"bvh2\", \"bvh8\"", "name = \"binned_sah\"\n[[builder]]\nname = \"wide_collapse\""),
      "test.toml"));
}

TEST(HarnessConfigErrors, EmptyListsAndDuplicates) {
  const auto experiment = [](const std::string& lines) {
    return "[experiment]\nname = \"t\"\n" + lines +
           "\n[[builder]]\nname = \"binned_sah\"\n[[ray_set]]\nkind = \"primary\"\n";
  };
  expect_error(experiment("scenes = []"), 3, {"experiment.scenes must not be an empty list"});
  expect_error(experiment("scenes = [\"s\"]\nthreads = []"), 4,
               {"experiment.threads must not be an empty list"});
  expect_error(experiment("scenes = [\"s\"]\nlayouts = []"), 4,
               {"experiment.layouts must not be an empty list"});
  expect_error(experiment("scenes = [\"s\",\n  \"s\"]"), 4, {"experiment.scenes lists \"s\" twice"});
  expect_error(experiment("scenes = [\"s\"]\noptional_scenes = [\"s\"]"), 4,
               {"\"s\"", "both scenes and optional_scenes"});
  expect_error(experiment("scenes = [\"s\"]\nthreads = [2, 2]"), 4, {"threads lists 2 twice"});
  // One scene under two spellings, and a procedural spec with a typo even where the scene is optional.
  expect_error(
      experiment("scenes = [\"proc:terrain:tris=10k\"]\noptional_scenes = [\"proc:terrain:tris=10000\"]"), 4,
      {"\"proc:terrain:tris=10k\" and \"proc:terrain:tris=10000\" are the same scene"});
  expect_error(experiment("scenes = [\"s\"]\noptional_scenes = [\"proc:terrian:tris=1k\"]"), 4,
               {"experiment.optional_scenes", "terrian"});
  expect_error(experiment("scenes = [\"proc:terrain:tris=0\"]"), 3, {"experiment.scenes", "tris"});
  expect_error(experiment("scenes = [\"\"]"), 3, {"must not be empty"});
}

TEST(HarnessConfigErrors, DuplicateRaySetNames) {
  expect_error(kBase + "\n[[ray_set]]\nkind = \"primary\"\nwidth = 64\n", 11,
               {"ray set name 'primary' is used twice"});
  expect_error(
      kBase + "[[ray_set]]\nname = \"a\"\nkind = \"ao\"\n[[ray_set]]\nkind = \"shadow\"\nname = \"a\"\n", 15,
      {"ray set name 'a' is used twice"});
}

TEST(HarnessConfigErrors, CountsBelowMinimum) {
  const auto experiment = [](const std::string& line) {
    return "[experiment]\nname = \"t\"\nscenes = [\"s\"]\n" + line +
           "\n[[builder]]\nname = \"binned_sah\"\n"
           "[[ray_set]]\nkind = \"primary\"\n";
  };
  expect_error(experiment("threads = 0"), 4, {"experiment.threads = 0 must be at least 1"});
  expect_error(experiment("threads = [1, -2]"), 4, {"experiment.threads = -2"});
  expect_error(kBase + "[repetitions]\nbuild = 0\n", 11, {"repetitions.build = 0 must be at least 1"});
  expect_error(kBase + "[repetitions]\ntrace = 0\n", 11, {"repetitions.trace = 0"});
  expect_error(kBase + "[repetitions]\ntrace_warmup = -1\n", 11, {"repetitions.trace_warmup = -1"});
  expect_error(kBase + "[repetitions]\ninterleave = 1\n", 11,
               {"repetitions.interleave must be true or false"});
  const auto ok = parse_with("[repetitions]\nbuild_warmup = 0\ntrace_warmup = 0\n");
  EXPECT_EQ(ok.reps, (Repetitions{5, 0, 5, 0}));
}

// experiment.epo turns on the EPO cost of every tree (core/epo.h); off unless set, and only a boolean.
TEST(HarnessConfigErrors, EpoIsABooleanOffByDefault) {
  EXPECT_FALSE(parse_with("").epo);
  const auto experiment = [](const std::string& line) {
    return "[experiment]\nname = \"t\"\nscenes = [\"s\"]\n" + line +
           "\n[[builder]]\nname = \"binned_sah\"\n[[ray_set]]\nkind = \"primary\"\n";
  };
  EXPECT_TRUE(parse_experiment_config(experiment("epo = true"), "t.toml").epo);
  EXPECT_FALSE(parse_experiment_config(experiment("epo = false"), "t.toml").epo);
  expect_error(experiment("epo = \"yes\""), 4, {"experiment.epo must be true or false, not a string"});
  expect_error(experiment("epo = 1"), 4, {"experiment.epo must be true or false, not an integer"});
  expect_error(experiment("epos = true"), 4, {"epos"});
}

TEST(HarnessConfigErrors, ExperimentNameAndRequiredTables) {
  expect_error("[experiment]\nscenes = [\"s\"]\n", 1, {"[experiment] has no name"});
  expect_error("[experiment]\nname = \"my run\"\nscenes = [\"s\"]\n", 2,
               {"experiment.name = \"my run\"", "letters, digits, '-' and '_'"});
  expect_error("[[builder]]\nname = \"binned_sah\"\n", 1, {"missing [experiment] table"});
  expect_error("[experiment]\nname = \"t\"\n\n[[builder]]\nname = \"binned_sah\"\n", 1, {"names no scene"});
  expect_error("[experiment]\nname = \"t\"\nscenes = [\"s\"]\n[[ray_set]]\nkind = \"primary\"\n", 1,
               {"no [[builder]]", "at least one builder"});
  expect_error("[experiment]\nname = \"t\"\nscenes = [\"s\"]\n[[builder]]\nname = \"binned_sah\"\n", 1,
               {"no [[ray_set]]", "at least one ray set"});
  expect_error(kBase + "[[ray_set]]\nname = \"a b\"\nkind = \"ao\"\n", 11, {"ray_set.name", "a b"});
}

TEST(HarnessConfigErrors, UnknownBuilderParameterAndLayout) {
  expect_error(kBase + "[[builder]]\n\nname = \"binned_sha\"\n", 12,
               {"unknown builder 'binned_sha'", "binned_sah", "sweep_sah"});
  expect_error(kBase + "[[builder]]\nbins = 8\n", 10, {"[[builder]] has no name"});
  expect_error(kBase + "[[builder]]\nname = \"sweep_sah\"\nbins = 8\n", 12,
               {"sweep_sah", "unknown parameter 'bins'", "min_leaf, max_leaf, c_trav, c_isect"});
  expect_error(R"([experiment]
name = "t"
scenes = ["s"]
layouts = ["bvh2",
           "bvh9"]
)",
               5, {"experiment.layouts", "unknown layout 'bvh9'", "bvh2"});
}

TEST(HarnessConfigCamera, OneViewPerSceneWithDefaults) {
  const auto config = parse_experiment_config(R"([experiment]
name = "c"
scenes = ["proc:soup:tris=1k"]
optional_scenes = ["crytek_sponza", "stanford_bunny"]

[[builder]]
name = "binned_sah"

[[ray_set]]
kind = "primary"

[[camera]]
scene = "crytek_sponza"
eye = [-100, 20.5, -4]
target = [100.0, 45.0, -4.0]
up = [0, 0, 1]
fov = 65.5

[[camera]]
scene = "proc:soup:tris=1k"
eye = [0, 0, 5]
target = [0, 0, 0]
)",
                                              "c.toml");
  ASSERT_EQ(config.cameras.size(), 2u);
  const CameraConfig* sponza = config.camera_for("crytek_sponza");
  ASSERT_NE(sponza, nullptr);
  EXPECT_EQ(sponza->eye, (std::array<float, 3>{-100.0f, 20.5f, -4.0f}));
  EXPECT_EQ(sponza->target, (std::array<float, 3>{100.0f, 45.0f, -4.0f}));
  EXPECT_EQ(sponza->up, (std::array<float, 3>{0.0f, 0.0f, 1.0f}));
  EXPECT_EQ(sponza->fov, 65.5f);
  const CameraConfig* soup = config.camera_for("proc:soup:tris=1k");
  ASSERT_NE(soup, nullptr);
  EXPECT_EQ(soup->up, (std::array<float, 3>{0.0f, 1.0f, 0.0f}));  // defaults
  EXPECT_EQ(soup->fov, 45.0f);
  EXPECT_EQ(config.camera_for("stanford_bunny"), nullptr);
  EXPECT_TRUE(parse_with("").cameras.empty());
}

TEST(HarnessConfigCamera, BadViewsNameKeyValueAndLine) {
  // kBase is lines 1-9 with the scene "proc:soup:tris=1k"; [[camera]] starts on line 10.
  const std::string scene = "[[camera]]\nscene = \"proc:soup:tris=1k\"\n";
  expect_error(kBase + "[[camera]]\nscene = \"crytek_sponza\"\neye = [0, 0, 1]\ntarget = [0, 0, 0]\n", 11,
               {"camera.scene = \"crytek_sponza\" is not a scene of this experiment"});
  expect_error(kBase + "[[camera]]\neye = [0, 0, 1]\ntarget = [0, 0, 0]\n", 10, {"[[camera]] has no scene"});
  expect_error(kBase + scene + "target = [0, 0, 0]\n", 10, {"[[camera]] has no eye"});
  expect_error(kBase + scene + "eye = [0, 0, 1]\n", 10, {"[[camera]] has no target"});
  expect_error(kBase + scene + "eye = [0, 1]\ntarget = [0, 0, 0]\n", 12,
               {"camera.eye must be a list of three numbers", "not 2"});
  expect_error(kBase + scene + "eye = \"0,0,1\"\ntarget = [0, 0, 0]\n", 12,
               {"camera.eye must be a list of three numbers", "not a string"});
  expect_error(kBase + scene + "eye = [0, 0, 1]\ntarget = [0, \"x\", 0]\n", 13,
               {"camera.target must be a list of three numbers", "not contain a string"});
  expect_error(kBase + scene + "eye = [0, 0, 1e39]\ntarget = [0, 0, 0]\n", 12,
               {"camera.eye", "1e+39", "not finite as a float"});
  expect_error(kBase + scene + "eye = [0, 0, 1]\ntarget = [0, nan, 0]\n", 13, {"camera.target", "nan"});
  expect_error(kBase + scene + "eye = [0, 0, 1]\ntarget = [0, 0, 0]\nfov = \"wide\"\n", 14,
               {"camera.fov must be a number"});
  expect_error(kBase + scene + "eye = [0, 0, 1]\ntarget = [0, 0, 0]\nzoom = 2\n", 14,
               {"unknown key 'zoom' in [[camera]]", "scene, eye, target, up, fov"});
  // The view itself: the message names the scene and the value, at the table's line.
  expect_error(kBase + scene + "eye = [1, 2, 3]\ntarget = [1, 2, 3]\n", 10,
               {"[[camera]] for \"proc:soup:tris=1k\"", "target (1, 2, 3) must differ from the eye"});
  expect_error(kBase + scene + "eye = [0, 0, 1]\ntarget = [0, 0, 0]\nup = [0, 0, 2]\n", 10,
               {"up (0, 0, 2)", "not parallel to the view direction"});
  expect_error(kBase + scene + "eye = [0, 0, 1]\ntarget = [0, 0, 0]\nup = [0, 0, 0]\n", 10, {"up (0, 0, 0)"});
  expect_error(kBase + scene + "eye = [0, 0, 1]\ntarget = [0, 0, 0]\nfov = 180\n", 14,
               {"camera.fov = 180 degrees must be in (0, 180)"});
  expect_error(kBase + scene + "eye = [0, 0, 1]\ntarget = [0, 0, 0]\nfov = 0.0\n", 14,
               {"camera.fov = 0 degrees"});
  // One view per scene.
  expect_error(kBase + scene + "eye = [0, 0, 1]\ntarget = [0, 0, 0]\n" + scene +
                   "eye = [0, 0, 2]\ntarget = [0, 0, 0]\n",
               15, {"scene \"proc:soup:tris=1k\" has two [[camera]] tables"});
  expect_error("camera = 3\n" + kBase, 1, {"camera must be written as [[camera]] tables"});
}

// [[lights]]: per scene, for the shadow sets that take the scene's lights.
TEST(HarnessConfigLights, PositionsPerSceneForSceneLightShadowSets) {
  const auto config = parse_with(R"([[ray_set]]
kind = "shadow"
light_source = "scene"

[[lights]]
scene = "proc:soup:tris=1k"
positions = [[0, 2, 0.5], [1.5, -2, 3]]
)");
  const LightsConfig* lights = config.lights_for("proc:soup:tris=1k");
  ASSERT_NE(lights, nullptr);
  ASSERT_EQ(lights->positions.size(), 2u);
  EXPECT_EQ(lights->positions[1], (std::array<float, 3>{1.5f, -2.0f, 3.0f}));
  EXPECT_EQ(to_lights(*lights)[0], (Vec3{0.0f, 2.0f, 0.5f}));
  EXPECT_EQ(config.lights_for("crytek_sponza"), nullptr);
  EXPECT_TRUE(parse_with("").lights.empty());
}

TEST(HarnessConfigLights, BadLightsNameKeyValueAndLine) {
  // kBase is lines 1-9; the shadow set takes lines 10-12 and [[lights]] starts on line 13.
  const std::string shadow = "[[ray_set]]\nkind = \"shadow\"\nlight_source = \"scene\"\n";
  const std::string table = "[[lights]]\nscene = \"proc:soup:tris=1k\"\n";
  expect_error(kBase + table + "positions = [[0, 1, 0]]\n", 10,
               {"[[lights]] is for shadow sets with light_source = \"scene\"", "no [[ray_set]] has one"});
  expect_error(kBase + shadow + "[[lights]]\nscene = \"crytek_sponza\"\npositions = [[0, 1, 0]]\n", 14,
               {"lights.scene = \"crytek_sponza\" is not a scene of this experiment"});
  expect_error(kBase + shadow + "[[lights]]\npositions = [[0, 1, 0]]\n", 13, {"[[lights]] has no scene"});
  expect_error(kBase + shadow + table, 13, {"[[lights]] has no positions"});
  expect_error(kBase + shadow + table + "positions = []\n", 15,
               {"lights.positions must be a list of 1 to 65536 points", "not 0"});
  expect_error(kBase + shadow + table + "positions = [0, 1, 0]\n", 15,
               {"lights.positions[0] must be a list of three numbers", "not an integer"});
  expect_error(kBase + shadow + table + "positions = [[0, 1, 0], [0, 1]]\n", 15,
               {"lights.positions[1] must be a list of three numbers", "not 2"});
  expect_error(kBase + shadow + table + "positions = [[0, 1e39, 0]]\n", 15,
               {"lights.positions[0]", "not finite as a float"});
  expect_error(kBase + shadow + table + "positions = [[0, 1, 0]]\nintensity = 2\n", 16,
               {"unknown key 'intensity' in [[lights]]", "scene, positions"});
  expect_error(kBase + shadow + table + "positions = [[0, 1, 0]]\n" + table + "positions = [[0, 2, 0]]\n", 17,
               {"scene \"proc:soup:tris=1k\" has two [[lights]] tables"});
}

// Settings are chosen on tune.toml and results claimed on claim.toml: the two share no view of a scene,
// the procedural ones compared by their normalised spec (a proc scene's seed is its own, not the
// experiment's), a shared scene by its camera (Sponza is seen from two ends).
TEST(HarnessConfigLoad, ClaimAndTuneShareNoSceneView) {
  const std::filesystem::path configs = std::filesystem::path(SAHBENCH_SOURCE_DIR) / "configs";
  auto scenes_of = [](const ExperimentConfig& c) {
    std::set<std::string> out;
    for (const auto* list : {&c.scenes, &c.optional_scenes})
      for (const auto& scene : *list) {
        std::string view =
            is_procedural_spec(scene) ? parse_proc_spec(scene, procedural_kinds()).normalised() : scene;
        if (const CameraConfig* camera = c.camera_for(scene))
          view += fmt::format(" from {} to {}", fmt::join(camera->eye, ","), fmt::join(camera->target, ","));
        out.insert(view);
      }
    return out;
  };
  const auto tune = scenes_of(load_experiment_config(configs / "tune.toml"));
  std::size_t claims = 0;
  for (const auto& entry : std::filesystem::directory_iterator(configs)) {
    const std::string name = entry.path().filename().string();
    if (!name.starts_with("claim") || entry.path().extension() != ".toml") continue;
    ++claims;
    for (const auto& scene : scenes_of(load_experiment_config(entry.path())))
      EXPECT_EQ(tune.count(scene), 0u) << name << " claims on tune.toml's " << scene;
  }
  EXPECT_GE(claims, 5u);
}

// Every experiment config shipped in configs/ loads, and every one that measures Sponza looks at it from
// inside (the automatic framing would see only the outside of the building).
TEST(HarnessConfigLoad, ShippedConfigsLoadAndViewSponzaFromInside) {
  register_embree_builders();  // as sahbench does at startup (a repeated call is a no-op)
  std::size_t experiments = 0;
  std::vector<std::array<float, 3>> eyes;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::path(SAHBENCH_SOURCE_DIR) / "configs")) {
    if (entry.path().extension() != ".toml") continue;
    std::ifstream in(entry.path());
    std::stringstream text;
    text << in.rdbuf();
    if (text.str().find("\n[stress]") != std::string::npos) continue;  // sahbench stress's own schema
    SCOPED_TRACE(entry.path().string());
    ExperimentConfig config;
    ASSERT_NO_THROW(config = load_experiment_config(entry.path()));
    ++experiments;
    const auto& optional = config.optional_scenes;
    if (std::find(optional.begin(), optional.end(), "crytek_sponza") != optional.end()) {
      const CameraConfig* camera = config.camera_for("crytek_sponza");
      ASSERT_NE(camera, nullptr);
      eyes.push_back(camera->eye);
    }
  }
  EXPECT_GE(experiments, 6u);
  ASSERT_FALSE(eyes.empty()) << "no shipped config measures crytek_sponza";
  // Inside the building: within its box, under the roof.
  SAHBENCH_REQUIRE_SHARED_SCENE("crytek_sponza");
  const Scene sponza = load_scene("crytek_sponza");
  Aabb box;
  for (const Triangle& t : sponza.triangles) box.extend(t.bounds());
  for (const auto& eye : eyes)
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_GT(eye[axis], box.min[axis] + 0.05f * box.extent()[axis]) << axis;
      EXPECT_LT(eye[axis], box.max[axis] - 0.05f * box.extent()[axis]) << axis;
    }
}

TEST(HarnessConfigLoad, ReadsFileAndNamesItInErrors) {
  const auto dir = std::filesystem::temp_directory_path() / ("sahbench_config_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto good = dir / "good.toml";
  std::ofstream(good) << kBase;
  const auto config = load_experiment_config(good);
  EXPECT_EQ(config.path, good);
  EXPECT_EQ(config.name, "t");

  const auto bad = dir / "bad.toml";
  std::ofstream(bad) << kBase << "[repetitions]\nbuild = 0\n";
  try {
    load_experiment_config(bad);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(bad.string() + ":11:", 0), 0u) << e.what();
  }
  try {
    load_experiment_config(dir / "missing.toml");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.toml"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sahbench
