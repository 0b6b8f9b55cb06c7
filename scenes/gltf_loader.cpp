#include "scenes/gltf_loader.h"

#include <tiny_gltf.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "scenes/triangle_filter.h"

namespace sahbench {

namespace {

// glTF stores binary data little-endian; the element reads below copy bytes as they are.
static_assert(std::endian::native == std::endian::little, "the glTF loader assumes a little-endian host");

/// Column-major 4x4 matrix, as glTF stores them.
using Mat4 = std::array<double, 16>;

constexpr Mat4 kIdentity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

Mat4 multiply(const Mat4& a, const Mat4& b) {
  Mat4 c{};
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 4; ++row) {
      double s = 0.0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + row] * b[col * 4 + k];
      c[col * 4 + row] = s;
    }
  return c;
}

// The triangles of one primitive, as indices into its positions. Decoded once per primitive and placed
// once per node that uses its mesh.
struct DecodedPrimitive {
  std::vector<Vec3> positions;
  std::vector<uint32_t> corners;  // three per triangle
};

class GltfReader {
 public:
  GltfReader(const tinygltf::Model& model, std::string file, TriangleFilter& filter, Scene& scene)
      : model_(model), file_(std::move(file)), filter_(filter), scene_(scene), decoded_(model.meshes.size()) {}

  void read_scene();

 private:
  Mat4 local_transform(int node_index) const;
  void place_mesh(int mesh_index, const Mat4& world);
  void place_camera_and_light(const tinygltf::Node& node, const Mat4& world);
  const std::vector<DecodedPrimitive>& decode_mesh(int mesh_index);
  std::optional<DecodedPrimitive> decode_primitive(const tinygltf::Primitive& p, const std::string& where);
  std::vector<Vec3> read_positions(int accessor_index, const std::string& where) const;
  std::vector<uint32_t> read_indices(int accessor_index, const std::string& where) const;
  const unsigned char* checked_range(int view_index, std::size_t byte_offset, std::size_t count,
                                     std::size_t element_size, std::size_t* stride,
                                     const std::string& where) const;
  const tinygltf::Accessor& accessor(int index, const std::string& where) const;
  void check_count(const tinygltf::Accessor& acc, const std::string& where) const;
  void apply_sparse(const tinygltf::Accessor& acc, std::size_t element_size, unsigned char* dst,
                    const std::string& where) const;

  [[noreturn]] void fail(const std::string& what) const { throw Error(file_ + ": " + what); }
  std::string mesh_name(int mesh_index) const {
    const std::string& name = model_.meshes[static_cast<std::size_t>(mesh_index)].name;
    return "mesh " + std::to_string(mesh_index) + (name.empty() ? "" : " ('" + name + "')");
  }

  const tinygltf::Model& model_;
  std::string file_;
  TriangleFilter& filter_;
  Scene& scene_;
  std::vector<std::optional<std::vector<DecodedPrimitive>>> decoded_;  // per mesh, filled on first use
};

void GltfReader::read_scene() {
  // Compressed geometry would leave the accessors without data; refuse rather than load nothing.
  for (const std::string& ext : model_.extensionsRequired)
    if (ext == "KHR_draco_mesh_compression" || ext == "EXT_meshopt_compression" ||
        ext == "KHR_meshopt_compression")
      fail("required extension " + ext + " is not supported");

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
  std::vector<bool> visited(node_count, false);
  std::vector<std::pair<int, Mat4>> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.emplace_back(*it, kIdentity);
  while (!stack.empty()) {
    const auto [index, parent] = stack.back();
    stack.pop_back();
    if (index < 0 || static_cast<std::size_t>(index) >= node_count)
      fail("node index " + std::to_string(index) + " out of range (" + std::to_string(node_count) +
           " nodes)");
    if (visited[static_cast<std::size_t>(index)])
      fail("node " + std::to_string(index) + " is reached twice (the node hierarchy must be a tree)");
    visited[static_cast<std::size_t>(index)] = true;

    const tinygltf::Node& node = model_.nodes[static_cast<std::size_t>(index)];
    const Mat4 world = multiply(parent, local_transform(index));
    if (node.mesh >= 0) {
      if (static_cast<std::size_t>(node.mesh) >= model_.meshes.size())
        fail("node " + std::to_string(index) + ": mesh index " + std::to_string(node.mesh) + " out of range");
      place_mesh(node.mesh, world);
    }
    place_camera_and_light(node, world);
    for (auto it = node.children.rbegin(); it != node.children.rend(); ++it) stack.emplace_back(*it, world);
  }
}

Mat4 GltfReader::local_transform(int node_index) const {
  const tinygltf::Node& n = model_.nodes[static_cast<std::size_t>(node_index)];
  const std::string where = "node " + std::to_string(node_index) + ": ";
  if (!n.matrix.empty()) {
    if (n.matrix.size() != 16) fail(where + "matrix must have 16 elements");
    Mat4 m;
    std::copy(n.matrix.begin(), n.matrix.end(), m.begin());
    return m;
  }
  if (!n.translation.empty() && n.translation.size() != 3) fail(where + "translation must have 3 elements");
  if (!n.rotation.empty() && n.rotation.size() != 4) fail(where + "rotation must have 4 elements");
  if (!n.scale.empty() && n.scale.size() != 3) fail(where + "scale must have 3 elements");
  const double tx = n.translation.empty() ? 0.0 : n.translation[0];
  const double ty = n.translation.empty() ? 0.0 : n.translation[1];
  const double tz = n.translation.empty() ? 0.0 : n.translation[2];
  // Unit quaternion (x, y, z, w) to a rotation matrix; normalised first, as exporters write rounded values.
  double qx = 0, qy = 0, qz = 0, qw = 1;
  if (!n.rotation.empty()) {
    qx = n.rotation[0], qy = n.rotation[1], qz = n.rotation[2], qw = n.rotation[3];
    const double len = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
    if (len > 0.0) qx /= len, qy /= len, qz /= len, qw /= len;
  }
  const double sx = n.scale.empty() ? 1.0 : n.scale[0];
  const double sy = n.scale.empty() ? 1.0 : n.scale[1];
  const double sz = n.scale.empty() ? 1.0 : n.scale[2];
  const double xx = qx * qx, yy = qy * qy, zz = qz * qz;
  const double xy = qx * qy, xz = qx * qz, yz = qy * qz, wx = qw * qx, wy = qw * qy, wz = qw * qz;
  // T * R * S, column-major (one column per line).
  // clang-format off
  return Mat4{(1 - 2 * (yy + zz)) * sx, 2 * (xy + wz) * sx,       2 * (xz - wy) * sx,       0,
              2 * (xy - wz) * sy,       (1 - 2 * (xx + zz)) * sy, 2 * (yz + wx) * sy,       0,
              2 * (xz + wy) * sz,       2 * (yz - wx) * sz,       (1 - 2 * (xx + yy)) * sz, 0,
              tx,                       ty,                       tz,                       1};
  // clang-format on
}

// The first perspective camera found in the hierarchy becomes the scene camera; glTF cameras look
// down their local -z with +y up. Point and spot lights (KHR_lights_punctual) contribute positions.
void GltfReader::place_camera_and_light(const tinygltf::Node& node, const Mat4& m) {
  auto point = [&](double x, double y, double z) {
    return Vec3{to_float(m[0] * x + m[4] * y + m[8] * z + m[12]), to_float(m[1] * x + m[5] * y + m[9] * z + m[13]),
                to_float(m[2] * x + m[6] * y + m[10] * z + m[14])};
  };
  auto direction = [&](double x, double y, double z) {
    return Vec3{to_float(m[0] * x + m[4] * y + m[8] * z), to_float(m[1] * x + m[5] * y + m[9] * z),
                to_float(m[2] * x + m[6] * y + m[10] * z)};
  };
  if (!scene_.camera && node.camera >= 0 && static_cast<std::size_t>(node.camera) < model_.cameras.size()) {
    const tinygltf::Camera& cam = model_.cameras[static_cast<std::size_t>(node.camera)];
    const Vec3 forward = direction(0, 0, -1), up = direction(0, 1, 0);
    if (cam.type == "perspective" && cam.perspective.yfov > 0 && length(forward) > 0 && length(cross(forward, up)) > 0) {
      const Vec3 f = normalize(forward);
      const Vec3 u = normalize(cross(normalize(cross(f, up)), f));
      scene_.camera = Camera{point(0, 0, 0), f, u, static_cast<float>(cam.perspective.yfov)};
    }
  }
  const auto ext = node.extensions.find("KHR_lights_punctual");
  if (ext != node.extensions.end() && ext->second.Has("light")) {
    const int light = ext->second.Get("light").GetNumberAsInt();
    if (light >= 0 && static_cast<std::size_t>(light) < model_.lights.size() &&
        model_.lights[static_cast<std::size_t>(light)].type != "directional")
      scene_.lights.push_back(point(0, 0, 0));
  }
}

void GltfReader::place_mesh(int mesh_index, const Mat4& m) {
  for (const DecodedPrimitive& prim : decode_mesh(mesh_index)) {
    std::vector<Vec3> world(prim.positions.size());
    for (std::size_t i = 0; i < world.size(); ++i) {
      const Vec3 p = prim.positions[i];
      const double x = p.x, y = p.y, z = p.z;
      world[i] = {to_float(m[0] * x + m[4] * y + m[8] * z + m[12]),
                  to_float(m[1] * x + m[5] * y + m[9] * z + m[13]),
                  to_float(m[2] * x + m[6] * y + m[10] * z + m[14])};
    }
    filter_.reserve(prim.corners.size() / 3);
    for (std::size_t i = 0; i + 2 < prim.corners.size(); i += 3)
      filter_.add_indexed(world, prim.corners[i], prim.corners[i + 1], prim.corners[i + 2]);
  }
}

const std::vector<DecodedPrimitive>& GltfReader::decode_mesh(int mesh_index) {
  auto& slot = decoded_[static_cast<std::size_t>(mesh_index)];
  if (!slot) {
    std::vector<DecodedPrimitive> prims;
    const auto& mesh = model_.meshes[static_cast<std::size_t>(mesh_index)];
    for (std::size_t i = 0; i < mesh.primitives.size(); ++i) {
      const std::string where = mesh_name(mesh_index) + " primitive " + std::to_string(i);
      if (auto p = decode_primitive(mesh.primitives[i], where)) prims.push_back(std::move(*p));
    }
    slot = std::move(prims);
  }
  return *slot;
}

std::optional<DecodedPrimitive> GltfReader::decode_primitive(const tinygltf::Primitive& p,
                                                             const std::string& where) {
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

void GltfReader::check_count(const tinygltf::Accessor& acc, const std::string& where) const {
  // An accessor backed by a bufferView has been range-checked; one without (all zeros, or sparse only)
  // could claim any count, so bound it by what 32-bit indices can address.
  if (acc.count > std::numeric_limits<uint32_t>::max())
    fail(where + ": accessor count " + std::to_string(acc.count) + " is too large");
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

std::vector<Vec3> GltfReader::read_positions(int accessor_index, const std::string& where) const {
  const tinygltf::Accessor& acc = accessor(accessor_index, where);
  if (acc.type != TINYGLTF_TYPE_VEC3) fail(where + ": POSITION accessor is not VEC3");
  if (acc.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
    fail(where + ": POSITION component type " + std::to_string(acc.componentType) +
         " is not float (quantized positions are not supported)");
  constexpr std::size_t kSize = 3 * sizeof(float);
  // Positions are copied as raw bytes into Vec3 (three packed floats), so the copy is a memcpy.
  static_assert(sizeof(Vec3) == kSize);
  // Without a bufferView the values are zeros (glTF 2.0, section 3.6.2.3), possibly patched by sparse.
  // The range is checked before anything is allocated from the file's count.
  std::size_t stride = 0;
  const unsigned char* src =
      acc.bufferView >= 0 ? checked_range(acc.bufferView, acc.byteOffset, acc.count, kSize, &stride, where)
                          : nullptr;
  check_count(acc, where);
  std::vector<Vec3> positions(acc.count);
  if (src)
    for (std::size_t i = 0; i < acc.count; ++i) std::memcpy(&positions[i], src + i * stride, kSize);
  apply_sparse(acc, kSize, reinterpret_cast<unsigned char*>(positions.data()), where);
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
  // Read into 32-bit slots (zero-extended), then let sparse patch them in the file's element size.
  std::size_t stride = 0;
  const unsigned char* src =
      acc.bufferView >= 0 ? checked_range(acc.bufferView, acc.byteOffset, acc.count, size, &stride, where)
                          : nullptr;
  check_count(acc, where);
  std::vector<unsigned char> raw(acc.count * size);
  if (src)
    for (std::size_t i = 0; i < acc.count; ++i) std::memcpy(raw.data() + i * size, src + i * stride, size);
  apply_sparse(acc, size, raw.data(), where);
  std::vector<uint32_t> indices(acc.count, 0);
  for (std::size_t i = 0; i < acc.count; ++i) std::memcpy(&indices[i], raw.data() + i * size, size);
  return indices;
}

// Images are not needed for geometry; accepting every image (even a missing or undecodable one) keeps
// texture problems from failing a geometry load.
bool ignore_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*,
                  int, void*) {
  return true;
}

}  // namespace

Scene load_gltf(const std::filesystem::path& path, bool binary) {
  const std::string file = path.string();
  if (!std::filesystem::is_regular_file(path)) throw Error(file + ": cannot open file");
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(ignore_image, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  const bool ok = binary ? loader.LoadBinaryFromFile(&model, &err, &warn, file)
                         : loader.LoadASCIIFromFile(&model, &err, &warn, file);
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    throw Error(file + ": invalid " + (binary ? "GLB" : "glTF") +
                " file: " + (err.empty() ? "unknown error" : err));
  }

  Scene scene;
  scene.source = file;
  TriangleFilter filter(scene);
  GltfReader(model, file, filter, scene).read_scene();
  scene.animated = !model.animations.empty();
  return scene;
}

}  // namespace sahbench
