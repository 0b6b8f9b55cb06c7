#include "scenes/gltf_animation.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "core/error.h"
#include "scenes/gltf_reader.h"
#include "scenes/keyframes.h"
#include "scenes/transform.h"
#include "scenes/triangle_filter.h"

namespace sahbench {

namespace {

// Vertices per task when transforming: enough to amortise scheduling.
constexpr std::size_t kVertexGrain = 2048;

enum class Path { kTranslation, kRotation, kScale, kWeights };

struct Channel {
  int node = -1;
  Path path = Path::kTranslation;
  Keyframes keys;
};

// One decoded mesh primitive with what deforms it.
struct PrimitiveData {
  std::vector<Vec3> positions;
  std::vector<uint32_t> corners;
  /// Morph target POSITION displacements, one array per target (empty when the target has none).
  std::vector<std::vector<Vec3>> targets;
  /// Skinning influences, `influences` per vertex (4 per JOINTS_n / WEIGHTS_n set).
  std::vector<uint32_t> joints;
  std::vector<float> weights;
  int influences = 0;
};

// One use of a mesh primitive by a node; its vertices occupy [first_vertex, first_vertex + count) of a
// frame's vertex array.
struct Placement {
  int node = -1;
  int skin = -1;  // the node's skin, or -1
  const PrimitiveData* data = nullptr;
  uint32_t first_vertex = 0;
};

struct Skin {
  std::vector<int> joints;
  std::vector<Mat4> inverse_bind;  // one per joint
};

// rows 0..2 of a column-major 4x4 matrix, accumulated as a weighted sum (linear blend skinning).
using Affine = std::array<double, 12>;

Affine affine_of(const Mat4& m) {
  return {m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10], m[12], m[13], m[14]};
}

}  // namespace

struct GltfAnimation::Impl {
  std::string file;
  // Nodes: parent (-1 for a root) and an order in which every parent precedes its children.
  std::vector<int> parent;
  std::vector<int> order;
  std::vector<std::optional<Mat4>> rest_matrix;   // nodes given by a matrix (never animated)
  std::vector<Trs> rest_trs;                      // the others
  std::vector<std::vector<double>> rest_weights;  // morph weights of nodes whose mesh has targets
  std::vector<Skin> skins;
  std::vector<Channel> channels;
  double start = 0.0, end = 0.0;
  // mesh_data[mesh] holds its decoded primitives (only for meshes the scene uses).
  std::vector<std::vector<PrimitiveData>> mesh_data;
  std::vector<Placement> placements;
  uint32_t vertex_count = 0;
  std::vector<uint32_t> kept_corners;  // three frame-vertex indices per output triangle

  [[noreturn]] void fail(const std::string& what) const { throw Error(file + ": " + what); }

  void read_nodes(const GltfReader& reader);
  void read_mesh(GltfReader& reader, int mesh);
  void read_skins(const GltfReader& reader);
  void read_animation(const GltfReader& reader);
  std::vector<Mat4> world_matrices(const std::vector<Trs>& trs) const;
  void place(GltfReader& reader, const Scene& static_scene);
  void transform_vertices(const PrimitiveData& d, const Affine* rigid, std::span<const Affine> joint_matrices,
                          const std::vector<double>* morph, std::span<Vec3> out) const;
};

void GltfAnimation::Impl::read_nodes(const GltfReader& reader) {
  const tinygltf::Model& model = reader.model();
  const std::size_t n = model.nodes.size();
  parent.assign(n, -1);
  for (std::size_t i = 0; i < n; ++i)
    for (int c : model.nodes[i].children) {
      if (c < 0 || static_cast<std::size_t>(c) >= n)
        fail("node " + std::to_string(i) + ": child " + std::to_string(c) + " out of range");
      if (parent[static_cast<std::size_t>(c)] != -1 || static_cast<std::size_t>(c) == i)
        fail("node " + std::to_string(c) + " has two parents (the node hierarchy must be a tree)");
      parent[static_cast<std::size_t>(c)] = static_cast<int>(i);
    }
  // Parents before children: breadth-first from the roots. A node never reached lies on a cycle.
  for (std::size_t i = 0; i < n; ++i)
    if (parent[i] == -1) order.push_back(static_cast<int>(i));
  for (std::size_t next = 0; next < order.size(); ++next)
    for (int c : model.nodes[static_cast<std::size_t>(order[next])].children) order.push_back(c);
  if (order.size() != n) fail("the node hierarchy has a cycle");

  rest_matrix.assign(n, std::nullopt);
  rest_trs.assign(n, Trs{});
  rest_weights.assign(n, {});
  for (std::size_t i = 0; i < n; ++i) {
    if (!model.nodes[i].matrix.empty())
      rest_matrix[i] = reader.local_transform(static_cast<int>(i));
    else
      rest_trs[i] = reader.local_trs(static_cast<int>(i));
  }
}

void GltfAnimation::Impl::read_mesh(GltfReader& reader, int mesh_index) {
  const tinygltf::Model& model = reader.model();
  auto& slot = mesh_data[static_cast<std::size_t>(mesh_index)];
  if (!slot.empty()) return;
  const tinygltf::Mesh& mesh = model.meshes[static_cast<std::size_t>(mesh_index)];
  for (const DecodedPrimitive& decoded : reader.decode_mesh(mesh_index)) {
    const tinygltf::Primitive& prim = mesh.primitives[static_cast<std::size_t>(decoded.primitive)];
    const std::string where =
        reader.mesh_name(mesh_index) + " primitive " + std::to_string(decoded.primitive);
    PrimitiveData data;
    data.positions = decoded.positions;
    data.corners = decoded.corners;
    const std::size_t count = data.positions.size();

    for (std::size_t t = 0; t < prim.targets.size(); ++t) {
      const auto pos = prim.targets[t].find("POSITION");
      std::vector<Vec3> delta;
      if (pos != prim.targets[t].end()) {
        delta = reader.read_positions(pos->second, where + " morph target " + std::to_string(t));
        if (delta.size() != count)
          fail(where + ": morph target " + std::to_string(t) + " has " + std::to_string(delta.size()) +
               " positions, the primitive " + std::to_string(count));
      }
      data.targets.push_back(std::move(delta));
    }

    // JOINTS_0/WEIGHTS_0, JOINTS_1/WEIGHTS_1, ...: four influences per set.
    for (int set = 0;; ++set) {
      const auto j = prim.attributes.find("JOINTS_" + std::to_string(set));
      const auto w = prim.attributes.find("WEIGHTS_" + std::to_string(set));
      if (j == prim.attributes.end() && w == prim.attributes.end()) break;
      if (j == prim.attributes.end() || w == prim.attributes.end())
        fail(where + ": JOINTS_" + std::to_string(set) + " and WEIGHTS_" + std::to_string(set) +
             " must come together");
      const std::vector<uint32_t> joints =
          reader.read_joints(j->second, where + " JOINTS_" + std::to_string(set));
      const std::vector<float> weights =
          reader.read_floats(w->second, 4, where + " WEIGHTS_" + std::to_string(set));
      if (joints.size() != 4 * count || weights.size() != 4 * count)
        fail(where + ": JOINTS_" + std::to_string(set) + "/WEIGHTS_" + std::to_string(set) +
             " do not have one element per vertex (" + std::to_string(count) + ")");
      // Interleave per vertex: the influences of set s follow those of sets 0..s-1.
      const int before = data.influences;
      std::vector<uint32_t> all_joints(count * static_cast<std::size_t>(before + 4));
      std::vector<float> all_weights(all_joints.size());
      for (std::size_t v = 0; v < count; ++v) {
        for (int k = 0; k < before; ++k) {
          all_joints[v * (before + 4) + k] = data.joints[v * before + k];
          all_weights[v * (before + 4) + k] = data.weights[v * before + k];
        }
        for (int k = 0; k < 4; ++k) {
          all_joints[v * (before + 4) + before + k] = joints[4 * v + k];
          all_weights[v * (before + 4) + before + k] = weights[4 * v + k];
        }
      }
      data.joints = std::move(all_joints);
      data.weights = std::move(all_weights);
      data.influences = before + 4;
    }
    slot.push_back(std::move(data));
  }
}

void GltfAnimation::Impl::read_skins(const GltfReader& reader) {
  const tinygltf::Model& model = reader.model();
  for (std::size_t s = 0; s < model.skins.size(); ++s) {
    const tinygltf::Skin& in = model.skins[s];
    const std::string where = "skin " + std::to_string(s);
    Skin skin;
    for (int j : in.joints) {
      if (j < 0 || static_cast<std::size_t>(j) >= model.nodes.size())
        fail(where + ": joint node " + std::to_string(j) + " out of range");
      skin.joints.push_back(j);
    }
    skin.inverse_bind.assign(skin.joints.size(), kIdentity);  // glTF: identity when absent
    if (in.inverseBindMatrices >= 0) {
      const std::vector<float> m =
          reader.read_floats(in.inverseBindMatrices, 16, where + " inverseBindMatrices");
      if (m.size() < 16 * skin.joints.size())
        fail(where + ": " + std::to_string(m.size() / 16) + " inverse bind matrices for " +
             std::to_string(skin.joints.size()) + " joints");
      for (std::size_t j = 0; j < skin.joints.size(); ++j)
        std::copy_n(m.begin() + 16 * j, 16, skin.inverse_bind[j].begin());
    }
    skins.push_back(std::move(skin));
  }
}

void GltfAnimation::Impl::read_animation(const GltfReader& reader) {
  const tinygltf::Model& model = reader.model();
  if (model.animations.empty()) fail("the file has no animation");
  // The first animation: a file's animations are usually separate clips ("walk", "run") that would
  // fight over the same nodes if played together.
  const tinygltf::Animation& anim = model.animations.front();
  start = std::numeric_limits<double>::infinity();
  end = -std::numeric_limits<double>::infinity();
  for (std::size_t c = 0; c < anim.channels.size(); ++c) {
    const tinygltf::AnimationChannel& ch = anim.channels[c];
    const std::string where = "animation 0 channel " + std::to_string(c);
    if (ch.target_node < 0 || static_cast<std::size_t>(ch.target_node) >= model.nodes.size())
      fail(where + ": target node " + std::to_string(ch.target_node) + " out of range");
    if (ch.sampler < 0 || static_cast<std::size_t>(ch.sampler) >= anim.samplers.size())
      fail(where + ": sampler " + std::to_string(ch.sampler) + " out of range");
    const auto node = static_cast<std::size_t>(ch.target_node);
    const tinygltf::AnimationSampler& sampler = anim.samplers[static_cast<std::size_t>(ch.sampler)];

    Path path;
    int width = 3;
    if (ch.target_path == "translation") {
      path = Path::kTranslation;
    } else if (ch.target_path == "rotation") {
      path = Path::kRotation, width = 4;
    } else if (ch.target_path == "scale") {
      path = Path::kScale;
    } else if (ch.target_path == "weights") {
      path = Path::kWeights;
      width = static_cast<int>(rest_weights[node].size());
      if (width == 0)
        fail(where + ": animates the weights of node " + std::to_string(node) +
             ", which has no morph targets");
    } else {
      fail(where + ": target path '" + ch.target_path + "' is not supported");
    }
    if (path != Path::kWeights && rest_matrix[node])
      fail(where + ": node " + std::to_string(node) +
           " is animated but given by a matrix (glTF allows only TRS)");

    try {
      const Interpolation interpolation = parse_interpolation(sampler.interpolation);
      std::vector<float> times = reader.read_floats(sampler.input, 1, where + " input");
      std::vector<float> values =
          reader.read_floats(sampler.output, path == Path::kWeights ? 1 : width, where + " output");
      Keyframes keys(std::move(times), std::move(values), width, interpolation, path == Path::kRotation);
      start = std::min<double>(start, keys.first_time());
      end = std::max<double>(end, keys.last_time());
      channels.push_back({static_cast<int>(node), path, std::move(keys)});
    } catch (const Error& e) {
      const std::string what = e.what();
      // The reader's errors already name the file; the Keyframes ones do not.
      if (what.starts_with(file + ": ")) throw;
      fail(where + " (node " + std::to_string(node) + " " + ch.target_path + "): " + what);
    }
  }
  if (channels.empty()) start = end = 0.0;
}

std::vector<Mat4> GltfAnimation::Impl::world_matrices(const std::vector<Trs>& trs) const {
  std::vector<Mat4> world(order.size());
  for (int i : order) {
    const auto n = static_cast<std::size_t>(i);
    const Mat4 local = rest_matrix[n] ? *rest_matrix[n] : trs_matrix(trs[n]);
    world[n] = parent[n] < 0 ? local : multiply(world[static_cast<std::size_t>(parent[n])], local);
  }
  return world;
}

// Lists the mesh uses in the static loader's order and keeps exactly the triangles it kept, checked
// against its result.
void GltfAnimation::Impl::place(GltfReader& reader, const Scene& static_scene) {
  const tinygltf::Model& model = reader.model();
  mesh_data.assign(model.meshes.size(), {});
  const std::vector<Mat4> rest_world = world_matrices(rest_trs);

  Scene check;
  TriangleFilter filter(check);
  for (const VisitedNode& v : reader.scene_nodes()) {
    const tinygltf::Node& node = model.nodes[static_cast<std::size_t>(v.node)];
    if (node.mesh < 0) continue;
    if (static_cast<std::size_t>(node.mesh) >= model.meshes.size())
      fail("node " + std::to_string(v.node) + ": mesh index " + std::to_string(node.mesh) + " out of range");
    read_mesh(reader, node.mesh);
    const auto& prims = mesh_data[static_cast<std::size_t>(node.mesh)];

    if (node.skin >= 0 && static_cast<std::size_t>(node.skin) >= skins.size())
      fail("node " + std::to_string(v.node) + ": skin " + std::to_string(node.skin) + " out of range");
    const int skin = node.skin;

    // Morph weights: the node's, else the mesh's, else zeros (glTF 2.0, section 3.7.2.2).
    std::size_t target_count = 0;
    for (const auto& p : prims) target_count = std::max(target_count, p.targets.size());
    for (const auto& p : prims)
      if (p.targets.size() != target_count)
        fail(reader.mesh_name(node.mesh) + ": primitives have different numbers of morph targets");
    if (target_count > 0) {
      const tinygltf::Mesh& mesh = model.meshes[static_cast<std::size_t>(node.mesh)];
      std::vector<double> w(target_count, 0.0);
      const std::vector<double>& given = !node.weights.empty() ? node.weights : mesh.weights;
      if (!given.empty()) {
        if (given.size() != target_count)
          fail("node " + std::to_string(v.node) + ": " + std::to_string(given.size()) +
               " morph weights for " + std::to_string(target_count) + " targets");
        w = given;
      }
      rest_weights[static_cast<std::size_t>(v.node)] = std::move(w);
    }

    for (const PrimitiveData& p : prims) {
      if (skin >= 0) {
        const std::size_t joints = skins[static_cast<std::size_t>(skin)].joints.size();
        for (std::size_t i = 0; i < p.joints.size(); ++i)
          if (p.weights[i] != 0.0f && p.joints[i] >= joints)
            fail(reader.mesh_name(node.mesh) + ": vertex " + std::to_string(i / p.influences) +
                 " uses joint " + std::to_string(p.joints[i]) + " of a skin with " + std::to_string(joints));
      }
      if (static_cast<uint64_t>(vertex_count) + p.positions.size() > std::numeric_limits<uint32_t>::max())
        fail("too many vertices");
      placements.push_back({v.node, skin, &p, vertex_count});

      // The static loader's placement of this primitive (gltf_loader.cpp), recording what it keeps.
      const Mat4& m = rest_world[static_cast<std::size_t>(v.node)];
      std::vector<Vec3> world(p.positions.size());
      for (std::size_t i = 0; i < world.size(); ++i) world[i] = transform_point(m, p.positions[i]);
      for (std::size_t i = 0; i + 2 < p.corners.size(); i += 3) {
        const std::size_t before = check.triangles.size();
        filter.add_indexed(world, p.corners[i], p.corners[i + 1], p.corners[i + 2]);
        if (check.triangles.size() != before)
          kept_corners.insert(kept_corners.end(),
                              {vertex_count + p.corners[i], vertex_count + p.corners[i + 1],
                               vertex_count + p.corners[i + 2]});
      }
      vertex_count += static_cast<uint32_t>(p.positions.size());
    }
  }
  if (check.triangles != static_scene.triangles || check.removed.total() != static_scene.removed.total())
    fail("the animation's rest pose (" + std::to_string(check.triangles.size()) +
         " triangles) does not reproduce the static load (" + std::to_string(static_scene.triangles.size()) +
         " triangles); triangle indices would not match across frames");
}

// Morph targets first, then the node transform (`rigid`) or linear blend skinning.
void GltfAnimation::Impl::transform_vertices(const PrimitiveData& d, const Affine* rigid,
                                             std::span<const Affine> joint_matrices,
                                             const std::vector<double>* morph, std::span<Vec3> out) const {
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, d.positions.size(), kVertexGrain),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t v = r.begin(); v != r.end(); ++v) {
          // Morph targets (glTF 2.0, section 3.7.2.2): base + sum of w_k * delta_k.
          double x = d.positions[v].x, y = d.positions[v].y, z = d.positions[v].z;
          if (morph)
            for (std::size_t k = 0; k < d.targets.size(); ++k) {
              if (d.targets[k].empty()) continue;
              const double w = (*morph)[k];
              x += w * d.targets[k][v].x, y += w * d.targets[k][v].y, z += w * d.targets[k][v].z;
            }
          // Skinning (section 3.7.3): the weighted sum of the joint matrices.
          Affine blended{};
          if (!rigid)
            for (int k = 0; k < d.influences; ++k) {
              const std::size_t i = v * static_cast<std::size_t>(d.influences) + static_cast<std::size_t>(k);
              const double w = d.weights[i];
              if (w == 0.0) continue;
              const Affine& j = joint_matrices[d.joints[i]];
              for (int e = 0; e < 12; ++e) blended[e] += w * j[e];
            }
          const Affine& m = rigid ? *rigid : blended;
          // The same expression as transform_point, so an unanimated rigid mesh reproduces
          // the static load to the bit.
          out[v] = {to_float(m[0] * x + m[3] * y + m[6] * z + m[9]),
                    to_float(m[1] * x + m[4] * y + m[7] * z + m[10]),
                    to_float(m[2] * x + m[5] * y + m[8] * z + m[11])};
        }
      });
}

GltfAnimation::GltfAnimation(const std::filesystem::path& path, bool binary, const Scene& static_scene)
    : impl_(std::make_unique<Impl>()) {
  const tinygltf::Model model = load_gltf_model(path, binary);
  impl_->file = path.string();
  GltfReader reader(model, impl_->file);
  reader.check_required_extensions();
  impl_->read_nodes(reader);
  impl_->read_skins(reader);
  impl_->place(reader, static_scene);  // fills rest_weights, which read_animation checks against
  impl_->read_animation(reader);
}

GltfAnimation::~GltfAnimation() = default;
GltfAnimation::GltfAnimation(GltfAnimation&&) noexcept = default;
GltfAnimation& GltfAnimation::operator=(GltfAnimation&&) noexcept = default;

double GltfAnimation::start() const {
  return impl_->start;
}
double GltfAnimation::end() const {
  return impl_->end;
}

void GltfAnimation::positions_at(double t, std::vector<Triangle>& out) const {
  const Impl& a = *impl_;
  // Local transforms and morph weights at t: the rest values, overwritten by the animated channels.
  std::vector<Trs> trs = a.rest_trs;
  std::vector<std::vector<double>> weights = a.rest_weights;
  double value[4];
  for (const Channel& ch : a.channels) {
    const auto n = static_cast<std::size_t>(ch.node);
    if (ch.path == Path::kWeights) {
      ch.keys.evaluate(t, weights[n]);
      continue;
    }
    ch.keys.evaluate(t, std::span<double>(value, static_cast<std::size_t>(ch.keys.width())));
    if (ch.path == Path::kTranslation) std::copy_n(value, 3, trs[n].translation.begin());
    if (ch.path == Path::kRotation) std::copy_n(value, 4, trs[n].rotation.begin());
    if (ch.path == Path::kScale) std::copy_n(value, 3, trs[n].scale.begin());
  }
  const std::vector<Mat4> world = a.world_matrices(trs);

  // Joint matrices per skin: the joint's world transform times its inverse bind matrix.
  std::vector<std::vector<Affine>> joint_matrices(a.skins.size());
  for (std::size_t s = 0; s < a.skins.size(); ++s)
    for (std::size_t j = 0; j < a.skins[s].joints.size(); ++j)
      joint_matrices[s].push_back(affine_of(
          multiply(world[static_cast<std::size_t>(a.skins[s].joints[j])], a.skins[s].inverse_bind[j])));

  std::vector<Vec3> vertices(a.vertex_count);
  for (const Placement& p : a.placements) {
    const std::size_t node = static_cast<std::size_t>(p.node);
    const std::vector<double>* morph = weights[node].empty() ? nullptr : &weights[node];
    const std::span<Vec3> out_vertices(vertices.data() + p.first_vertex, p.data->positions.size());
    if (p.skin >= 0) {
      // A skinned mesh ignores its node's transform; the joints place it (glTF 2.0, section 3.7.3).
      a.transform_vertices(*p.data, nullptr, joint_matrices[static_cast<std::size_t>(p.skin)], morph,
                           out_vertices);
    } else {
      const Affine m = affine_of(world[node]);
      a.transform_vertices(*p.data, &m, {}, morph, out_vertices);
    }
  }

  const std::size_t count = a.kept_corners.size() / 3;
  out.resize(count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, kVertexGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                        out[i] = {vertices[a.kept_corners[3 * i]], vertices[a.kept_corners[3 * i + 1]],
                                  vertices[a.kept_corners[3 * i + 2]]};
                    });
}

}  // namespace sahbench
