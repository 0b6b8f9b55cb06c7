// Tree files (scenes/tree_file.h, docs/tree_format.md): a written tree reads back equal, and every way a
// file can be wrong (foreign, another version, truncated, counts out of range, another scene's, an
// invalid tree) is refused with an Error that names the file and why.

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "builders/registry.h"
#include "core/error.h"
#include "fuzz/fuzz_readers.h"
#include "scenes/procedural.h"
#include "scenes/tree_file.h"
#include "tests/scenes/temp_dir.h"
#include "tests/support/error_of.h"
#include "tests/support/test_scenes.h"

namespace sahbench {
namespace {

using test::error_of;

Bvh build(const std::string& builder, std::span<const Triangle> triangles,
          const ParamOverrides& params = {}) {
  const BuilderInfo& info = find_builder(builder);
  return info.build(BuildInput::from_triangles(triangles), resolve_params(info.name, info.params, params));
}

std::string read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void contains(const std::string& message, const std::string& part) {
  EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
}

class TreeFileTest : public ::testing::Test {
 protected:
  test::TempDir dir_;
  // Long triangles that overlap, so that the SBVH splits some of them.
  std::vector<Triangle> triangles_ = test::random_triangles(500, 7, 10.0f, 8.0f);
};

TEST_F(TreeFileTest, RoundTripGivesAnEqualTree) {
  // Binary, wide, and with repeated references (spatial splits).
  for (const auto& [builder, params] :
       std::vector<std::pair<std::string, ParamOverrides>>{{"binned_sah", {}},
                                                           {"wide_collapse", {{"arity", "8"}}},
                                                           {"wide_collapse", {{"arity", "4"}}},
                                                           {"sbvh", {}}}) {
    SCOPED_TRACE(builder);
    const Bvh bvh = build(builder, triangles_, params);
    if (builder == "sbvh") {
      ASSERT_GT(bvh.prim_refs.size(), triangles_.size()) << "no reference repeated";
    }
    const auto path = dir_.path() / (builder + ".sbt");
    write_tree_file(path, bvh, triangles_);
    EXPECT_EQ(std::filesystem::file_size(path), 64 + 32 * bvh.nodes.size() + 4 * bvh.prim_refs.size());
    const TreeFile file = read_tree_file(path);
    EXPECT_EQ(file.bvh, bvh);
    EXPECT_EQ(file.triangle_count, triangles_.size());
    EXPECT_EQ(file.scene_hash, triangle_hash(triangles_));
    EXPECT_EQ(load_tree_file(path, triangles_), bvh);
  }
}

TEST_F(TreeFileTest, HeaderIsLaidOutAsDocumented) {
  const Bvh bvh = build("binned_sah", triangles_);
  const auto path = dir_.path() / "t.sbt";
  write_tree_file(path, bvh, triangles_);
  const std::string bytes = read_bytes(path);
  ASSERT_GE(bytes.size(), 64u);
  EXPECT_EQ(bytes.substr(0, 8), "SAHBTREE");
  auto u32 = [&](std::size_t at) {
    uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(bytes[at + i]);
    return v;
  };
  auto u64 = [&](std::size_t at) { return uint64_t{u32(at)} | (uint64_t{u32(at + 4)} << 32); };
  EXPECT_EQ(u32(8), 1u);
  EXPECT_EQ(u32(12), 2u);
  EXPECT_EQ(u64(16), bvh.nodes.size());
  EXPECT_EQ(u64(24), bvh.prim_refs.size());
  EXPECT_EQ(u64(32), triangles_.size());
  EXPECT_EQ(u64(40), triangle_hash(triangles_));
  EXPECT_EQ(bytes.substr(48, 16), std::string(16, '\0'));
  // The root's first child index and counts, at offset 64 + 24.
  EXPECT_EQ(u32(64 + 24), bvh.nodes[0].first);
  EXPECT_EQ(u32(64 + 28), uint32_t{bvh.nodes[0].child_count} | (uint32_t{bvh.nodes[0].prim_count} << 16));
}

TEST_F(TreeFileTest, HashIsFnv1aOverTheCoordinateBytes) {
  // FNV-1a 64 of no bytes is its offset basis; of one triangle, the 36 little-endian bytes of its floats,
  // here checked against a byte-by-byte computation written out separately.
  EXPECT_EQ(triangle_hash({}), 0xcbf29ce484222325ull);
  const Triangle t{{1.0f, -2.0f, 0.5f}, {0.0f, -0.0f, 3.0f}, {1e-30f, 7.0f, -1e30f}};
  uint64_t expected = 0xcbf29ce484222325ull;
  for (const float c : {1.0f, -2.0f, 0.5f, 0.0f, -0.0f, 3.0f, 1e-30f, 7.0f, -1e30f}) {
    uint32_t bits = 0;
    std::memcpy(&bits, &c, 4);
    for (int i = 0; i < 4; ++i) expected = (expected ^ ((bits >> (8 * i)) & 0xFF)) * 0x100000001b3ull;
  }
  EXPECT_EQ(triangle_hash(std::vector<Triangle>{t}), expected);
  // Order and signed zeros matter: a reordered scene is another scene.
  const Triangle u{{0.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}};
  EXPECT_NE(triangle_hash(std::vector<Triangle>{t, u}), triangle_hash(std::vector<Triangle>{u, t}));
  Triangle z = u;
  z.v0.x = -0.0f;
  EXPECT_NE(triangle_hash(std::vector<Triangle>{z}), triangle_hash(std::vector<Triangle>{u}));
}

TEST_F(TreeFileTest, ForeignFileIsRefused) {
  const auto obj = dir_.write("scene.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string message = error_of([&] { read_tree_file(obj); });
  contains(message, obj.string());
  contains(message, "not a sahbench tree file");
  contains(error_of([&] { read_tree_file(dir_.write("empty.sbt", "")); }), "not a sahbench tree file");
  contains(error_of([&] { read_tree_file(dir_.path() / "no_such.sbt"); }), "no_such.sbt: cannot open");
  contains(error_of([&] { read_tree_file(dir_.path()); }), "it is a directory");
}

TEST_F(TreeFileTest, OtherVersionIsRefused) {
  const auto path = dir_.path() / "v.sbt";
  write_tree_file(path, build("binned_sah", triangles_), triangles_);
  std::string bytes = read_bytes(path);
  bytes[8] = 2;
  const std::string message = error_of([&] { read_tree_file(dir_.write("v2.sbt", bytes)); });
  contains(message, "v2.sbt");
  contains(message, "tree file version 2 is not supported (this build reads 1)");
}

TEST_F(TreeFileTest, TruncatedFileNamesExpectedAndActualSize) {
  const Bvh bvh = build("binned_sah", triangles_);
  const auto path = dir_.path() / "t.sbt";
  write_tree_file(path, bvh, triangles_);
  const std::string bytes = read_bytes(path);
  const std::size_t full = bytes.size();
  const std::string message =
      error_of([&] { read_tree_file(dir_.write("cut.sbt", bytes.substr(0, full - 3))); });
  contains(message, "cut.sbt: tree file is truncated");
  contains(message, std::to_string(full) + " bytes, the file has " + std::to_string(full - 3));
  contains(error_of([&] { read_tree_file(dir_.write("head.sbt", bytes.substr(0, 20))); }),
           "expected at least the 64-byte header, found 20 bytes");
  contains(error_of([&] { read_tree_file(dir_.write("long.sbt", bytes + "xy")); }),
           "has 2 bytes after the end");
}

TEST_F(TreeFileTest, CountsOutOfRangeAreRefused) {
  const auto path = dir_.path() / "t.sbt";
  write_tree_file(path, build("binned_sah", triangles_), triangles_);
  const std::string good = read_bytes(path);
  auto with = [&](std::size_t at, std::string value) {
    std::string b = good;
    b.replace(at, value.size(), value);
    return dir_.write("bad.sbt", b);
  };
  contains(error_of([&] { read_tree_file(with(12, std::string("\x03\0\0\0", 4))); }),
           "arity 3 is out of range");
  contains(error_of([&] { read_tree_file(with(16, std::string(8, '\0'))); }), "node count 0 is out of range");
  // 2^40 nodes: refused by the count, before any allocation or size comparison.
  contains(error_of([&] { read_tree_file(with(16, std::string("\0\0\0\0\0\x01\0\0", 8))); }),
           "node count 1099511627776 is out of range");
  contains(error_of([&] { read_tree_file(with(24, std::string("\0\0\0\0\0\x01\0\0", 8))); }),
           "reference count 1099511627776 is out of range");
  contains(error_of([&] { read_tree_file(with(60, "x")); }), "header byte 60 is reserved");
  // Counts in range but larger than the file: truncated.
  contains(error_of([&] { read_tree_file(with(16, std::string("\0\0\0\x01\0\0\0\0", 8))); }),
           "tree file is truncated");
}

TEST_F(TreeFileTest, TreeOfAnotherSceneIsRefusedNamingBoth) {
  const auto path = dir_.path() / "other.sbt";
  write_tree_file(path, build("binned_sah", triangles_), triangles_);
  // Same count, one coordinate moved: another scene.
  std::vector<Triangle> moved = triangles_;
  moved[123].v1.x += 0.25f;
  const std::string message = error_of([&] { load_tree_file(path, moved); });
  contains(message, "tree file " + path.string() + " was built for a scene with hash " +
                        hash_text(triangle_hash(triangles_)) + " and 500 triangles, this scene has hash " +
                        hash_text(triangle_hash(moved)) + " and 500 triangles");
  // Another count.
  const std::vector<Triangle> fewer(triangles_.begin(), triangles_.begin() + 499);
  contains(error_of([&] { load_tree_file(path, fewer); }),
           "this scene has hash " + hash_text(triangle_hash(fewer)) + " and 499 triangles");
}

TEST_F(TreeFileTest, InvalidTreeIsRefusedWithTheValidatorsMessage) {
  Bvh bvh = build("binned_sah", triangles_);
  // A leaf that drops a reference: that triangle is no longer in the tree.
  for (Node& n : bvh.nodes)
    if (n.is_leaf() && n.prim_count > 1) {
      --n.prim_count;
      break;
    }
  const auto path = dir_.path() / "invalid.sbt";
  write_tree_file(path, bvh, triangles_);
  const std::string message = error_of([&] { load_tree_file(path, triangles_); });
  contains(message, path.string() + ": the tree fails validation:");
  contains(message, "not referenced");
  // A child index past the end is caught by the validator, not read out of bounds.
  Bvh broken = build("binned_sah", triangles_);
  broken.nodes[0].first = static_cast<uint32_t>(broken.nodes.size());
  write_tree_file(path, broken, triangles_);
  contains(error_of([&] { load_tree_file(path, triangles_); }), "the tree fails validation");
}

TEST_F(TreeFileTest, WritingToAFolderOrAMissingFolderIsAnError) {
  const Bvh bvh = build("binned_sah", triangles_);
  contains(error_of([&] { write_tree_file(dir_.path(), bvh, triangles_); }), "is a directory");
  contains(error_of([&] { write_tree_file(dir_.path() / "none" / "t.sbt", bvh, triangles_); }),
           "cannot write the tree file");
}

TEST(TreeFileFuzzSeeds, ValidSeedLoadsAgainstItsScene) {
  // The fuzzer's seeds are trees of its scene, so that mutations of them reach the validator; a seed that
  // the scene check refused would only exercise the header.
  const Scene scene = generate_procedural(fuzz::kTreeFileFuzzScene);
  const auto folder = std::filesystem::path(SAHBENCH_SOURCE_DIR) / "fuzz" / "corpus" / "tree_file";
  std::size_t loaded = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.path().filename().string().rfind("valid_", 0) == 0) {
      SCOPED_TRACE(entry.path().string());
      EXPECT_NO_THROW(load_tree_file(entry.path(), scene.triangles));
      ++loaded;
    }
  EXPECT_GT(loaded, 0u);
}

}  // namespace
}  // namespace sahbench
