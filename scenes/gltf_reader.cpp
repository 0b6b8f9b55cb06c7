#include "scenes/gltf_reader.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "core/error.h"

namespace sahbench {

namespace {

// glTF stores binary data little-endian; the element reads below copy bytes as they are.
static_assert(std::endian::native == std::endian::little, "the glTF reader assumes a little-endian host");

// Most bytes an accessor without a bufferView may expand to. Such an accessor is zeros patched by its
// sparse values (glTF 2.0, section 3.6.2.3), so its count is backed by no data in the file: without a
// bound, a few bytes of JSON can demand 45 GiB (4e9 VEC3 positions). 256 MiB holds a morph target of
// over 22M vertices, beyond any real model.
constexpr std::size_t kMaxUnbackedBytes = std::size_t{256} << 20;

std::size_t component_size(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return 4;
    default:
      return 0;
  }
}

int type_for_components(int components) {
  switch (components) {
    case 1:
      return TINYGLTF_TYPE_SCALAR;
    case 2:
      return TINYGLTF_TYPE_VEC2;
    case 3:
      return TINYGLTF_TYPE_VEC3;
    case 4:
      return TINYGLTF_TYPE_VEC4;
    case 16:
      return TINYGLTF_TYPE_MAT4;
    default:
      return -1;
  }
}

std::string type_name(int components) {
  switch (components) {
    case 1:
      return "SCALAR";
    case 2:
      return "VEC2";
    case 3:
      return "VEC3";
    case 4:
      return "VEC4";
    case 16:
      return "MAT4";
    default:
      return std::to_string(components) + " components";
  }
}

// One normalised integer component as a float (glTF 2.0, section 3.11, "Animations" and the
// accessor normalisation rules): unsigned c / (2^n - 1), signed max(c / (2^(n-1) - 1), -1).
float normalised(const unsigned char* p, int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return static_cast<float>(*p) / 255.0f;
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      int8_t v;
      std::memcpy(&v, p, 1);
      return std::max(static_cast<float>(v) / 127.0f, -1.0f);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return static_cast<float>(v) / 65535.0f;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t v;
      std::memcpy(&v, p, 2);
      return std::max(static_cast<float>(v) / 32767.0f, -1.0f);
    }
    default:
      return 0.0f;  // callers admit only the four types above
  }
}

// Images are not needed for geometry; accepting every image (even a missing or undecodable one) keeps
// texture problems from failing a geometry load.
bool ignore_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*,
                  int, void*) {
  return true;
}

// tinygltf's file reading, refusing what is not a regular file. tinygltf opens an external buffer's uri
// as it finds it: a directory opens as a stream whose size reads as 2^63 - 1, which it then allocates
// (std::length_error or std::bad_alloc, not an Error), and a FIFO or device would block or never end.
bool read_regular_file(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                       void* user_data) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    if (err) *err += "'" + path + "' is not a regular file\n";
    return false;
  }
  return tinygltf::ReadWholeFile(out, err, path, user_data);
}

}  // namespace

tinygltf::Model load_gltf_model(const std::filesystem::path& path, bool binary) {
  const std::string file = path.string();
  if (!std::filesystem::is_regular_file(path)) throw Error(file + ": cannot open file");
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(ignore_image, nullptr);
  loader.SetFsCallbacks({&tinygltf::FileExists, &tinygltf::ExpandFilePath, &read_regular_file,
                         &tinygltf::WriteWholeFile, nullptr});
  tinygltf::Model model;
  std::string err, warn;
  const bool ok = binary ? loader.LoadBinaryFromFile(&model, &err, &warn, file)
                         : loader.LoadASCIIFromFile(&model, &err, &warn, file);
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    throw Error(file + ": invalid " + (binary ? "GLB" : "glTF") +
                " file: " + (err.empty() ? "unknown error" : err));
  }
  return model;
}

GltfReader::GltfReader(const tinygltf::Model& model, std::string file)
    : model_(model), file_(std::move(file)), decoded_(model.meshes.size()) {}

void GltfReader::fail(const std::string& what) const {
  throw Error(file_ + ": " + what);
}

void GltfReader::check_required_extensions() const {
  // Compressed geometry would leave the accessors without data; refuse rather than load nothing.
  for (const std::string& ext : model_.extensionsRequired)
    if (ext == "KHR_draco_mesh_compression" || ext == "EXT_meshopt_compression" ||
        ext == "KHR_meshopt_compression")
      fail("required extension " + ext + " is not supported");
}

std::vector<VisitedNode> GltfReader::scene_nodes() const {
  const auto node_count = model_.nodes.size();
  std::vector<int> roots;
  if (!model_.scenes.empty()) {
    const int s = model_.defaultScene >= 0 ? model_.defaultScene : 0;
    if (static_cast<std::size_t>(s) >= model_.scenes.size())
      fail("default scene " + std::to_string(s) + " does not exist");
    roots = model_.scenes[static_cast<std::size_t>(s)].nodes;
  } else {
    // No scene: every node that is nobody's child is a root.
    std::vector<bool> is_child(node_count, false);
    for (const auto& n : model_.nodes)
      for (int c : n.children)
        if (c >= 0 && static_cast<std::size_t>(c) < node_count) is_child[static_cast<std::size_t>(c)] = true;
    for (std::size_t i = 0; i < node_count; ++i)
      if (!is_child[i]) roots.push_back(static_cast<int>(i));
  }

  // Depth-first with an explicit stack (hierarchies can be deep). glTF requires the node graph to be a
  // set of disjoint trees; a node reached twice (a cycle, or a shared child) is an error, which also
  // bounds the work a malicious file can cause.
  std::vector<VisitedNode> order;
  std::vector<bool> visited(node_count, false);
  std::vector<VisitedNode> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, -1});
  while (!stack.empty()) {
    const VisitedNode v = stack.back();
    stack.pop_back();
    if (v.node < 0 || static_cast<std::size_t>(v.node) >= node_count)
      fail("node index " + std::to_string(v.node) + " out of range (" + std::to_string(node_count) +
           " nodes)");
    if (visited[static_cast<std::size_t>(v.node)])
      fail("node " + std::to_string(v.node) + " is reached twice (the node hierarchy must be a tree)");
    visited[static_cast<std::size_t>(v.node)] = true;
    order.push_back(v);
    const tinygltf::Node& node = model_.nodes[static_cast<std::size_t>(v.node)];
    for (auto it = node.children.rbegin(); it != node.children.rend(); ++it) stack.push_back({*it, v.node});
  }
  return order;
}

Trs GltfReader::local_trs(int node_index) const {
  const tinygltf::Node& n = model_.nodes[static_cast<std::size_t>(node_index)];
  const std::string where = "node " + std::to_string(node_index) + ": ";
  if (!n.translation.empty() && n.translation.size() != 3) fail(where + "translation must have 3 elements");
  if (!n.rotation.empty() && n.rotation.size() != 4) fail(where + "rotation must have 4 elements");
  if (!n.scale.empty() && n.scale.size() != 3) fail(where + "scale must have 3 elements");
  Trs trs;
  if (!n.translation.empty()) std::copy(n.translation.begin(), n.translation.end(), trs.translation.begin());
  if (!n.rotation.empty()) std::copy(n.rotation.begin(), n.rotation.end(), trs.rotation.begin());
  if (!n.scale.empty()) std::copy(n.scale.begin(), n.scale.end(), trs.scale.begin());
  return trs;
}

Mat4 GltfReader::local_transform(int node_index) const {
  const tinygltf::Node& n = model_.nodes[static_cast<std::size_t>(node_index)];
  if (!n.matrix.empty()) {
    if (n.matrix.size() != 16) fail("node " + std::to_string(node_index) + ": matrix must have 16 elements");
    Mat4 m;
    std::copy(n.matrix.begin(), n.matrix.end(), m.begin());
    return m;
  }
  return trs_matrix(local_trs(node_index));
}

std::string GltfReader::mesh_name(int mesh_index) const {
  const std::string& name = model_.meshes[static_cast<std::size_t>(mesh_index)].name;
  return "mesh " + std::to_string(mesh_index) + (name.empty() ? "" : " ('" + name + "')");
}

const std::vector<DecodedPrimitive>& GltfReader::decode_mesh(int mesh_index) {
  if (mesh_index < 0 || static_cast<std::size_t>(mesh_index) >= model_.meshes.size())
    fail("mesh index " + std::to_string(mesh_index) + " out of range");
  auto& slot = decoded_[static_cast<std::size_t>(mesh_index)];
  if (!slot) {
    std::vector<DecodedPrimitive> prims;
    const auto& mesh = model_.meshes[static_cast<std::size_t>(mesh_index)];
    for (std::size_t i = 0; i < mesh.primitives.size(); ++i) {
      const std::string where = mesh_name(mesh_index) + " primitive " + std::to_string(i);
      if (auto p = decode_primitive(mesh.primitives[i], static_cast<int>(i), where))
        prims.push_back(std::move(*p));
    }
    slot = std::move(prims);
  }
  return *slot;
}

std::optional<DecodedPrimitive> GltfReader::decode_primitive(const tinygltf::Primitive& p, int index,
                                                             const std::string& where) const {
  // A mode of -1 means the file did not give one; glTF's default is TRIANGLES.
  const int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
  if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
      mode == TINYGLTF_MODE_LINE_STRIP)
    return std::nullopt;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
      mode != TINYGLTF_MODE_TRIANGLE_FAN)
    fail(where + ": unknown primitive mode " + std::to_string(mode));
  // The spec lets a client skip a primitive without positions: it has nothing to draw.
  const auto pos = p.attributes.find("POSITION");
  if (pos == p.attributes.end()) return std::nullopt;

  DecodedPrimitive out;
  out.primitive = index;
  out.positions = read_positions(pos->second, where);
  std::vector<uint32_t> indices;
  if (p.indices >= 0) {
    indices = read_indices(p.indices, where);
  } else {
    if (out.positions.size() > std::numeric_limits<uint32_t>::max()) fail(where + ": too many vertices");
    indices.resize(out.positions.size());
    for (std::size_t i = 0; i < indices.size(); ++i) indices[i] = static_cast<uint32_t>(i);
  }

  const std::size_t n = indices.size();
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    if (n % 3 != 0) fail(where + ": TRIANGLES with " + std::to_string(n) + " indices, not a multiple of 3");
    out.corners = std::move(indices);
  } else if (n >= 3) {
    out.corners.reserve((n - 2) * 3);
    for (std::size_t i = 0; i + 2 < n; ++i) {
      // Vertex order as in the glTF 2.0 specification, section 3.7.2.1 (keeps the winding consistent).
      if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
        out.corners.insert(out.corners.end(), {indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]});
      } else {
        out.corners.insert(out.corners.end(), {indices[i + 1], indices[i + 2], indices[0]});
      }
    }
  }
  return out;
}

const tinygltf::Accessor& GltfReader::accessor(int index, const std::string& where) const {
  if (index < 0 || static_cast<std::size_t>(index) >= model_.accessors.size())
    fail(where + ": accessor " + std::to_string(index) + " out of range");
  return model_.accessors[static_cast<std::size_t>(index)];
}

const unsigned char* GltfReader::checked_range(int view_index, std::size_t byte_offset, std::size_t count,
                                               std::size_t element_size, std::size_t* stride,
                                               const std::string& where) const {
  if (view_index < 0 || static_cast<std::size_t>(view_index) >= model_.bufferViews.size())
    fail(where + ": bufferView " + std::to_string(view_index) + " out of range");
  const tinygltf::BufferView& view = model_.bufferViews[static_cast<std::size_t>(view_index)];
  if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model_.buffers.size())
    fail(where + ": bufferView " + std::to_string(view_index) + ": buffer " + std::to_string(view.buffer) +
         " out of range");
  const std::vector<unsigned char>& data = model_.buffers[static_cast<std::size_t>(view.buffer)].data;
  // All checks are written so that no sum or product can overflow.
  if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset)
    fail(where + ": bufferView " + std::to_string(view_index) + " (offset " +
         std::to_string(view.byteOffset) + ", length " + std::to_string(view.byteLength) +
         ") exceeds its buffer of " + std::to_string(data.size()) + " bytes");
  *stride = view.byteStride != 0 ? view.byteStride : element_size;
  if (count > 0) {
    const bool fits = byte_offset <= view.byteLength && element_size <= view.byteLength - byte_offset &&
                      count - 1 <= (view.byteLength - byte_offset - element_size) / *stride;
    if (!fits)
      fail(where + ": " + std::to_string(count) + " elements of " + std::to_string(element_size) +
           " bytes (stride " + std::to_string(*stride) + ", offset " + std::to_string(byte_offset) +
           ") exceed bufferView " + std::to_string(view_index) + " of " + std::to_string(view.byteLength) +
           " bytes");
  }
  return data.data() + view.byteOffset + byte_offset;
}

void GltfReader::check_count(const tinygltf::Accessor& acc, std::size_t element_size,
                             const std::string& where) const {
  // An accessor backed by a bufferView has been range-checked; one without (all zeros, or sparse only)
  // could claim any count, so bound it by what 32-bit indices can address and by kMaxUnbackedBytes.
  if (acc.count > std::numeric_limits<uint32_t>::max())
    fail(where + ": accessor count " + std::to_string(acc.count) + " is too large");
  if (acc.bufferView < 0 && acc.count > kMaxUnbackedBytes / element_size)
    fail(where + ": accessor without a bufferView has " + std::to_string(acc.count) + " elements of " +
         std::to_string(element_size) + " bytes, more than the " + std::to_string(kMaxUnbackedBytes >> 20) +
         " MiB of zeros such an accessor may expand to");
}

void GltfReader::apply_sparse(const tinygltf::Accessor& acc, std::size_t element_size, unsigned char* dst,
                              const std::string& where) const {
  if (!acc.sparse.isSparse) return;
  if (acc.sparse.count < 0 || static_cast<std::size_t>(acc.sparse.count) > acc.count)
    fail(where + ": sparse count " + std::to_string(acc.sparse.count) + " out of range");
  const auto count = static_cast<std::size_t>(acc.sparse.count);
  const int index_type = acc.sparse.indices.componentType;
  const std::size_t index_size = index_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE    ? 1
                                 : index_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ? 2
                                 : index_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT   ? 4
                                                                                        : 0;
  if (index_size == 0)
    fail(where + ": sparse index component type " + std::to_string(index_type) + " invalid");
  if (acc.sparse.indices.byteOffset < 0 || acc.sparse.values.byteOffset < 0)
    fail(where + ": negative sparse byteOffset");
  std::size_t index_stride = 0, value_stride = 0;
  const unsigned char* idx =
      checked_range(acc.sparse.indices.bufferView, static_cast<std::size_t>(acc.sparse.indices.byteOffset),
                    count, index_size, &index_stride, where + " sparse indices");
  const unsigned char* val =
      checked_range(acc.sparse.values.bufferView, static_cast<std::size_t>(acc.sparse.values.byteOffset),
                    count, element_size, &value_stride, where + " sparse values");
  for (std::size_t i = 0; i < count; ++i) {
    uint32_t target = 0;
    std::memcpy(&target, idx + i * index_size, index_size);  // little-endian: low bytes first
    if (target >= acc.count) fail(where + ": sparse index " + std::to_string(target) + " out of range");
    std::memcpy(dst + static_cast<std::size_t>(target) * element_size, val + i * element_size, element_size);
  }
}

std::vector<unsigned char> GltfReader::read_elements(const tinygltf::Accessor& acc, std::size_t element_size,
                                                     const std::string& where) const {
  // Without a bufferView the values are zeros (glTF 2.0, section 3.6.2.3), possibly patched by sparse.
  // The range is checked before anything is allocated from the file's count.
  std::size_t stride = 0;
  const unsigned char* src = acc.bufferView >= 0 ? checked_range(acc.bufferView, acc.byteOffset, acc.count,
                                                                 element_size, &stride, where)
                                                 : nullptr;
  check_count(acc, element_size, where);
  std::vector<unsigned char> raw(acc.count * element_size, 0);
  if (src)
    for (std::size_t i = 0; i < acc.count; ++i)
      std::memcpy(raw.data() + i * element_size, src + i * stride, element_size);
  apply_sparse(acc, element_size, raw.data(), where);
  return raw;
}

std::vector<Vec3> GltfReader::read_positions(int accessor_index, const std::string& where) const {
  const tinygltf::Accessor& acc = accessor(accessor_index, where);
  if (acc.type != TINYGLTF_TYPE_VEC3) fail(where + ": POSITION accessor is not VEC3");
  if (acc.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
    fail(where + ": POSITION component type " + std::to_string(acc.componentType) +
         " is not float (quantized positions are not supported)");
  constexpr std::size_t kSize = 3 * sizeof(float);
  // Positions are copied as raw bytes into Vec3 (three packed floats).
  static_assert(sizeof(Vec3) == kSize);
  const std::vector<unsigned char> raw = read_elements(acc, kSize, where);
  std::vector<Vec3> positions(acc.count);
  if (!raw.empty()) std::memcpy(positions.data(), raw.data(), raw.size());
  return positions;
}

std::vector<uint32_t> GltfReader::read_indices(int accessor_index, const std::string& where) const {
  const tinygltf::Accessor& acc = accessor(accessor_index, where);
  if (acc.type != TINYGLTF_TYPE_SCALAR) fail(where + ": index accessor is not SCALAR");
  const std::size_t size = acc.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE    ? 1
                           : acc.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ? 2
                           : acc.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT   ? 4
                                                                                         : 0;
  if (size == 0)
    fail(where + ": index component type " + std::to_string(acc.componentType) +
         " is not unsigned byte, short or int");
  // Read in the file's element size (sparse patches in that size), then zero-extend.
  const std::vector<unsigned char> raw = read_elements(acc, size, where);
  std::vector<uint32_t> indices(acc.count, 0);
  for (std::size_t i = 0; i < acc.count; ++i) std::memcpy(&indices[i], raw.data() + i * size, size);
  return indices;
}

std::vector<float> GltfReader::read_floats(int accessor_index, int components,
                                           const std::string& where) const {
  const tinygltf::Accessor& acc = accessor(accessor_index, where);
  if (acc.type != type_for_components(components))
    fail(where + ": accessor " + std::to_string(accessor_index) + " is not " + type_name(components));
  const int type = acc.componentType;
  const std::size_t size = component_size(type);
  const bool is_float = type == TINYGLTF_COMPONENT_TYPE_FLOAT;
  const bool is_normalised_int = acc.normalized && type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT && size != 0;
  if (!is_float && !is_normalised_int)
    fail(where + ": accessor " + std::to_string(accessor_index) + " has component type " +
         std::to_string(type) + " (expected float or a normalized byte or short)");
  const auto n = static_cast<std::size_t>(components);
  const std::vector<unsigned char> raw = read_elements(acc, n * size, where);
  std::vector<float> out(acc.count * n);
  if (is_float) {
    if (!raw.empty()) std::memcpy(out.data(), raw.data(), raw.size());
  } else {
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = normalised(raw.data() + i * size, type);
  }
  return out;
}

std::vector<uint32_t> GltfReader::read_joints(int accessor_index, const std::string& where) const {
  const tinygltf::Accessor& acc = accessor(accessor_index, where);
  if (acc.type != TINYGLTF_TYPE_VEC4) fail(where + ": JOINTS accessor is not VEC4");
  const std::size_t size = acc.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE    ? 1
                           : acc.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ? 2
                                                                                         : 0;
  if (size == 0)
    fail(where + ": JOINTS component type " + std::to_string(acc.componentType) +
         " is not unsigned byte or short");
  const std::vector<unsigned char> raw = read_elements(acc, 4 * size, where);
  std::vector<uint32_t> out(acc.count * 4, 0);
  for (std::size_t i = 0; i < out.size(); ++i) std::memcpy(&out[i], raw.data() + i * size, size);
  return out;
}

}  // namespace sahbench
