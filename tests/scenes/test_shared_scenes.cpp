#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <optional>
#include <string>

#include "scenes/load.h"
#include "scenes/scene_path.h"
#include "tests/scenes/temp_dir.h"
#include "tests/support/prerequisites.h"

namespace sahbench {
namespace {

using test::error_message;
using test::TempDir;

// Triangle counts from shared/scenes/SOURCES.md (after node transforms: instances count once per use).
struct SharedScene {
  const char* name;
  std::size_t triangles;
  bool animated = false;  ///< SOURCES.md: the skinned-animation scenes
};

// Names the scene in test output instead of dumping its bytes.
void PrintTo(const SharedScene& s, std::ostream* os) {
  *os << s.name << " (" << s.triangles << " triangles)";
}

class SceneShared : public ::testing::TestWithParam<SharedScene> {};

TEST_P(SceneShared, LoadsWithTheDocumentedCount) {
  const SharedScene& expected = GetParam();
  SAHBENCH_REQUIRE_SHARED_SCENE(expected.name);
  const auto file = find_scene_file(expected.name);
  const Scene scene = load_scene(expected.name);
  EXPECT_EQ(scene.name, expected.name);
  EXPECT_EQ(scene.animated, expected.animated) << "the scene's static/animated declaration";
  EXPECT_EQ(scene.source, file->string());
  EXPECT_EQ(scene.triangles.size() + scene.removed.total(), expected.triangles)
      << "valid " << scene.triangles.size() << ", removed: non_finite " << scene.removed.non_finite
      << ", bad_index " << scene.removed.bad_index << ", zero_area " << scene.removed.zero_area;
}

INSTANTIATE_TEST_SUITE_P(
    Documented, SceneShared,
    ::testing::Values(SharedScene{"cornell_box", 36}, SharedScene{"smallpine", 1650},
                      SharedScene{"RiggedFigure", 256, true}, SharedScene{"CesiumMan", 4672, true},
                      SharedScene{"BrainStem", 61666, true}, SharedScene{"stanford_bunny", 69451},
                      SharedScene{"FlightHelmet", 94722}, SharedScene{"2CylinderEngine", 121496},
                      SharedScene{"ReciprocatingSaw", 198470}, SharedScene{"stanford_dragon_res2", 202520},
                      SharedScene{"crytek_sponza", 262205}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(SceneSharedList, ListsEveryDocumentedScene) {
  test::Skips skips;
  const auto entries = list_shared_scenes();
  for (const char* name :
       {"cornell_box", "smallpine", "stanford_bunny", "FlightHelmet", "stanford_dragon_res2"}) {
    const auto it =
        std::find_if(entries.begin(), entries.end(), [&](const auto& e) { return e.name == name; });
    if (!skips.have_scene(name)) continue;
    ASSERT_NE(it, entries.end()) << name;
    EXPECT_EQ(it->path, *find_scene_file(name));
  }
  EXPECT_TRUE(std::is_sorted(entries.begin(), entries.end(),
                             [](const auto& a, const auto& b) { return a.name < b.name; }));
  SAHBENCH_REPORT_SKIPS(skips);
}

// The helper every shared-scene test uses: a missing scene is a skip with its reason, and a failure
// under CI=true, where the scenes are provided.
TEST(ScenePrerequisites, MissingSceneIsASkipLocallyAndAFailureUnderCi) {
  const char* old = std::getenv("CI");
  const std::optional<std::string> saved = old ? std::optional<std::string>(old) : std::nullopt;
  ::unsetenv("CI");
  const auto why = test::missing_shared_scene("nothing_by_this_name_xyz");
  ASSERT_TRUE(why.has_value());
  EXPECT_NE(why->find("'nothing_by_this_name_xyz' not found"), std::string::npos) << *why;
  ::setenv("CI", "true", 1);
  EXPECT_NONFATAL_FAILURE(test::missing_shared_scene("nothing_by_this_name_xyz"), "CI=true");
  test::Skips skips;
  EXPECT_NONFATAL_FAILURE(skips.have_scene("nothing_by_this_name_xyz"), "nothing_by_this_name_xyz");
  EXPECT_TRUE(skips.none_ran());
  if (saved)
    ::setenv("CI", saved->c_str(), 1);
  else
    ::unsetenv("CI");
}

// Sets SAHBENCH_SCENE_PATH for one test and restores it afterwards.
class SceneSearchPath : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const char* old = std::getenv("SAHBENCH_SCENE_PATH")) saved_ = old;
  }
  void TearDown() override {
    if (saved_)
      ::setenv("SAHBENCH_SCENE_PATH", saved_->c_str(), 1);
    else
      ::unsetenv("SAHBENCH_SCENE_PATH");
  }
  static void set_path(const std::string& value) { ::setenv("SAHBENCH_SCENE_PATH", value.c_str(), 1); }

  std::optional<std::string> saved_;
};

constexpr const char* kTriangleObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

TEST_F(SceneSearchPath, EnvironmentComesFirstMissingSkippedDuplicatesRemoved) {
  TempDir a, b;
  const auto dir_a = a.path() / "a";
  const auto dir_b = b.path() / "b";
  std::filesystem::create_directories(dir_a);
  std::filesystem::create_directories(dir_b);
  set_path(dir_a.string() + "::" + (a.path() / "missing").string() + ":" + dir_b.string() + ":" +
           dir_a.string() + "/../a");
  const auto dirs = scene_search_path();
  ASSERT_GE(dirs.size(), 2u);
  EXPECT_EQ(dirs[0], std::filesystem::canonical(dir_a));
  EXPECT_EQ(dirs[1], std::filesystem::canonical(dir_b));
  EXPECT_EQ(std::count(dirs.begin(), dirs.end(), std::filesystem::canonical(dir_a)), 1);
  for (const auto& d : dirs) EXPECT_TRUE(std::filesystem::is_directory(d)) << d;
}

TEST_F(SceneSearchPath, FindsEveryNamingForm) {
  TempDir dir;
  dir.write("plain.obj", kTriangleObj);          // NAME.obj
  dir.write("exact", "");                        // NAME itself (a file)
  dir.write("folder/folder.obj", kTriangleObj);  // NAME/NAME.obj
  dir.write("sketch/scene.gltf", "{}");          // NAME/scene.gltf
  dir.write("both.glb", "");                     // NAME.glb wins over NAME.obj
  dir.write("both.obj", kTriangleObj);
  set_path(dir.path().string());
  const auto root = std::filesystem::canonical(dir.path());
  EXPECT_EQ(find_scene_file("plain"), root / "plain.obj");
  EXPECT_EQ(find_scene_file("plain.obj"), root / "plain.obj");
  EXPECT_EQ(find_scene_file("exact"), root / "exact");
  EXPECT_EQ(find_scene_file("folder"), root / "folder" / "folder.obj");
  EXPECT_EQ(find_scene_file("sketch"), root / "sketch" / "scene.gltf");
  EXPECT_EQ(find_scene_file("both"), root / "both.glb");
  EXPECT_FALSE(find_scene_file("nothing_by_this_name_xyz").has_value());

  // Loading by name goes through the same resolution.
  const Scene scene = load_scene("plain");
  EXPECT_EQ(scene.triangles.size(), 1u);
  EXPECT_EQ(scene.name, "plain");
  EXPECT_EQ(scene.source, (root / "plain.obj").string());

  // The listing names each scene once, sorted, with the file the name resolves to.
  const auto entries = list_shared_scenes();
  auto find = [&](const std::string& name) {
    return std::find_if(entries.begin(), entries.end(), [&](const auto& e) { return e.name == name; });
  };
  ASSERT_NE(find("plain"), entries.end());
  EXPECT_EQ(find("plain")->path, root / "plain.obj");
  ASSERT_NE(find("folder"), entries.end());
  ASSERT_NE(find("sketch"), entries.end());
  ASSERT_NE(find("both"), entries.end());
  EXPECT_EQ(find("both")->path, root / "both.glb");
  EXPECT_EQ(find("exact"), entries.end());  // no scene extension
}

TEST_F(SceneSearchPath, UnknownNameListsTheSearchPath) {
  TempDir dir;
  set_path(dir.path().string());
  const std::string msg = error_message([] { load_scene("nothing_by_this_name_xyz"); });
  EXPECT_NE(msg.find("nothing_by_this_name_xyz: unknown scene"), std::string::npos) << msg;
  EXPECT_NE(msg.find(std::filesystem::canonical(dir.path()).string()), std::string::npos) << msg;
}

TEST_F(SceneSearchPath, UnsupportedExtensionAndDirectoryPath) {
  TempDir dir;
  const auto txt = dir.write("notes.txt", "hello");
  const std::string msg = error_message([&] { load_scene(txt.string()); });
  EXPECT_NE(msg.find(txt.string() + ": unsupported scene file extension '.txt'"), std::string::npos) << msg;

  dir.write("model/model.obj", kTriangleObj);
  EXPECT_EQ(load_scene((dir.path() / "model").string()).triangles.size(), 1u);
  dir.write("empty_folder/readme.md", "");
  const std::string msg2 = error_message([&] { load_scene((dir.path() / "empty_folder").string()); });
  EXPECT_NE(msg2.find("directory holds no scene file"), std::string::npos) << msg2;
}

}  // namespace
}  // namespace sahbench
