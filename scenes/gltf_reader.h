#pragma once
// Checked reading of a parsed glTF 2.0 model (tinygltf), shared by the static loader (gltf_loader.h) and
// the animation evaluator (gltf_animation.h): accessors read with every range checked against its
// buffer, mesh primitives decoded into triangles, and the node hierarchy walked in one fixed order.
// Sharing these is what makes the triangles of an animated frame line up with the static load, index
// for index. Internal to the scenes layer (it exposes tinygltf types).

#include <tiny_gltf.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/vec3.h"
#include "scenes/transform.h"

namespace sahbench {

/// Parses a .gltf (binary = false) or .glb file. Images are not decoded (a missing or broken image does
/// not fail the load). Throws Error naming the file when it cannot be read or is not valid glTF.
tinygltf::Model load_gltf_model(const std::filesystem::path& path, bool binary);

/// The triangles of one mesh primitive, as indices into its positions.
struct DecodedPrimitive {
  int primitive = 0;              ///< index in the mesh's primitives (skipped ones leave gaps)
  std::vector<Vec3> positions;    ///< the POSITION accessor as stored
  std::vector<uint32_t> corners;  ///< three per triangle, in the order the static load emits them
};

/// A node reached from the scene's roots: its index and its parent's (-1 for a root).
struct VisitedNode {
  int node = -1;
  int parent = -1;
};

class GltfReader {
 public:
  /// `file` names the model in error messages; the model must outlive the reader.
  GltfReader(const tinygltf::Model& model, std::string file);

  const tinygltf::Model& model() const { return model_; }
  const std::string& file() const { return file_; }

  /// Throws Error("<file>: <what>").
  [[noreturn]] void fail(const std::string& what) const;

  /// Fails on a required extension that leaves accessors without data (Draco, meshopt).
  void check_required_extensions() const;

  /// The nodes of the default scene (else the first scene; else every node that is nobody's child), in
  /// depth-first pre-order with children in file order. A parent always precedes its children. Fails
  /// on an out-of-range index or a node reached twice (a cycle or a shared child).
  std::vector<VisitedNode> scene_nodes() const;

  /// The node's static local transform: its matrix, or T * R * S from its TRS (missing parts default).
  /// Fails on a matrix, translation, rotation or scale with the wrong number of elements.
  Mat4 local_transform(int node) const;
  /// The node's TRS (defaults where absent); fails on wrong sizes. Not meaningful for a matrix node.
  Trs local_trs(int node) const;

  /// The mesh's triangle primitives, decoded on first use and cached. Points and lines, and primitives
  /// without POSITION, are skipped; strips and fans become triangles (glTF 2.0, section 3.7.2.1).
  const std::vector<DecodedPrimitive>& decode_mesh(int mesh);

  /// "mesh 3 ('name')", for messages.
  std::string mesh_name(int mesh) const;

  /// POSITION-style data: a VEC3 float accessor as Vec3 (zeros without a bufferView, sparse applied).
  std::vector<Vec3> read_positions(int accessor, const std::string& where) const;
  /// A SCALAR unsigned byte/short/int accessor, widened to 32 bits.
  std::vector<uint32_t> read_indices(int accessor, const std::string& where) const;
  /// Any accessor of `components` components per element (1 SCALAR, 3 VEC3, 4 VEC4, 16 MAT4) as
  /// floats: float components as stored, normalised integer components converted as in glTF 2.0,
  /// section 3.11 (e.g. c / 255 for unsigned bytes). Non-normalised integers are an error.
  std::vector<float> read_floats(int accessor, int components, const std::string& where) const;
  /// A VEC4 unsigned byte or short accessor (JOINTS_n) as 32-bit values, four per element.
  std::vector<uint32_t> read_joints(int accessor, const std::string& where) const;
  /// The accessor at `index`; fails when out of range.
  const tinygltf::Accessor& accessor(int index, const std::string& where) const;

 private:
  std::optional<DecodedPrimitive> decode_primitive(const tinygltf::Primitive& p, int index,
                                                   const std::string& where) const;
  // The accessor's elements of `element_size` bytes, packed, with sparse substitution applied.
  std::vector<unsigned char> read_elements(const tinygltf::Accessor& acc, std::size_t element_size,
                                           const std::string& where) const;
  const unsigned char* checked_range(int view_index, std::size_t byte_offset, std::size_t count,
                                     std::size_t element_size, std::size_t* stride,
                                     const std::string& where) const;
  void check_count(const tinygltf::Accessor& acc, std::size_t element_size, const std::string& where) const;
  void apply_sparse(const tinygltf::Accessor& acc, std::size_t element_size, unsigned char* dst,
                    const std::string& where) const;

  const tinygltf::Model& model_;
  std::string file_;
  std::vector<std::optional<std::vector<DecodedPrimitive>>> decoded_;  // per mesh, filled on first use
};

}  // namespace sahbench
