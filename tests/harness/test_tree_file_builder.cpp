// The `file` builder (harness/run/tree_file_builder.h): a saved tree is a tree source like any builder, in
// a config (path relative to the config's folder) and on the command line (relative to the current
// folder); its cells trace with no mismatch against brute force, and a missing file, a foreign file or a
// tree of another scene is an Error naming it.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "builders/registry.h"
#include "cli/build_command.h"
#include "core/error.h"
#include "harness/config/config.h"
#include "harness/run/csv.h"
#include "harness/run/runner.h"
#include "harness/run/tree_file_builder.h"
#include "scenes/load.h"
#include "scenes/tree_file.h"
#include "tests/support/error_of.h"
#include "tests/support/process_temp_dir.h"

namespace sahbench {
namespace {

using test::error_of;

constexpr const char* kScene = "proc:sphere:tris=3000";

// A fresh folder per test, with a trees/ subfolder.
std::filesystem::path fresh_dir(const std::string& name) {
  const auto dir = test::process_temp_dir("tree_file_builder") / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "trees");
  return dir;
}

// The tree of `builder` (with `params`) on `scene`, saved at `path`.
Bvh save_tree(const std::string& scene_spec, const std::string& builder, const ParamOverrides& params,
              const std::filesystem::path& path) {
  const Scene scene = load_scene(scene_spec);
  const BuilderInfo& info = find_builder(builder);
  const Bvh bvh =
      info.build(BuildInput::from_triangles(scene.triangles), resolve_params(info.name, info.params, params));
  write_tree_file(path, bvh, scene.triangles);
  return bvh;
}

void contains(const std::string& message, const std::string& part) {
  EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
}

class TreeFileBuilder : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { register_tree_file_builder(); }
};

TEST_F(TreeFileBuilder, ConfigRunTracesSavedTreesWithNoMismatches) {
  const auto dir = fresh_dir("run");
  save_tree(kScene, "binned_sah", {}, dir / "trees" / "binary.sbt");
  save_tree(kScene, "wide_collapse", {{"arity", "8"}}, dir / "trees" / "wide.sbt");
  const auto csv = dir / "out.csv";
  const auto config = dir / "byot.toml";
  // Paths relative to the config's folder; the run itself happens wherever the test runs.
  std::ofstream(config) << "[experiment]\nname = \"byot\"\noutput = \"" << csv.string() << "\"\n"
                        << "scenes = [\"" << kScene
                        << "\"]\nlayouts = [\"bvh2\", \"bvh2_packed\", \"bvh8\"]\n"
                        << "reference = \"brute_force\"\n"
                        << "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
                        << "[[builder]]\nname = \"file\"\npath = [\"trees/binary.sbt\", \"trees/wide.sbt\"]\n"
                        << "[[builder]]\nname = \"embree\"\n"
                        << "[[ray_set]]\nkind = \"primary\"\nwidth = 16\nheight = 16\n"
                        << "[[ray_set]]\nkind = \"shadow\"\nwidth = 16\nheight = 16\n";
  std::ostringstream log;
  ASSERT_EQ(run_experiment({config, false, "", std::nullopt}, log), 0) << log.str();
  const auto rows = read_csv(csv);
  std::size_t binary = 0, wide = 0, embree = 0;
  for (const auto& row : rows) {
    SCOPED_TRACE(row.at("builder") + " " + row.at("builder_params") + " " + row.at("layout"));
    EXPECT_EQ(row.at("mismatches"), "0");
    EXPECT_EQ(row.at("reference"), "brute_force");
    if (row.at("builder") != "file") {
      ++embree;
      continue;
    }
    EXPECT_FALSE(row.at("sah_cost").empty());
    const std::string params = row.at("builder_params");
    if (params.find("path=binary.sbt;path_hash=0x") == 0) {
      ++binary;
      EXPECT_EQ(row.at("arity"), "2");
    } else {
      EXPECT_EQ(params.find("path=wide.sbt;path_hash=0x"), 0u) << params;
      EXPECT_EQ(row.at("layout"), "bvh8");
      ++wide;
    }
  }
  // The binary tree on both binary layouts and the 8-wide one on bvh8, each with 2 ray sets; Embree's
  // 1-ray layout beside them.
  EXPECT_EQ(binary, 4u);
  EXPECT_EQ(wide, 2u);
  EXPECT_GT(embree, 0u);
}

TEST_F(TreeFileBuilder, RelativePathsAreRelativeToTheConfigsFolder) {
  const auto dir = fresh_dir("relative");
  save_tree(kScene, "binned_sah", {}, dir / "trees" / "t.sbt");
  std::filesystem::create_directories(dir / "configs");
  const auto config = dir / "configs" / "c.toml";
  std::ofstream(config) << "[experiment]\nname = \"c\"\nscenes = [\"" << kScene << "\"]\n"
                        << "[[builder]]\nname = \"file\"\npath = \"../trees/t.sbt\"\n"
                        << "[[builder]]\nname = \"reinsert\"\nsource = { name = \"file\", path = \""
                        << (dir / "trees" / "t.sbt").string() << "\" }\n"
                        << "[[ray_set]]\nkind = \"primary\"\n";
  const ExperimentConfig c = load_experiment_config(config);
  ASSERT_EQ(c.builders.size(), 2u);
  EXPECT_EQ(c.builders[0].values.get_path("path"), (dir / "trees" / "t.sbt").string());
  // An absolute path is kept; and a pass takes a saved binary tree as its source.
  EXPECT_NE(c.builders[1].params_text().find("source=file(path=t.sbt;path_hash=0x"), std::string::npos)
      << c.builders[1].params_text();
  // The same path relative to the current folder is not found from the config's.
  std::ofstream(config) << "[experiment]\nname = \"c\"\nscenes = [\"" << kScene << "\"]\n"
                        << "[[builder]]\nname = \"file\"\npath = \"trees/t.sbt\"\n"
                        << "[[ray_set]]\nkind = \"primary\"\n";
  const std::string message = error_of([&] { load_experiment_config(config); });
  contains(message, "c.toml:");
  contains(message, (dir / "configs" / "trees" / "t.sbt").string() + ": cannot open the tree file");
}

TEST_F(TreeFileBuilder, CommandLinePathsAreRelativeToTheCurrentFolder) {
  const auto dir = fresh_dir("cli");
  save_tree(kScene, "binned_sah", {}, dir / "trees" / "t.sbt");
  const auto cwd = std::filesystem::current_path();
  std::filesystem::current_path(dir);
  BuilderRun shorthand = parse_builder_run("file:trees/t.sbt");
  BuilderRun keyed = parse_builder_run("file:path=trees/t.sbt,c_trav=2");
  BuilderRun short_keyed = parse_builder_run("file:trees/t.sbt,c_trav=2");
  EXPECT_NO_THROW(resolve(shorthand));
  EXPECT_NO_THROW(resolve(keyed));
  EXPECT_NO_THROW(resolve(short_keyed));
  std::filesystem::current_path(cwd);
  // Held absolute, so the file is found whatever the current folder later is, and recorded by its name
  // and its contents' hash.
  const std::string path = (dir / "trees" / "t.sbt").string();
  EXPECT_EQ(shorthand.values.get_path("path"), path);
  const std::string text = keyed.values.to_string();
  EXPECT_EQ(text.find("path=t.sbt;path_hash=0x"), 0u) << text;
  EXPECT_NE(text.find(";c_trav=2;c_isect=1"), std::string::npos) << text;
  EXPECT_EQ(short_keyed.values.to_string(), text);
}

TEST_F(TreeFileBuilder, AnotherTreeInTheSameFileIsAnotherRun) {
  const auto dir = fresh_dir("rewritten");
  const auto path = dir / "t.sbt";
  save_tree(kScene, "binned_sah", {}, path);
  BuilderRun first = parse_builder_run("file:" + path.string());
  resolve(first);
  save_tree(kScene, "sweep_sah", {}, path);
  BuilderRun second = parse_builder_run("file:" + path.string());
  resolve(second);
  EXPECT_NE(first.params_text(), second.params_text());
  save_tree(kScene, "binned_sah", {}, path);
  BuilderRun again = parse_builder_run("file:" + path.string());
  resolve(again);
  EXPECT_EQ(first.params_text(), again.params_text());
  // The same file in another folder (another checkout) is the same run.
  std::filesystem::create_directories(dir / "elsewhere");
  std::filesystem::copy_file(path, dir / "elsewhere" / "t.sbt");
  BuilderRun moved = parse_builder_run("file:" + (dir / "elsewhere" / "t.sbt").string());
  resolve(moved);
  EXPECT_EQ(first.params_text(), moved.params_text());
  // Written over after the run was resolved: its build refuses to measure the new tree under the old hash.
  save_tree(kScene, "sweep_sah", {}, path);
  const Scene scene = load_scene(kScene);
  contains(error_of([&] { again.info->build(BuildInput::from_triangles(scene.triangles), again.values); }),
           "the tree file changed since the run was planned");
}

TEST_F(TreeFileBuilder, ConfigsWhereATreeFileCannotFitAreRefusedAsRead) {
  const auto dir = fresh_dir("unfit");
  save_tree(kScene, "binned_sah", {}, dir / "t.sbt");
  const std::string head = "[experiment]\nname = \"t\"\nlayouts = [\"bvh2\"]\n";
  const std::string builder = "[[builder]]\nname = \"file\"\npath = \"t.sbt\"\n";
  const std::string rays = "[[ray_set]]\nkind = \"primary\"\nwidth = 8\nheight = 8\n";
  const auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return dir / name;
  };
  const auto two = write("two.toml", head + "scenes = [\"" + std::string(kScene) +
                                         "\", \"proc:soup:tris=100\"]\n" + builder + rays);
  contains(error_of([&] { load_experiment_config(two); }), "two.toml:");
  contains(error_of([&] { load_experiment_config(two); }), "fits one scene, but this config names 2 scenes");
  const auto one = write("one.toml", head + "scenes = [\"" + std::string(kScene) + "\"]\n" + builder + rays);
  EXPECT_NO_THROW(load_experiment_config(one));
  // A truncated file is named as the config is read, with the config's line, not after the run began.
  std::filesystem::resize_file(dir / "t.sbt", std::filesystem::file_size(dir / "t.sbt") - 4);
  const std::string cut = error_of([&] { load_experiment_config(one); });
  contains(cut, "one.toml:5:");
  contains(cut, "t.sbt: tree file is truncated");
}

TEST_F(TreeFileBuilder, BadPathsAreErrorsNamingThem) {
  const auto dir = fresh_dir("bad");
  BuilderRun missing = parse_builder_run("file:path=" + (dir / "no_such.sbt").string());
  contains(error_of([&] { resolve(missing); }),
           (dir / "no_such.sbt").string() + ": cannot open the tree file");
  BuilderRun none = parse_builder_run("file");
  contains(error_of([&] { resolve(none); }), "file: parameter 'path' is required");
  BuilderRun separator = parse_builder_run("file:path=a;b.sbt");
  contains(error_of([&] { resolve(separator); }), "a;b.sbt' has a character a path parameter may not hold");
  std::ofstream(dir / "foreign.sbt") << "solid cube\n";
  BuilderRun foreign = parse_builder_run("file:" + (dir / "foreign.sbt").string());
  contains(error_of([&] { resolve(foreign); }), "not a sahbench tree file");
}

// As `run` does, `build` says when a thread count is more than the machine has.
TEST(BuildCommand, MoreThreadsThanTheMachineHasAreSaid) {
  BuildCommandOptions options;
  options.scene = kScene;
  options.builders = {parse_builder_run("binned_sah")};
  const int more = static_cast<int>(std::max(1u, std::thread::hardware_concurrency())) + 1;
  options.threads = {more};
  options.reps = 1;
  options.warmup = 0;
  std::ostringstream out, log;
  ASSERT_EQ(run_build_command(options, out, log), 0) << out.str() << log.str();
  contains(log.str(), "warning: --threads " + std::to_string(more) + " is more than the");
}

TEST_F(TreeFileBuilder, TreeOfAnotherSceneFailsTheBuild) {
  const auto dir = fresh_dir("other_scene");
  const auto path = dir / "trees" / "soup.sbt";
  save_tree("proc:soup:tris=1000", "binned_sah", {}, path);
  BuildCommandOptions options;
  options.scene = kScene;
  options.builders = {parse_builder_run("file:" + path.string())};
  options.reps = 1;
  options.warmup = 0;
  std::ostringstream out, log;
  const std::string message = error_of([&] { run_build_command(options, out, log); });
  contains(message, "tree file " + path.string() + " was built for a scene with hash ");
  contains(message, "and 1000 triangles, this scene has hash");
}

// In a config run the scene is checked as soon as it is loaded, naming the config and the builder run,
// before the builders listed ahead of it have built anything (no row is written).
TEST_F(TreeFileBuilder, TreeOfAnotherSceneFailsTheRunBeforeAnyBuild) {
  const auto dir = fresh_dir("run_other_scene");
  save_tree("proc:soup:tris=1000", "binned_sah", {}, dir / "trees" / "soup.sbt");
  // The file read by the builder itself, or as the source of a pass over it.
  for (const std::string builder :
       {"name = \"file\"\npath = \"trees/soup.sbt\"\n",
        "name = \"reinsert\"\nsource = { name = \"file\", path = \"trees/soup.sbt\" }\n"}) {
    SCOPED_TRACE(builder);
    const auto csv = dir / "out.csv";
    std::filesystem::remove(csv);
    const auto config = dir / "other.toml";
    std::ofstream(config) << "[experiment]\nname = \"other\"\noutput = \"" << csv.string() << "\"\n"
                          << "scenes = [\"" << kScene << "\"]\nlayouts = [\"bvh2\"]\nreference = \"none\"\n"
                          << "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
                          << "[[builder]]\nname = \"binned_sah\"\n"
                          << "[[builder]]\n"
                          << builder << "[[ray_set]]\nkind = \"primary\"\nwidth = 16\nheight = 16\n";
    std::ostringstream log;
    const std::string message = error_of([&] { run_experiment({config, false, "", std::nullopt}, log); });
    contains(message, config.string() + ": builder run '");
    contains(message, "on scene " + std::string(kScene) + ": tree file ");
    contains(message, "was built for a scene with hash ");
    EXPECT_EQ(log.str().find("build repetition"), std::string::npos) << log.str();
    EXPECT_TRUE(!std::filesystem::exists(csv) || read_csv(csv).empty());
  }
}

TEST_F(TreeFileBuilder, BuildSaveWritesTheTreeThatFileReadsBack) {
  const auto dir = fresh_dir("save");
  const auto path = dir / "trees" / "saved.sbt";
  BuildCommandOptions options;
  options.scene = kScene;
  options.builders = {parse_builder_run("sbvh")};
  options.threads = {1, 2};
  options.reps = 1;
  options.warmup = 0;
  options.save = path.string();
  std::ostringstream out, log;
  ASSERT_EQ(run_build_command(options, out, log), 0) << out.str() << log.str();
  contains(out.str(), "# saved the tree to " + path.string());
  const Scene scene = load_scene(kScene);
  const BuilderInfo& sbvh = find_builder("sbvh");
  EXPECT_EQ(load_tree_file(path, scene.triangles),
            sbvh.build(BuildInput::from_triangles(scene.triangles), resolve_params("sbvh", sbvh.params, {})));
  // Read back through the command: same statistics, valid.
  BuildCommandOptions again = options;
  again.save.clear();
  again.threads = {1};
  again.builders = {parse_builder_run("file:" + path.string()), parse_builder_run("sbvh")};
  std::ostringstream out2;
  ASSERT_EQ(run_build_command(again, out2, log), 0) << out2.str();
  // The statistics of a row: nodes, leaves, depth, references per leaf, SAH, bytes and validity.
  auto statistics_of = [&](const std::string& builder) {
    std::istringstream lines(out2.str());
    for (std::string line; std::getline(lines, line);) {
      std::istringstream fields(line);
      std::vector<std::string> words{std::istream_iterator<std::string>(fields), {}};
      if (words.size() > 7 && words[1] == builder)
        return std::vector<std::string>(words.end() - 7, words.end());
    }
    return std::vector<std::string>{};
  };
  const auto from_file = statistics_of("file");
  ASSERT_EQ(from_file.size(), 7u) << out2.str();
  EXPECT_EQ(from_file, statistics_of("sbvh")) << out2.str();
  EXPECT_EQ(from_file.back(), "ok") << out2.str();
  // One tree per file: two builders, or Embree's, are refused before any build.
  BuildCommandOptions two = options;
  two.builders = {parse_builder_run("sbvh"), parse_builder_run("binned_sah")};
  contains(error_of([&] { run_build_command(two, out, log); }), "--save writes one tree");
  BuildCommandOptions embree = options;
  embree.builders = {parse_builder_run("embree_medium")};
  contains(error_of([&] { run_build_command(embree, out, log); }), "--save writes one tree");
  BuildCommandOptions folder = options;
  folder.save = dir.string();
  contains(error_of([&] { run_build_command(folder, out, log); }), "is a directory");
}

}  // namespace
}  // namespace sahbench
