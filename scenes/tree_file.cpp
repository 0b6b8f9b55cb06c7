#include "scenes/tree_file.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "core/text_file.h"
#include "core/validate.h"

namespace sahbench {
namespace {

// Largest node, reference and triangle counts a file may declare: node indices, reference offsets and
// triangle indices are 32-bit in the common format (core/bvh.h).
constexpr uint64_t kMaxNodes = uint64_t{1} << 32;
constexpr uint64_t kMaxRefs = uint64_t{1} << 32;
constexpr uint64_t kMaxTriangles = uint64_t{1} << 32;
// Validator errors quoted in the Error of a refused tree; the report holds up to a few dozen.
constexpr std::size_t kQuotedErrors = 5;

// Little-endian encoding by shifts, so that the bytes are the same on any host.
void put_u16(std::vector<unsigned char>& out, uint16_t v) {
  for (int i = 0; i < 2; ++i) out.push_back(static_cast<unsigned char>(v >> (8 * i)));
}
void put_u32(std::vector<unsigned char>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<unsigned char>(v >> (8 * i)));
}
void put_u64(std::vector<unsigned char>& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<unsigned char>(v >> (8 * i)));
}
void put_f32(std::vector<unsigned char>& out, float v) {
  put_u32(out, std::bit_cast<uint32_t>(v));
}

uint64_t get_le(const unsigned char* p, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= uint64_t{p[i]} << (8 * i);
  return v;
}
uint16_t get_u16(const unsigned char* p) {
  return static_cast<uint16_t>(get_le(p, 2));
}
uint32_t get_u32(const unsigned char* p) {
  return static_cast<uint32_t>(get_le(p, 4));
}
float get_f32(const unsigned char* p) {
  return std::bit_cast<float>(get_u32(p));
}

std::vector<unsigned char> encode_header(const TreeFileHeader& h) {
  std::vector<unsigned char> out(std::begin(kTreeFileMagic), std::end(kTreeFileMagic));
  put_u32(out, h.version);
  put_u32(out, h.arity);
  put_u64(out, h.node_count);
  put_u64(out, h.ref_count);
  put_u64(out, h.triangle_count);
  put_u64(out, h.scene_hash);
  out.resize(kTreeFileHeaderBytes, 0);  // reserved, zero
  return out;
}

uint64_t expected_size(const TreeFileHeader& h) {
  return kTreeFileHeaderBytes + h.node_count * kTreeFileNodeBytes + h.ref_count * kTreeFileRefBytes;
}

// The header in `bytes` (kTreeFileHeaderBytes of them, the magic already checked), checked; `name` is
// the file's, for messages.
TreeFileHeader decode_header(const unsigned char* bytes, const std::string& name) {
  TreeFileHeader h;
  h.version = get_u32(bytes + 8);
  if (h.version != kTreeFileVersion)
    throw Error(name + ": tree file version " + std::to_string(h.version) +
                " is not supported (this build reads " + std::to_string(kTreeFileVersion) + ")");
  h.arity = get_u32(bytes + 12);
  h.node_count = get_le(bytes + 16, 8);
  h.ref_count = get_le(bytes + 24, 8);
  h.triangle_count = get_le(bytes + 32, 8);
  h.scene_hash = get_le(bytes + 40, 8);
  if (h.arity != 2 && h.arity != 4 && h.arity != 8)
    throw Error(name + ": arity " + std::to_string(h.arity) + " is out of range (2, 4 or 8)");
  if (h.node_count == 0 || h.node_count > kMaxNodes)
    throw Error(name + ": node count " + std::to_string(h.node_count) + " is out of range (1 to 2^32)");
  if (h.ref_count > kMaxRefs)
    throw Error(name + ": reference count " + std::to_string(h.ref_count) +
                " is out of range (at most 2^32)");
  if (h.triangle_count > kMaxTriangles)
    throw Error(name + ": triangle count " + std::to_string(h.triangle_count) +
                " is out of range (at most 2^32)");
  for (uint64_t i = 48; i < kTreeFileHeaderBytes; ++i)
    if (bytes[i] != 0)
      throw Error(name + ": header byte " + std::to_string(i) + " is reserved and must be 0 in version " +
                  std::to_string(kTreeFileVersion));
  return h;
}

// Opens `path` for reading in binary; a missing file or a directory is an Error naming it.
std::ifstream open_tree_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw Error(path.string() + ": cannot open the tree file: it is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot open the tree file (no such file, or not readable)");
  return in;
}

TreeFileHeader read_header(std::ifstream& in, const std::filesystem::path& path, uint64_t file_size) {
  unsigned char bytes[kTreeFileHeaderBytes] = {};
  const uint64_t have = std::min<uint64_t>(file_size, kTreeFileHeaderBytes);
  if (!in.read(reinterpret_cast<char*>(bytes), static_cast<std::streamsize>(have)))
    throw Error(path.string() + ": cannot read the tree file");
  // The magic first, so that a short foreign file is called foreign rather than truncated.
  if (have < sizeof kTreeFileMagic || std::memcmp(bytes, kTreeFileMagic, sizeof kTreeFileMagic) != 0)
    throw Error(path.string() + ": not a sahbench tree file (it does not start with \"SAHBTREE\")");
  if (have < kTreeFileHeaderBytes)
    throw Error(path.string() + ": tree file is truncated: expected at least the " +
                std::to_string(kTreeFileHeaderBytes) + "-byte header, found " + std::to_string(file_size) +
                " bytes");
  return decode_header(bytes, path.string());
}

uint64_t size_of(const std::filesystem::path& path) {
  std::error_code ec;
  const uint64_t size = std::filesystem::file_size(path, ec);
  if (ec) throw Error(path.string() + ": cannot open the tree file: " + ec.message());
  return size;
}

// The file's size against what its header's counts make: checked before anything is allocated, so a
// header that claims 2^32 nodes costs nothing, and with the header, so that a config names a truncated
// file as it is read.
void check_size(const TreeFileHeader& h, const std::filesystem::path& path, uint64_t file_size) {
  const uint64_t expected = expected_size(h);
  const std::string counts =
      std::to_string(h.node_count) + " nodes and " + std::to_string(h.ref_count) + " references";
  if (file_size < expected)
    throw Error(path.string() + ": tree file is truncated: its header's " + counts + " make " +
                std::to_string(expected) + " bytes, the file has " + std::to_string(file_size));
  if (file_size > expected)
    throw Error(path.string() + ": tree file has " + std::to_string(file_size - expected) +
                " bytes after the end of its " + counts + " (" + std::to_string(expected) + " bytes)");
}

}  // namespace

uint64_t triangle_hash(std::span<const Triangle> triangles) {
  uint64_t hash = kFnv1aOffset;
  for (const Triangle& t : triangles)
    for (const Vec3& v : {t.v0, t.v1, t.v2})
      for (const float c : {v.x, v.y, v.z}) {
        const uint32_t bits = std::bit_cast<uint32_t>(c);
        const char bytes[4] = {static_cast<char>(bits & 0xFFu), static_cast<char>((bits >> 8) & 0xFFu),
                               static_cast<char>((bits >> 16) & 0xFFu), static_cast<char>(bits >> 24)};
        hash = fnv1a(std::string_view(bytes, sizeof bytes), hash);
      }
  return hash;
}

std::string hash_text(uint64_t hash) {
  return fmt::format("{:#018x}", hash);
}

void write_tree_file(const std::filesystem::path& path, const Bvh& bvh, std::span<const Triangle> triangles) {
  require_file_path(path, "tree");
  TreeFileHeader h;
  h.arity = bvh.arity;
  h.node_count = bvh.nodes.size();
  h.ref_count = bvh.prim_refs.size();
  h.triangle_count = triangles.size();
  h.scene_hash = triangle_hash(triangles);
  std::vector<unsigned char> bytes = encode_header(h);
  bytes.reserve(expected_size(h));
  for (const Node& n : bvh.nodes) {
    for (const Vec3& v : {n.bounds.min, n.bounds.max}) {
      put_f32(bytes, v.x);
      put_f32(bytes, v.y);
      put_f32(bytes, v.z);
    }
    put_u32(bytes, n.first);
    put_u16(bytes, n.child_count);
    put_u16(bytes, n.prim_count);
  }
  for (const uint32_t r : bvh.prim_refs) put_u32(bytes, r);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(path.string() + ": cannot write the tree file (no such folder, or not writable)");
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw Error(path.string() + ": cannot write the tree file (disk full?)");
}

TreeFileHeader read_tree_file_header(const std::filesystem::path& path) {
  std::ifstream in = open_tree_file(path);
  const uint64_t file_size = size_of(path);
  const TreeFileHeader h = read_header(in, path, file_size);
  check_size(h, path, file_size);
  return h;
}

TreeFile read_tree_file(const std::filesystem::path& path) {
  std::ifstream in = open_tree_file(path);
  const uint64_t file_size = size_of(path);
  const TreeFileHeader h = read_header(in, path, file_size);
  check_size(h, path, file_size);
  const uint64_t expected = expected_size(h);

  std::vector<unsigned char> bytes(expected - kTreeFileHeaderBytes);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size())))
    throw Error(path.string() + ": cannot read the tree file");
  TreeFile file;
  file.triangle_count = h.triangle_count;
  file.scene_hash = h.scene_hash;
  file.bvh.arity = h.arity;
  file.bvh.nodes.resize(h.node_count);
  const unsigned char* p = bytes.data();
  for (Node& n : file.bvh.nodes) {
    n.bounds.min = {get_f32(p), get_f32(p + 4), get_f32(p + 8)};
    n.bounds.max = {get_f32(p + 12), get_f32(p + 16), get_f32(p + 20)};
    n.first = get_u32(p + 24);
    n.child_count = get_u16(p + 28);
    n.prim_count = get_u16(p + 30);
    p += kTreeFileNodeBytes;
  }
  file.bvh.prim_refs.resize(h.ref_count);
  for (uint32_t& r : file.bvh.prim_refs) {
    r = get_u32(p);
    p += kTreeFileRefBytes;
  }
  return file;
}

void check_tree_file_scene(uint64_t scene_hash, uint64_t triangle_count, const std::filesystem::path& path,
                           std::span<const Triangle> triangles) {
  const uint64_t hash = triangle_hash(triangles);
  if (scene_hash != hash || triangle_count != triangles.size())
    throw Error(fmt::format(
        "tree file {} was built for a scene with hash {} and {} triangles, this scene has hash {} and {} "
        "triangles",
        path.string(), hash_text(scene_hash), triangle_count, hash_text(hash), triangles.size()));
}

Bvh check_tree_for_scene(TreeFile file, const std::filesystem::path& path,
                         std::span<const Triangle> triangles) {
  check_tree_file_scene(file.scene_hash, file.triangle_count, path, triangles);
  const ValidationReport report = validate(file.bvh, triangles);
  if (!report.ok()) {
    std::string quoted;
    for (std::size_t i = 0; i < std::min(report.errors.size(), kQuotedErrors); ++i)
      quoted += "\n  " + report.errors[i];
    if (report.errors.size() > kQuotedErrors)
      quoted += "\n  (" + std::to_string(report.errors.size() - kQuotedErrors) + " more)";
    throw Error(path.string() + ": the tree fails validation:" + quoted);
  }
  return std::move(file.bvh);
}

Bvh load_tree_file(const std::filesystem::path& path, std::span<const Triangle> triangles) {
  return check_tree_for_scene(read_tree_file(path), path, triangles);
}

}  // namespace sahbench
