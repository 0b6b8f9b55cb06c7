#pragma once
// Tree files: a tree of the common format (core/bvh.h) saved for one scene, so that a tree built
// elsewhere, by another program or language, is measured here like any builder's ("bring your own
// tree"). The byte layout is specified in docs/tree_format.md: a 64-byte little-endian header (magic,
// version, arity, counts, the scene's triangle hash), the nodes (32 bytes each), then the references.
//
// Files are read here, beside the scene loaders, because the layers below (core, builders, traversal)
// must not know about files; the harness registers the `file` builder that calls load_tree_file.

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>

#include "core/bvh.h"
#include "core/fnv1a.h"
#include "core/triangle.h"

namespace sahbench {

/// The 8 bytes every tree file starts with.
inline constexpr char kTreeFileMagic[8] = {'S', 'A', 'H', 'B', 'T', 'R', 'E', 'E'};
/// The format version written, and the only one read.
inline constexpr uint32_t kTreeFileVersion = 1;
/// Bytes of the header, of one node and of one reference in a file.
inline constexpr uint64_t kTreeFileHeaderBytes = 64;
inline constexpr uint64_t kTreeFileNodeBytes = 32;
inline constexpr uint64_t kTreeFileRefBytes = 4;

/// The scene's identity in a tree file: FNV-1a 64 over the IEEE-754 binary32 bit patterns of every
/// triangle's nine coordinates (v0.x, v0.y, v0.z, v1.x, ..., v2.z), each as 4 little-endian bytes, in
/// scene order: the triangles as loaded, after invalid ones are removed. A tree's prim_refs index these
/// triangles, so the same triangles in another order are another scene.
uint64_t triangle_hash(std::span<const Triangle> triangles);

/// What a tree file's header says.
struct TreeFileHeader {
  uint32_t version = kTreeFileVersion;
  uint32_t arity = 2;
  uint64_t node_count = 0;
  uint64_t ref_count = 0;
  uint64_t triangle_count = 0;
  uint64_t scene_hash = 0;
};

/// A tree file's contents: the tree, and the scene it was built for.
struct TreeFile {
  Bvh bvh;
  uint64_t triangle_count = 0;
  uint64_t scene_hash = 0;
};

/// Writes `bvh`, built for `triangles`, to `path` (replacing it). A directory or an unwritable path is an
/// Error naming it. The tree is written as it is; load_tree_file checks it when it is read.
void write_tree_file(const std::filesystem::path& path, const Bvh& bvh, std::span<const Triangle> triangles);

/// The header of the tree file at `path`, checked: magic, version, arity 2, 4 or 8, node and reference
/// counts in range (1 to 2^32 nodes, at most 2^32 references and triangles), reserved bytes zero, and
/// the file's size what the counts make (as read_tree_file says). Each failure is an Error naming the
/// file and why.
TreeFileHeader read_tree_file_header(const std::filesystem::path& path);

/// The whole file: its header checked as read_tree_file_header does, and its size exactly what the
/// header's counts make (a shorter file is "truncated", naming the expected and the actual size; a longer
/// one has trailing bytes). The tree's structure is not checked here.
TreeFile read_tree_file(const std::filesystem::path& path);

/// Throws unless a tree file's recorded scene (hash and triangle count, from its header) is `triangles`,
/// with the message check_tree_for_scene gives.
void check_tree_file_scene(uint64_t scene_hash, uint64_t triangle_count, const std::filesystem::path& path,
                           std::span<const Triangle> triangles);

/// The tree of `file`, read from `path`, if it is one for `triangles`: the file's triangle count and hash
/// must be the scene's ("tree file P was built for a scene with hash H and N triangles, this scene
/// has ..."), and the tree must pass the validator (core/validate.h), whose first errors the Error quotes.
Bvh check_tree_for_scene(TreeFile file, const std::filesystem::path& path,
                         std::span<const Triangle> triangles);

/// read_tree_file then check_tree_for_scene: the tree at `path`, checked against `triangles`.
Bvh load_tree_file(const std::filesystem::path& path, std::span<const Triangle> triangles);

/// "0x" and 16 hex digits: how messages and `sahbench build --save` show a hash.
std::string hash_text(uint64_t hash);

}  // namespace sahbench
