#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "scenes/load.h"
#include "scenes/ply_loader.h"
#include "tests/scenes/temp_dir.h"

namespace sahbench {
namespace {

using test::error_message;
using test::TempDir;

// A unit square (a quad face) and one extra triangle: 3 triangles after fan triangulation.
constexpr const char* kAsciiPly =
    "ply\n"
    "format ascii 1.0\n"
    "comment a quad and a triangle\n"
    "element vertex 5\n"
    "property float x\n"
    "property float y\n"
    "property float z\n"
    "property uchar red\n"
    "element face 2\n"
    "property list uchar int vertex_indices\n"
    "end_header\n"
    "0 0 0 255\n"
    "1 0 0 0\n"
    "1 1 0 0\n"
    "0 1 0 0\n"
    "0 0 2 7\n"
    "4 0 1 2 3\n"
    "3 0 1 4\n";

const std::vector<Triangle> kExpected{
    {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}},
    {{0, 0, 0}, {1, 1, 0}, {0, 1, 0}},
    {{0, 0, 0}, {1, 0, 0}, {0, 0, 2}},
};

std::string ascii_ply(const std::string& vertex_lines, int vertex_count, const std::string& face_lines,
                      int face_count) {
  return "ply\nformat ascii 1.0\nelement vertex " + std::to_string(vertex_count) +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
         std::to_string(face_count) + "\nproperty list uchar int vertex_indices\nend_header\n" +
         vertex_lines + face_lines;
}

// Appends `v` in the given byte order.
template <typename T>
void put(std::string& out, T v, bool big_endian) {
  auto bytes = std::bit_cast<std::array<char, sizeof(T)>>(v);
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(bytes.begin(), bytes.end());
  out.append(bytes.data(), bytes.size());
}

// The same geometry as kAsciiPly in binary, with double coordinates, extra scalar and list properties
// in both elements, an extra element between them, and ushort/uint list types.
std::string binary_ply(bool big_endian) {
  std::string s = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\n"
                  "element vertex 5\n"
                  "property short id\n"
                  "property double x\n"
                  "property double y\n"
                  "property double z\n"
                  "property list uchar float uv\n"
                  "element edge 1\n"
                  "property int vertex1\n"
                  "property int vertex2\n"
                  "element face 2\n"
                  "property uchar flags\n"
                  "property list ushort uint vertex_indices\n"
                  "end_header\n";
  const double xyz[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 2}};
  for (int i = 0; i < 5; ++i) {
    put<int16_t>(s, static_cast<int16_t>(i), big_endian);
    for (double c : xyz[i]) put<double>(s, c, big_endian);
    put<uint8_t>(s, 2, big_endian);
    put<float>(s, 0.5f, big_endian);
    put<float>(s, 0.25f, big_endian);
  }
  put<int32_t>(s, 0, big_endian);
  put<int32_t>(s, 1, big_endian);
  put<uint8_t>(s, 9, big_endian);
  put<uint16_t>(s, 4, big_endian);
  for (uint32_t i : {0u, 1u, 2u, 3u}) put<uint32_t>(s, i, big_endian);
  put<uint8_t>(s, 9, big_endian);
  put<uint16_t>(s, 3, big_endian);
  for (uint32_t i : {0u, 1u, 4u}) put<uint32_t>(s, i, big_endian);
  return s;
}

TEST(ScenePly, AsciiQuadIsFanTriangulated) {
  TempDir dir;
  const Scene scene = load_ply(dir.write("a.ply", kAsciiPly));
  EXPECT_EQ(scene.triangles, kExpected);
  EXPECT_EQ(scene.removed.total(), 0u);
  EXPECT_EQ(scene.source, (dir.path() / "a.ply").string());
}

TEST(ScenePly, BinaryLittleEndian) {
  TempDir dir;
  const Scene scene = load_ply(dir.write("le.ply", binary_ply(false)));
  EXPECT_EQ(scene.triangles, kExpected);
}

TEST(ScenePly, BinaryBigEndian) {
  TempDir dir;
  const Scene scene = load_ply(dir.write("be.ply", binary_ply(true)));
  EXPECT_EQ(scene.triangles, kExpected);
}

TEST(ScenePly, CrLfHeaderAndVertexIndexNameAndFacesFirst) {
  TempDir dir;
  const std::string text =
      "ply\r\nformat ascii 1.0\r\nelement face 1\r\nproperty list uchar uint vertex_index\r\n"
      "element vertex 3\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\nend_header\r\n"
      "3 0 1 2\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n";
  const Scene scene = load_ply(dir.write("crlf.ply", text));
  ASSERT_EQ(scene.triangles.size(), 1u);
  EXPECT_EQ(scene.triangles[0], (Triangle{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
}

TEST(ScenePly, InvalidTrianglesAreCountedNotLoaded) {
  TempDir dir;
  const std::string text = ascii_ply("0 0 0\n1 0 0\n0 1 0\nnan 0 0\n2 0 0\n", 5,
                                     "3 0 1 2\n"   // valid
                                     "3 0 1 5\n"   // index past the end
                                     "3 0 -1 2\n"  // negative index
                                     "3 0 1 3\n"   // NaN vertex
                                     "3 0 1 4\n"   // collinear: zero area
                                     "3 0 0 2\n"   // repeated vertex: zero area
                                     "2 0 1\n",    // two-vertex polygon: zero area
                                     7);
  const Scene scene = load_ply(dir.write("bad.ply", text));
  EXPECT_EQ(scene.triangles.size(), 1u);
  EXPECT_EQ(scene.removed.bad_index, 2u);
  EXPECT_EQ(scene.removed.non_finite, 1u);
  EXPECT_EQ(scene.removed.zero_area, 3u);
}

TEST(ScenePly, OverflowingDoubleBecomesNonFinite) {
  TempDir dir;
  // 1e300 overflows float, 1e999 overflows double; 1e-999 underflows to zero and stays valid.
  const Scene scene =
      load_ply(dir.write("big.ply", ascii_ply("0 0 0\n1 0 0\n0 1e300 0\n1e999 0 0\n0 1 1e-999\n", 5,
                                              "3 0 1 2\n3 0 1 3\n3 0 1 4\n", 3)));
  EXPECT_EQ(scene.removed.non_finite, 2u);
  ASSERT_EQ(scene.triangles.size(), 1u);
  EXPECT_EQ(scene.triangles[0].v2, (Vec3{0, 1, 0}));
}

TEST(ScenePly, TruncatedAsciiNamesFileAndCounts) {
  TempDir dir;
  const auto path = dir.write("short.ply", ascii_ply("0 0 0\n1 0 0\n", 4, "", 1));
  const std::string msg = error_message([&] { load_ply(path); });
  EXPECT_NE(msg.find(path.string()), std::string::npos) << msg;
  EXPECT_NE(msg.find("truncated: expected 4 vertices, file ends after 2"), std::string::npos) << msg;
}

TEST(ScenePly, TruncatedBinaryFaces) {
  TempDir dir;
  std::string bytes = binary_ply(false);
  bytes.resize(bytes.size() - 5);  // cut into the last face
  const auto path = dir.write("cut.ply", bytes);
  const std::string msg = error_message([&] { load_ply(path); });
  EXPECT_NE(msg.find("cut.ply: truncated: expected 2 faces, file ends after 1"), std::string::npos) << msg;
}

TEST(ScenePly, HugeListCountIsTruncationNotACrash) {
  TempDir dir;
  std::string bytes = binary_ply(false);
  // Replace the first face's count (ushort 4, right after the last vertex, the edge and a flags byte)
  // with 65535: the reader must run out of file, not out of memory or bounds.
  const std::size_t header_end = bytes.find("end_header\n") + 11;
  const std::size_t count_at = header_end + 5 * (2 + 24 + 1 + 8) + 8 + 1;
  bytes[count_at] = '\xff';
  bytes[count_at + 1] = '\xff';
  const auto path = dir.write("huge.ply", bytes);
  const std::string msg = error_message([&] { load_ply(path); });
  EXPECT_NE(msg.find("truncated: expected 2 faces, file ends after 0"), std::string::npos) << msg;
}

TEST(ScenePly, MalformedHeadersNameFileAndProblem) {
  TempDir dir;
  const std::pair<std::string, std::string> cases[] = {
      {"not ply\n", "not a PLY file"},
      {"ply\nformat ascii 1.0\nelement vertex 3\n", "no 'end_header'"},
      {"ply\nformat utf8 1.0\nend_header\n", "unknown format 'utf8'"},
      {"ply\nformat ascii 1.0\nproperty float x\nend_header\n", "'property' before any 'element'"},
      {"ply\nformat ascii 1.0\nelement vertex 3\nproperty real x\nend_header\n", "unknown type 'real'"},
      {"ply\nformat ascii 1.0\nelement vertex abc\nend_header\n", "bad element count 'abc'"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n",
       "no 'face' element"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "element face 0\nproperty list uchar int vertex_indices\nend_header\n",
       "no 'z' property"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 0\nproperty list uchar int colors\nend_header\n",
       "no 'vertex_indices'"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 0\nproperty list float int vertex_indices\nend_header\n",
       "list count type must be an integer"},
      {"ply\nformat ascii 1.0\nbogus line\nend_header\n", "unknown keyword 'bogus'"},
  };
  for (const auto& [text, expected] : cases) {
    const auto path = dir.write("h.ply", text);
    const std::string msg = error_message([&] { load_ply(path); });
    EXPECT_NE(msg.find(path.string()), std::string::npos) << msg;
    EXPECT_NE(msg.find(expected), std::string::npos) << "expected '" << expected << "' in: " << msg;
  }
}

TEST(ScenePly, BadAsciiNumber) {
  TempDir dir;
  const auto path = dir.write("num.ply", ascii_ply("0 0 0\n1 x 0\n0 1 0\n", 3, "3 0 1 2\n", 1));
  const std::string msg = error_message([&] { load_ply(path); });
  EXPECT_NE(msg.find("num.ply: line 11: 'x' is not a number"), std::string::npos) << msg;
}

// An element without properties holds no bytes: a count near 2^64 is skipped at once, not looped over
// (a timeout of the PLY fuzz target; fuzz/regressions/ply).
TEST(ScenePly, ElementWithoutPropertiesHoldsNoBytes) {
  TempDir dir;
  const auto path =
      dir.write("empty_element.ply",
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                "property float z\nelement junk 18446744073709551615\nelement face 1\n"
                "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  const Scene scene = load_ply(path);
  const std::vector<Triangle> expected{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}};
  EXPECT_EQ(scene.triangles, expected);
}

TEST(ScenePly, MissingFile) {
  TempDir dir;
  const auto path = dir.path() / "absent.ply";
  const std::string msg = error_message([&] { load_ply(path); });
  EXPECT_NE(msg.find(path.string() + ": cannot open file"), std::string::npos) << msg;
}

TEST(ScenePly, LoadSceneDispatchesOnUpperCaseExtension) {
  TempDir dir;
  const auto path = dir.write("A.PLY", kAsciiPly);
  const Scene scene = load_scene(path.string());
  EXPECT_EQ(scene.triangles, kExpected);
  EXPECT_EQ(scene.name, path.string());
}

}  // namespace
}  // namespace sahbench
