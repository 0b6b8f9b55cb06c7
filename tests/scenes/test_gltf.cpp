#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "scenes/gltf_loader.h"
#include "scenes/load.h"
#include "tests/scenes/gltf_bytes.h"
#include "tests/scenes/temp_dir.h"

namespace sahbench {
namespace {

using test::Bytes;
using test::data_uri;
using test::error_message;
using test::TempDir;

// A unit quad in z = 0: four float positions (48 bytes) then six uint16 indices (12 bytes).
Bytes quad_buffer() {
  Bytes b;
  b.vec3(0, 0, 0).vec3(1, 0, 0).vec3(1, 1, 0).vec3(0, 1, 0);
  for (uint16_t i : {0, 1, 2, 0, 2, 3}) b.u16(i);
  return b;
}

// The quad mesh, used by two nodes: node 0 translates by (10, 0, 0) with a matrix; node 1 rotates by
// 90 degrees about z and holds node 2, which scales by 2 and uses the mesh again.
std::string quad_gltf(const std::string& buffer_uri, std::size_t buffer_size,
                      const std::string& position_accessor_extra = "",
                      const std::string& position_count = "4") {
  return R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0, 1]}],
  "nodes": [
    {"mesh": 0, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 10,0,0,1]},
    {"rotation": [0, 0, 0.7071067811865476, 0.7071067811865476], "children": [2]},
    {"mesh": 0, "scale": [2, 2, 2]}
  ],
  "meshes": [{"name": "quad", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "buffers": [{"uri": ")" +
         buffer_uri + R"(", "byteLength": )" + std::to_string(buffer_size) + R"(}],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 48},
    {"buffer": 0, "byteOffset": 48, "byteLength": 12}
  ],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": )" +
         position_count + R"(, "type": "VEC3")" + position_accessor_extra + R"(},
    {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}
  ]
})";
}

void replace_once(std::string& s, const std::string& from, const std::string& to) {
  const std::size_t at = s.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  s.replace(at, from.size(), to);
}

void expect_near(const Vec3& a, const Vec3& b) {
  EXPECT_NEAR(a.x, b.x, 1e-6f);
  EXPECT_NEAR(a.y, b.y, 1e-6f);
  EXPECT_NEAR(a.z, b.z, 1e-6f);
}

TEST(SceneGltf, EmbeddedBufferNodeTransformsAndReusedMesh) {
  TempDir dir;
  const Bytes buffer = quad_buffer();
  const Scene scene = load_gltf(dir.write("quad.gltf", quad_gltf(data_uri(buffer), buffer.size())), false);
  EXPECT_EQ(scene.removed.total(), 0u);
  ASSERT_EQ(scene.triangles.size(), 4u);  // the mesh is placed once per node that uses it
  // Node 0: translated.
  EXPECT_EQ(scene.triangles[0], (Triangle{{10, 0, 0}, {11, 0, 0}, {11, 1, 0}}));
  EXPECT_EQ(scene.triangles[1], (Triangle{{10, 0, 0}, {11, 1, 0}, {10, 1, 0}}));
  // Node 1 -> node 2: scaled by 2, then rotated by 90 degrees about z: (x, y) -> (-2y, 2x).
  expect_near(scene.triangles[2].v0, {0, 0, 0});
  expect_near(scene.triangles[2].v1, {0, 2, 0});
  expect_near(scene.triangles[2].v2, {-2, 2, 0});
  expect_near(scene.triangles[3].v2, {-2, 0, 0});
}

TEST(SceneGltf, CameraAndPointLightAreReadWithTheirNodeTransforms) {
  TempDir dir;
  const Bytes buffer = quad_buffer();
  std::string json = quad_gltf(data_uri(buffer), buffer.size());
  // A camera node at (0, 0, 5) turned 90 degrees about y (looking down -x), and a light node at (1, 2, 3).
  replace_once(json, R"("scenes": [{"nodes": [0, 1]}])", R"("scenes": [{"nodes": [0, 1, 3, 4]}])");
  replace_once(json, R"({"mesh": 0, "scale": [2, 2, 2]}
  ])",
               R"({"mesh": 0, "scale": [2, 2, 2]},
    {"camera": 0, "translation": [0, 0, 5], "rotation": [0, 0.7071067811865476, 0, 0.7071067811865476]},
    {"translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}}
  ],
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}}],
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point"}]}})");
  const Scene scene = load_gltf(dir.write("camera.gltf", json), false);
  ASSERT_TRUE(scene.camera.has_value());
  expect_near(scene.camera->position, {0, 0, 5});
  expect_near(scene.camera->forward, {-1, 0, 0});
  expect_near(scene.camera->up, {0, 1, 0});
  EXPECT_FLOAT_EQ(scene.camera->yfov, 0.5f);
  ASSERT_EQ(scene.lights.size(), 1u);
  expect_near(scene.lights[0], {1, 2, 3});
  EXPECT_EQ(scene.triangles.size(), 4u);
}

TEST(SceneGltf, NoCameraOrLightsWhenTheFileHasNone) {
  TempDir dir;
  const Bytes buffer = quad_buffer();
  const Scene scene = load_gltf(dir.write("quad.gltf", quad_gltf(data_uri(buffer), buffer.size())), false);
  EXPECT_FALSE(scene.camera.has_value());
  EXPECT_TRUE(scene.lights.empty());
}

TEST(SceneGltf, SeparateBinWithStrideOffsetUint8IndicesAndMissingImage) {
  TempDir dir;
  // Interleaved: 4 bytes of padding, then per vertex xyz and 4 more bytes (stride 16).
  Bytes b;
  b.u32(0xDEADBEEF);
  const float xyz[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  for (const auto& p : xyz) b.vec3(p[0], p[1], p[2]).u32(0xFFFFFFFF);
  for (uint8_t i : {0, 1, 2, 0, 2, 3}) b.u8(i);
  dir.write("sub/quad.bin", b.str());
  const std::string json = R"({
    "asset": {"version": "2.0"},
    "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
    "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
    "textures": [{"source": 0}],
    "images": [{"uri": "missing_texture.png"}],
    "buffers": [{"uri": "quad.bin", "byteLength": )" +
                           std::to_string(b.size()) + R"(}],
    "bufferViews": [
      {"buffer": 0, "byteOffset": 0, "byteLength": 68, "byteStride": 16},
      {"buffer": 0, "byteOffset": 68, "byteLength": 6}
    ],
    "accessors": [
      {"bufferView": 0, "byteOffset": 4, "componentType": 5126, "count": 4, "type": "VEC3"},
      {"bufferView": 1, "componentType": 5121, "count": 6, "type": "SCALAR"}
    ]
  })";
  const Scene scene = load_gltf(dir.write("sub/quad.gltf", json), false);
  ASSERT_EQ(scene.triangles.size(), 2u);
  EXPECT_EQ(scene.triangles[1], (Triangle{{0, 0, 0}, {1, 1, 0}, {0, 1, 0}}));
}

// A GLB container: 12-byte header, a JSON chunk padded with spaces, a BIN chunk padded with zeros.
std::string glb(std::string json, Bytes bin) {
  while (json.size() % 4 != 0) json += ' ';
  bin.pad_to(4);
  Bytes out;
  out.u32(0x46546C67).u32(2).u32(static_cast<uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
  out.u32(static_cast<uint32_t>(json.size())).u32(0x4E4F534A);
  std::string s = out.str() + json;
  Bytes chunk;
  chunk.u32(static_cast<uint32_t>(bin.size())).u32(0x004E4942);
  return s + chunk.str() + bin.str();
}

TEST(SceneGltf, GlbWithStripFanNonIndexedAndLinesWithoutScenes) {
  TempDir dir;
  Bytes b;
  b.vec3(0, 0, 0).vec3(1, 0, 0).vec3(0, 1, 0).vec3(1, 1, 0).vec3(0.5f, 2, 0);  // 60 bytes
  for (uint32_t i : {0, 1, 2, 3, 4}) b.u32(i);                                 // 20 bytes at 60
  const std::string json = R"({
    "asset": {"version": "2.0"},
    "nodes": [{"mesh": 0, "children": [1]}, {"mesh": 1}],
    "meshes": [
      {"primitives": [
        {"attributes": {"POSITION": 0}, "indices": 1, "mode": 5},
        {"attributes": {"POSITION": 0}, "indices": 2, "mode": 6},
        {"attributes": {"POSITION": 3}}
      ]},
      {"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 1}]}
    ],
    "buffers": [{"byteLength": 80}],
    "bufferViews": [{"buffer": 0, "byteLength": 60}, {"buffer": 0, "byteOffset": 60, "byteLength": 20}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 5, "type": "VEC3"},
      {"bufferView": 1, "componentType": 5125, "count": 4, "type": "SCALAR"},
      {"bufferView": 1, "componentType": 5125, "count": 5, "type": "SCALAR"},
      {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}
    ]
  })";
  const Scene scene = load_gltf(dir.write("modes.glb", glb(json, b)), true);
  EXPECT_EQ(scene.removed.total(), 0u);
  ASSERT_EQ(scene.triangles.size(), 2u + 3u + 1u);  // strip, fan, non-indexed; lines skipped
  // Strip triangle 1 keeps the winding: (p1, p3, p2).
  EXPECT_EQ(scene.triangles[1], (Triangle{{1, 0, 0}, {1, 1, 0}, {0, 1, 0}}));
  // Fan triangles are (p_i+1, p_i+2, p_0).
  EXPECT_EQ(scene.triangles[2], (Triangle{{1, 0, 0}, {0, 1, 0}, {0, 0, 0}}));
  EXPECT_EQ(scene.triangles[5], (Triangle{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
}

TEST(SceneGltf, SparsePositionsOverrideTheBase) {
  TempDir dir;
  Bytes b = quad_buffer();  // 60 bytes
  b.u16(1).u16(0);          // sparse index 1 (and padding) at 60
  b.vec3(5, 0, 0);          // its new value at 64
  std::string json =
      quad_gltf(data_uri(b), b.size(),
                R"(, "sparse": {"count": 1, "indices": {"bufferView": 2, "componentType": 5123},
                                   "values": {"bufferView": 3}})");
  replace_once(json, R"({"buffer": 0, "byteOffset": 48, "byteLength": 12})",
               R"({"buffer": 0, "byteOffset": 48, "byteLength": 12},
                  {"buffer": 0, "byteOffset": 60, "byteLength": 2},
                  {"buffer": 0, "byteOffset": 64, "byteLength": 12})");
  const Scene scene = load_gltf(dir.write("sparse.gltf", json), false);
  ASSERT_EQ(scene.triangles.size(), 4u);
  EXPECT_EQ(scene.triangles[0].v1, (Vec3{15, 0, 0}));
}

TEST(SceneGltf, InvalidTrianglesAreCounted) {
  TempDir dir;
  Bytes b;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  b.vec3(0, 0, 0).vec3(1, 0, 0).vec3(0, 1, 0).vec3(nan, 0, 0);       // 48 bytes
  for (uint16_t i : {0, 1, 2, 0, 1, 7, 0, 1, 3, 0, 0, 2}) b.u16(i);  // valid, bad index, NaN, zero area
  std::string json = quad_gltf(data_uri(b), b.size());
  replace_once(json, R"("byteLength": 12)", R"("byteLength": 24)");
  replace_once(json, R"("count": 6)", R"("count": 12)");
  const Scene scene = load_gltf(dir.write("bad.gltf", json), false);
  // Two nodes use the mesh, so each kind of problem is counted twice.
  EXPECT_EQ(scene.triangles.size(), 2u);
  EXPECT_EQ(scene.removed.bad_index, 2u);
  EXPECT_EQ(scene.removed.non_finite, 2u);
  EXPECT_EQ(scene.removed.zero_area, 2u);
}

// Each case edits the valid quad file; every one must fail with an Error naming the file.
TEST(SceneGltf, MalformedFilesThrowNamingTheFile) {
  TempDir dir;
  const Bytes buffer = quad_buffer();
  const std::string good = quad_gltf(data_uri(buffer), buffer.size());
  auto edited = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    replace_once(s, from, to);
    return s;
  };
  const std::pair<std::string, std::string> cases[] = {
      // Accessor reaches past its bufferView.
      {quad_gltf(data_uri(buffer), buffer.size(), "", "5"), "exceed bufferView 0"},
      // Accessor offset past its bufferView.
      {quad_gltf(data_uri(buffer), buffer.size(), R"(, "byteOffset": 4000000000)"), "exceed bufferView 0"},
      // bufferView past the end of its buffer.
      {edited(R"("byteOffset": 48, "byteLength": 12)", R"("byteOffset": 50, "byteLength": 12)"),
       "bufferView 1 (offset 50, length 12) exceeds its buffer of 60 bytes"},
      // Stride so large that the last element is outside.
      {edited(R"("byteOffset": 0, "byteLength": 48})",
              R"("byteOffset": 0, "byteLength": 48, "byteStride": 252})"),
       "exceed bufferView 0"},
      // Non-float positions.
      {edited(R"("componentType": 5126)", R"("componentType": 5123)"),
       "mesh 0 ('quad') primitive 0: POSITION"},
      // Index accessor that does not exist (tinygltf itself rejects this one).
      {edited(R"("indices": 1)", R"("indices": 9)"), "invalid glTF file"},
      // Index count not a multiple of 3.
      {edited(R"("count": 6)", R"("count": 5)"), "not a multiple of 3"},
      // bufferView index out of range (also rejected by tinygltf).
      {edited(R"("bufferView": 1,)", R"("bufferView": 7,)"), "invalid glTF file"},
      // A cycle in the node graph.
      {edited(R"("children": [2])", R"("children": [2, 1])"), "reached twice"},
      // A child that does not exist.
      {edited(R"("children": [2])", R"("children": [12])"), "node index 12 out of range"},
      // Broken JSON.
      {good.substr(0, good.size() / 2), "invalid glTF"},
      // Rotation with the wrong number of elements.
      {edited(R"("rotation": [0, 0, 0.7071067811865476, 0.7071067811865476])", R"("rotation": [0, 0, 1])"),
       "rotation must have 4 elements"},
  };
  for (const auto& [json, expected] : cases) {
    const auto path = dir.write("broken.gltf", json);
    const std::string msg = error_message([&] { load_gltf(path, false); });
    EXPECT_NE(msg.find(path.string()), std::string::npos) << msg;
    EXPECT_NE(msg.find(expected), std::string::npos) << "expected '" << expected << "' in: " << msg;
  }
}

// An accessor without a bufferView is zeros that no bytes of the file back; its count is bounded before
// anything is allocated (an out-of-memory of the glTF fuzz target: 4e9 positions asked for 45 GiB;
// fuzz/regressions/gltf).
TEST(SceneGltf, AccessorWithoutBufferViewIsBounded) {
  TempDir dir;
  const auto path = dir.write("unbacked.gltf", R"({"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}],
      "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
      "accessors": [{"componentType": 5126, "count": 4000000000, "type": "VEC3"}]})");
  const std::string msg = error_message([&] { load_gltf(path, false); });
  EXPECT_NE(
      msg.find("unbacked.gltf: mesh 0 primitive 0: accessor without a bufferView has 4000000000 elements"),
      std::string::npos)
      << msg;
}

// A buffer whose uri names a directory is refused by name; tinygltf alone sized it as 2^63 - 1 bytes and
// allocated that (a crash of the gltf fuzz target; fuzz/regressions/gltf).
TEST(SceneGltf, BufferUriNamingADirectoryIsAnError) {
  TempDir dir;
  const Bytes buffer = quad_buffer();
  std::filesystem::create_directories(dir.path() / "sub");
  const auto path = dir.write("dir_buffer.gltf", quad_gltf("sub", buffer.size()));
  const std::string msg = error_message([&] { load_gltf(path, false); });
  EXPECT_NE(msg.find("dir_buffer.gltf: invalid glTF file"), std::string::npos) << msg;
  EXPECT_NE(msg.find("is not a regular file"), std::string::npos) << msg;
}

TEST(SceneGltf, MissingBinAndMissingFileAndTruncatedGlb) {
  TempDir dir;
  const auto gltf = dir.write("nobin.gltf", quad_gltf("absent.bin", 60));
  std::string msg = error_message([&] { load_gltf(gltf, false); });
  EXPECT_NE(msg.find(gltf.string()), std::string::npos) << msg;

  const auto absent = dir.path() / "absent.glb";
  msg = error_message([&] { load_scene(absent.string()); });
  EXPECT_NE(msg.find(absent.string()), std::string::npos) << msg;

  // A GLB that loads whole, cut short inside its binary chunk.
  const Bytes b = quad_buffer();
  std::string bytes = glb(quad_gltf("", b.size()), b);
  EXPECT_FALSE(load_gltf(dir.write("whole.glb", bytes), true).triangles.empty());
  bytes.resize(bytes.size() - 30);
  const auto cut = dir.write("cut.glb", bytes);
  msg = error_message([&] { load_gltf(cut, true); });
  EXPECT_NE(msg.find(cut.string()), std::string::npos) << msg;
  EXPECT_NE(msg.find("invalid GLB file"), std::string::npos) << msg;
}

TEST(SceneGltf, LoadSceneDispatchesGltfAndGlb) {
  TempDir dir;
  const Bytes buffer = quad_buffer();
  const auto path = dir.write("Quad.GLTF", quad_gltf(data_uri(buffer), buffer.size()));
  const Scene scene = load_scene(path.string());
  EXPECT_EQ(scene.triangles.size(), 4u);
  EXPECT_EQ(scene.source, path.string());
}

}  // namespace
}  // namespace sahbench
