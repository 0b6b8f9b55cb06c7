#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "scenes/load.h"
#include "scenes/obj_loader.h"
#include "tests/scenes/temp_dir.h"

namespace sahbench {
namespace {

using test::error_message;
using test::TempDir;

// Bytes that are no OBJ, or an OBJ cut off before its faces, load as no triangles: refused, not measured
// as an empty scene.
TEST(SceneObj, AFileWithoutTrianglesIsRefused) {
  TempDir dir;
  for (const char* text : {"\x7f\x45\x4c\x46 garbage \x01\x02\n", "v 0 0 0\nv 1 0 0\nv 0 1", ""}) {
    const auto path = dir.write("none.obj", text);
    try {
      load_scene_file(path);
      ADD_FAILURE() << "no error for " << text;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(path.string() + ": no triangles"), std::string::npos) << e.what();
    }
  }
}

// A file whose every triangle is removed as invalid says so, not that it is no OBJ.
TEST(SceneObj, AFileOfOnlyInvalidTrianglesSaysSo) {
  TempDir dir;
  const auto path = dir.write("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
  try {
    load_scene_file(path);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path.string() + ": no triangles left: all 1 were invalid"),
              std::string::npos)
        << e.what();
  }
}

TEST(SceneObj, QuadsAndPolygonsWithMissingMtl) {
  TempDir dir;
  const std::string text =
      "# a quad, a triangle and a pentagon; the material library does not exist\n"
      "mtllib missing.mtl\n"
      "o thing\n"
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
      "vt 0 0\nvn 0 0 1\n"
      "usemtl nothing\n"
      "f 1/1/1 2/1/1 3/1/1 4/1/1\n"
      "v 0 0 3\n"
      "f 1//1 2//1 5//1\n"
      "v 2 0 0\nv 3 1 0\nv 2 2 0\nv 1.5 1 0\nv 1.7 0.5 0\n"
      "f -5 -4 -3 -2 -1\n"  // relative indices: the five vertices just defined
      "l 1 2\n";
  const Scene scene = load_obj(dir.write("shape.obj", text));
  EXPECT_EQ(scene.removed.total(), 0u);
  ASSERT_EQ(scene.triangles.size(), 2u + 1u + 3u);
  EXPECT_EQ(scene.triangles[0], (Triangle{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}}));
  EXPECT_EQ(scene.triangles[1], (Triangle{{0, 0, 0}, {1, 1, 0}, {0, 1, 0}}));
  EXPECT_EQ(scene.triangles[2], (Triangle{{0, 0, 0}, {1, 0, 0}, {0, 0, 3}}));
  EXPECT_EQ(scene.triangles[3], (Triangle{{2, 0, 0}, {3, 1, 0}, {2, 2, 0}}));
  EXPECT_EQ(scene.triangles[5], (Triangle{{2, 0, 0}, {1.5f, 1, 0}, {1.7f, 0.5f, 0}}));
}

TEST(SceneObj, InvalidTrianglesAreCounted) {
  TempDir dir;
  const std::string text =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\n"
      "f 1 2 3\n"   // valid
      "f 1 2 9\n"   // past the end
      "f 1 2 -9\n"  // relative, before the first vertex
      "f 1 2 4\n"   // collinear
      "f 1 1 3\n"   // repeated vertex
      "f 1 2\n";    // two-vertex face
  const Scene scene = load_obj(dir.write("bad.obj", text));
  EXPECT_EQ(scene.triangles.size(), 1u);
  EXPECT_EQ(scene.removed.bad_index, 2u);
  EXPECT_EQ(scene.removed.zero_area, 3u);
}

// tinyobjloader reads what it cannot parse as 0 and wraps indices beyond int: each such vertex must be
// counted non-finite and each such index bad, never kept as a triangle at the origin.
TEST(SceneObj, UnreadableValuesAreCountedNotReadAsZero) {
  TempDir dir;
  const std::string text =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
      "v nan 0 0\nv inf 0 0\nv 1 1 banana\nv 1e39 0 0\nv 0 0\n"  // vertices 4..8
      "f 1 2 3\n"                                                // valid
      "f 1 2 4\nf 1 2 5\nf 1 2 6\nf 1 2 7\nf 1 2 8\n"            // non-finite
      "f 1 2 99999999999999999999\n"                             // beyond int64
      "f 1 2 4294967299\n"                                       // 2^32 + 3: wrapped, it was 3
      "f 1/1 2/1 3x/1\n";                                        // not an index
  const Scene scene = load_obj(dir.write("unreadable.obj", text));
  EXPECT_EQ(scene.triangles.size(), 1u);
  EXPECT_EQ(scene.removed.non_finite, 5u);
  EXPECT_EQ(scene.removed.bad_index, 3u);
}

// The strict pass must count lines as tinyobjloader does, or its flags land on the wrong vertex: bare
// keywords, a lone CR as line end, a '#' after a face, a tiny coordinate and '+' signs.
TEST(SceneObj, StrictPassReadsLinesAsTinyObjLoaderDoes) {
  TempDir dir;
  const std::string text =
      "v\nf\nf \n"                       // no callbacks
      "v 0 0 0\rv 1 0 0\rv 0 1 1e-50\r"  // classic Mac line ends
      "v nan 0 0\r\n"                    // vertex 4, non-finite
      "f 1 2 3 # a comment tinyobjloader reads as corners\n"
      "f +1 +2 +3\n"
      "f 1 2 4\n";
  const Scene scene = load_obj(dir.write("lexing.obj", text));
  EXPECT_EQ(scene.removed.non_finite, 1u);
  // The first face has 10 corners for both readers: its fan keeps 1-2-3 and counts 7 bad triangles.
  EXPECT_EQ(scene.removed.bad_index, 7u);
  EXPECT_EQ(scene.triangles.size(), 2u);
  EXPECT_EQ(scene.triangles[0], (Triangle{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
}

TEST(SceneObj, HugeCoordinateIsNonFinite) {
  TempDir dir;
  const Scene scene = load_obj(dir.write("big.obj", "v 0 0 0\nv 1 0 0\nv 0 1e300 0\nf 1 2 3\n"));
  EXPECT_EQ(scene.triangles.size(), 0u);
  EXPECT_EQ(scene.removed.non_finite, 1u);
}

TEST(SceneObj, FaceBeforeItsVertices) {
  TempDir dir;
  const Scene scene = load_obj(dir.write("late.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"));
  EXPECT_EQ(scene.triangles.size(), 1u);
}

TEST(SceneObj, PolygonWithManyVertices) {
  // More than 255 corners: tinyobjloader's own mesh arrays store the count in a byte; the streaming
  // path used here does not.
  TempDir dir;
  std::string text;
  constexpr int kCorners = 300;
  for (int i = 0; i < kCorners; ++i) {
    const double a = 2.0 * 3.14159265358979 * i / kCorners;
    text += "v " + std::to_string(std::cos(a));
    text += ' ';
    text += std::to_string(std::sin(a)) + " 0\n";
  }
  text += "f";
  for (int i = 1; i <= kCorners; ++i) {
    text += ' ';
    text += std::to_string(i);
  }
  text += "\n";
  const Scene scene = load_obj(dir.write("disc.obj", text));
  EXPECT_EQ(scene.triangles.size() + scene.removed.total(), static_cast<std::size_t>(kCorners - 2));
  EXPECT_EQ(scene.removed.total(), 0u);
}

TEST(SceneObj, MissingFile) {
  TempDir dir;
  const auto path = dir.path() / "absent.obj";
  const std::string msg = error_message([&] { load_obj(path); });
  EXPECT_NE(msg.find(path.string() + ": cannot open the OBJ scene: no such file"), std::string::npos) << msg;
  // Through load_scene, a missing path is named too.
  const std::string msg2 = error_message([&] { load_scene(path.string()); });
  EXPECT_NE(msg2.find(path.string() + ": no such file"), std::string::npos) << msg2;
}

}  // namespace
}  // namespace sahbench
