// Animation evaluation (scenes/animation.h, gltf_animation.h, wave.h):
//  - skinning of a shared scene (CesiumMan) against a second, deliberately different implementation
//    written here: row-major matrices, T, R and S multiplied one by one, slerp as q0 (q0^-1 q1)^s
//    through the quaternion logarithm, each vertex blended as a weighted sum of transformed points;
//  - a hand-made glTF with morph targets (default and animated weights), a STEP translation, a LINEAR
//    rotation of a parent node, and a triangle the static load removes, with answers worked out here;
//  - every animated shared scene loads with its rest pose equal to the static load;
//  - the procedural wave and static scenes; malformed animations are errors naming the file and part.

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tiny_gltf.h>

#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>

#include "scenes/animation.h"
#include "scenes/load.h"
#include "scenes/scene_path.h"
#include "tests/scenes/gltf_bytes.h"
#include "tests/scenes/temp_dir.h"
#include "tests/support/prerequisites.h"

namespace sahbench {
namespace {

using test::Bytes;
using test::data_uri;
using test::error_message;
using test::TempDir;

// ---------------------------------------------------------------------------------------------------
// The independent skinning implementation.

using Row4 = std::array<double, 4>;
using Matrix = std::array<Row4, 4>;  // row-major: m[row][col]

Matrix identity() {
  Matrix m{};
  for (int i = 0; i < 4; ++i) m[i][i] = 1.0;
  return m;
}

Matrix operator*(const Matrix& a, const Matrix& b) {
  Matrix c{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) c[i][j] += a[i][k] * b[k][j];
  return c;
}

struct Quat {
  double w = 1, x = 0, y = 0, z = 0;
};

Quat operator*(const Quat& a, const Quat& b) {
  return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
          a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}

Quat conjugate(const Quat& q) {
  return {q.w, -q.x, -q.y, -q.z};
}

Quat normalised(const Quat& q) {
  const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  return {q.w / n, q.x / n, q.y / n, q.z / n};
}

// q^s for a unit quaternion, through the axis-angle form.
Quat power(const Quat& q, double s) {
  const double v = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
  if (v < 1e-15) return {};
  const double angle = std::atan2(v, q.w);  // half the rotation angle
  const double k = std::sin(s * angle) / v;
  return {std::cos(s * angle), q.x * k, q.y * k, q.z * k};
}

// Spherical interpolation as q0 (q0^-1 q1)^s, along the shorter arc.
Quat slerp_by_power(Quat a, Quat b, double s) {
  a = normalised(a), b = normalised(b);
  if (a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z < 0) b = {-b.w, -b.x, -b.y, -b.z};
  return normalised(a * power(conjugate(a) * b, s));
}

Matrix translation(double x, double y, double z) {
  Matrix m = identity();
  m[0][3] = x, m[1][3] = y, m[2][3] = z;
  return m;
}

Matrix scaling(double x, double y, double z) {
  Matrix m = identity();
  m[0][0] = x, m[1][1] = y, m[2][2] = z;
  return m;
}

// The rotation matrix of a unit quaternion, by rotating the three basis vectors (q v q*).
Matrix rotation(const Quat& q_in) {
  const Quat q = normalised(q_in);
  Matrix m = identity();
  for (int axis = 0; axis < 3; ++axis) {
    const Quat v{0, axis == 0 ? 1.0 : 0.0, axis == 1 ? 1.0 : 0.0, axis == 2 ? 1.0 : 0.0};
    const Quat r = q * v * conjugate(q);
    m[0][axis] = r.x, m[1][axis] = r.y, m[2][axis] = r.z;
  }
  return m;
}

std::array<double, 3> apply(const Matrix& m, const std::array<double, 3>& p) {
  std::array<double, 3> out{};
  for (int i = 0; i < 3; ++i) out[i] = m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3];
  return out;
}

// Float accessor data (tightly packed or strided), as doubles.
std::vector<double> accessor_values(const tinygltf::Model& model, int index) {
  const tinygltf::Accessor& acc = model.accessors.at(static_cast<std::size_t>(index));
  const tinygltf::BufferView& view = model.bufferViews.at(static_cast<std::size_t>(acc.bufferView));
  const auto& data = model.buffers.at(static_cast<std::size_t>(view.buffer)).data;
  const int n = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(acc.type));
  const std::size_t size = acc.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT            ? 4
                           : acc.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ? 2
                                                                                         : 1;
  const std::size_t stride = view.byteStride ? view.byteStride : size * static_cast<std::size_t>(n);
  std::vector<double> out;
  for (std::size_t i = 0; i < acc.count; ++i)
    for (int c = 0; c < n; ++c) {
      const unsigned char* p =
          data.data() + view.byteOffset + acc.byteOffset + i * stride + static_cast<std::size_t>(c) * size;
      if (size == 4) {
        float f;
        std::memcpy(&f, p, 4);
        out.push_back(f);
      } else if (size == 2) {
        uint16_t u;
        std::memcpy(&u, p, 2);
        out.push_back(u);
      } else {
        out.push_back(*p);
      }
    }
  return out;
}

// Linear interpolation of a channel at t by scanning the keyframes (LINEAR samplers only).
std::vector<double> sample(const tinygltf::Model& model, const tinygltf::AnimationSampler& s, double t,
                           int width, bool rotation) {
  EXPECT_EQ(s.interpolation, "LINEAR");
  const std::vector<double> times = accessor_values(model, s.input);
  const std::vector<double> values = accessor_values(model, s.output);
  auto key = [&](std::size_t k) {
    return std::vector<double>(values.begin() + static_cast<long>(k) * width,
                               values.begin() + static_cast<long>(k + 1) * width);
  };
  if (t <= times.front()) return key(0);
  if (t >= times.back()) return key(times.size() - 1);
  std::size_t k = 0;
  while (times[k + 1] <= t) ++k;
  const double s_param = (t - times[k]) / (times[k + 1] - times[k]);
  const auto a = key(k), b = key(k + 1);
  if (rotation) {
    const Quat q = slerp_by_power({a[3], a[0], a[1], a[2]}, {b[3], b[0], b[1], b[2]}, s_param);
    return {q.x, q.y, q.z, q.w};
  }
  std::vector<double> out(static_cast<std::size_t>(width));
  for (int i = 0; i < width; ++i) out[i] = a[i] + s_param * (b[i] - a[i]);
  return out;
}

// The skinned mesh of node `mesh_node` at time t, one triangle per three indices, in double.
std::vector<std::array<std::array<double, 3>, 3>> skinned_triangles(const tinygltf::Model& model,
                                                                    int mesh_node, double t) {
  const std::size_t n = model.nodes.size();
  // Local TRS at t: the node's own values, then the animated channels of the first animation.
  std::vector<std::vector<double>> tr(n), rot(n), sc(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& node = model.nodes[i];
    tr[i] = node.translation.empty() ? std::vector<double>{0, 0, 0} : node.translation;
    rot[i] = node.rotation.empty() ? std::vector<double>{0, 0, 0, 1} : node.rotation;
    sc[i] = node.scale.empty() ? std::vector<double>{1, 1, 1} : node.scale;
  }
  for (const auto& ch : model.animations.at(0).channels) {
    const auto& s = model.animations[0].samplers.at(static_cast<std::size_t>(ch.sampler));
    const auto node = static_cast<std::size_t>(ch.target_node);
    if (ch.target_path == "translation") tr[node] = sample(model, s, t, 3, false);
    if (ch.target_path == "rotation") rot[node] = sample(model, s, t, 4, true);
    if (ch.target_path == "scale") sc[node] = sample(model, s, t, 3, false);
  }
  std::vector<int> parent(n, -1);
  for (std::size_t i = 0; i < n; ++i)
    for (int c : model.nodes[i].children) parent[static_cast<std::size_t>(c)] = static_cast<int>(i);
  std::function<Matrix(std::size_t)> global = [&](std::size_t i) -> Matrix {
    const auto& node = model.nodes[i];
    Matrix local = identity();
    if (!node.matrix.empty()) {
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) local[r][c] = node.matrix[static_cast<std::size_t>(c * 4 + r)];
    } else {
      local = translation(tr[i][0], tr[i][1], tr[i][2]) *
              rotation({rot[i][3], rot[i][0], rot[i][1], rot[i][2]}) * scaling(sc[i][0], sc[i][1], sc[i][2]);
    }
    return parent[i] < 0 ? local : global(static_cast<std::size_t>(parent[i])) * local;
  };

  const auto& node = model.nodes.at(static_cast<std::size_t>(mesh_node));
  const auto& skin = model.skins.at(static_cast<std::size_t>(node.skin));
  const std::vector<double> ibm = accessor_values(model, skin.inverseBindMatrices);
  std::vector<Matrix> joint(skin.joints.size());
  for (std::size_t j = 0; j < joint.size(); ++j) {
    Matrix inverse_bind;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) inverse_bind[r][c] = ibm[16 * j + static_cast<std::size_t>(c * 4 + r)];
    joint[j] = global(static_cast<std::size_t>(skin.joints[j])) * inverse_bind;
  }

  std::vector<std::array<std::array<double, 3>, 3>> out;
  for (const auto& prim : model.meshes.at(static_cast<std::size_t>(node.mesh)).primitives) {
    const std::vector<double> pos = accessor_values(model, prim.attributes.at("POSITION"));
    const std::vector<double> joints = accessor_values(model, prim.attributes.at("JOINTS_0"));
    const std::vector<double> weights = accessor_values(model, prim.attributes.at("WEIGHTS_0"));
    const std::vector<double> indices = accessor_values(model, prim.indices);
    auto vertex = [&](std::size_t v) {
      // Each influence moves the point; the results are blended by weight.
      std::array<double, 3> sum{0, 0, 0};
      for (int k = 0; k < 4; ++k) {
        const double w = weights[4 * v + static_cast<std::size_t>(k)];
        if (w == 0) continue;
        const auto p = apply(joint[static_cast<std::size_t>(joints[4 * v + static_cast<std::size_t>(k)])],
                             {pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]});
        for (int i = 0; i < 3; ++i) sum[i] += w * p[i];
      }
      return sum;
    };
    for (std::size_t i = 0; i + 2 < indices.size(); i += 3)
      out.push_back({vertex(static_cast<std::size_t>(indices[i])),
                     vertex(static_cast<std::size_t>(indices[i + 1])),
                     vertex(static_cast<std::size_t>(indices[i + 2]))});
  }
  return out;
}

TEST(AnimationGltf, CesiumManSkinningMatchesAnIndependentImplementation) {
  SAHBENCH_REQUIRE_SHARED_SCENE("CesiumMan");
  const auto file = find_scene_file("CesiumMan");
  const AnimatedScene animated = load_animated("CesiumMan");
  ASSERT_TRUE(animated.animated());
  EXPECT_DOUBLE_EQ(animated.start, 0.0);
  EXPECT_NEAR(animated.end, 2.0, 1e-6);
  // With nothing removed at load, frame triangle i is the mesh's triangle i.
  ASSERT_EQ(animated.scene.removed.total(), 0u);

  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int,
                           const unsigned char*, int, void*) { return true; },
                        nullptr);
  ASSERT_TRUE(loader.LoadASCIIFromFile(&model, &err, &warn, file->string())) << err;
  int mesh_node = -1;
  for (std::size_t i = 0; i < model.nodes.size(); ++i)
    if (model.nodes[i].skin >= 0) mesh_node = static_cast<int>(i);
  ASSERT_GE(mesh_node, 0);

  std::vector<Triangle> got;
  // Between keyframes, on one, past the end (clamped), and before the start.
  for (double t : {0.37, 1.0, 1.8333, 2.5, -0.1}) {
    SCOPED_TRACE("t = " + std::to_string(t));
    animated.positions_at(t, got);
    const auto expected = skinned_triangles(model, mesh_node, t);
    ASSERT_EQ(got.size(), expected.size());
    // The figure is about 1.5 units tall, where a float's spacing is 1.2e-7: a few units in the last
    // place, as the two implementations round differently (measured: below 2e-7).
    constexpr double kTolerance = 1e-6;
    double worst = 0;
    for (std::size_t i = 0; i < got.size(); ++i) {
      const Vec3 v[3] = {got[i].v0, got[i].v1, got[i].v2};
      for (int c = 0; c < 3; ++c)
        for (int a = 0; a < 3; ++a)
          worst = std::max(worst, std::abs(double(v[c][static_cast<std::size_t>(a)]) - expected[i][c][a]));
    }
    EXPECT_LT(worst, kTolerance);
  }
  // The animation moves the figure: frames differ from each other.
  std::vector<Triangle> other;
  animated.positions_at(0.5, other);
  animated.positions_at(1.5, got);
  EXPECT_NE(got, other);
}

// ---------------------------------------------------------------------------------------------------
// A hand-made file: morph targets, node animation, and a triangle removed at load.

// Nine vertices, three unindexed triangles: A in z = 0, B collinear (zero area: the static load
// removes it), C in z = 1. Target 0 lifts vertex 1 by (0, 0, 1); target 1 moves every vertex by
// (0, 2, 0). Node 1 (the root) turns about z from 0 to 90 degrees over [0, 2] s (LINEAR); node 0, its
// child, holds the mesh and jumps from (0, 0, 0) to (0, 5, 0) at t = 1 (STEP). The weights go from
// (0, 0) to (1, 0.5) over [0, 2] s; the mesh's default weights are (0.5, 0).
std::string morph_file(const std::string& interpolation_override = "",
                       const std::string& extra_channel = "") {
  Bytes b;
  const float base[9][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {3, 0, 0},
                            {4, 0, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
  for (const auto& p : base) b.vec3(p[0], p[1], p[2]);             // 0: 108 bytes
  for (int v = 0; v < 9; ++v) b.vec3(0, 0, v == 1 ? 1.0f : 0.0f);  // 108: target 0
  for (int v = 0; v < 9; ++v) b.vec3(0, 2, 0);                     // 216: target 1
  b.f32(0).f32(2);                                                 // 324: times 0, 2
  b.f32(0).f32(0).f32(1).f32(0.5f);                                // 332: weights
  const double s45 = std::sin(std::numbers::pi / 4);
  b.f32(0).f32(0).f32(0).f32(1).f32(0).f32(0).f32(float(s45)).f32(float(s45));  // 348: rotations
  b.f32(0).f32(1);                                                              // 380: times 0, 1
  b.vec3(0, 0, 0).vec3(0, 5, 0);                                                // 388: translations
  const std::string interp = interpolation_override.empty() ? "LINEAR" : interpolation_override;
  return R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [1]}],
  "nodes": [{"mesh": 0}, {"children": [0]}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "targets": [{"POSITION": 1}, {"POSITION": 2}]}],
              "weights": [0.5, 0]}],
  "animations": [{
    "channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}},
                 {"sampler": 1, "target": {"node": 1, "path": "rotation"}},
                 {"sampler": 2, "target": {"node": 0, "path": "translation"}})" +
         extra_channel + R"(],
    "samplers": [{"input": 3, "output": 4, "interpolation": ")" +
         interp + R"("},
                 {"input": 3, "output": 5},
                 {"input": 6, "output": 7, "interpolation": "STEP"}]
  }],
  "buffers": [{"uri": ")" +
         data_uri(b) + R"(", "byteLength": )" + std::to_string(b.size()) + R"(}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 108},
                  {"buffer": 0, "byteOffset": 108, "byteLength": 108},
                  {"buffer": 0, "byteOffset": 216, "byteLength": 108},
                  {"buffer": 0, "byteOffset": 324, "byteLength": 8},
                  {"buffer": 0, "byteOffset": 332, "byteLength": 16},
                  {"buffer": 0, "byteOffset": 348, "byteLength": 32},
                  {"buffer": 0, "byteOffset": 380, "byteLength": 8},
                  {"buffer": 0, "byteOffset": 388, "byteLength": 24}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 9, "type": "VEC3"},
                {"bufferView": 1, "componentType": 5126, "count": 9, "type": "VEC3"},
                {"bufferView": 2, "componentType": 5126, "count": 9, "type": "VEC3"},
                {"bufferView": 3, "componentType": 5126, "count": 2, "type": "SCALAR"},
                {"bufferView": 4, "componentType": 5126, "count": 4, "type": "SCALAR"},
                {"bufferView": 5, "componentType": 5126, "count": 2, "type": "VEC4"},
                {"bufferView": 6, "componentType": 5126, "count": 2, "type": "SCALAR"},
                {"bufferView": 7, "componentType": 5126, "count": 2, "type": "VEC3"}]
})";
}

// The expected position of base vertex `v` at time t, worked out from the description above.
Vec3 morph_expected(int v, double t) {
  const float base[9][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {3, 0, 0},
                            {4, 0, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
  const double s = std::clamp(t / 2.0, 0.0, 1.0);
  const double w0 = s, w1 = 0.5 * s;
  double x = base[v][0], y = base[v][1] + 2.0 * w1, z = base[v][2] + (v == 1 ? w0 : 0.0);
  y += t >= 1.0 ? 5.0 : 0.0;                      // the child's STEP translation
  const double angle = s * std::numbers::pi / 2;  // the parent's rotation about z
  return {float(std::cos(angle) * x - std::sin(angle) * y), float(std::sin(angle) * x + std::cos(angle) * y),
          float(z)};
}

void expect_vec_near(const Vec3& a, const Vec3& b) {
  EXPECT_NEAR(a.x, b.x, 1e-5f);
  EXPECT_NEAR(a.y, b.y, 1e-5f);
  EXPECT_NEAR(a.z, b.z, 1e-5f);
}

TEST(AnimationGltf, MorphTargetsNodeAnimationAndRemovedTriangles) {
  TempDir dir;
  const auto path = dir.write("morph.gltf", morph_file());
  const AnimatedScene animated = load_animated(path.string());
  ASSERT_TRUE(animated.animated());
  ASSERT_EQ(animated.scene.triangles.size(), 2u);
  EXPECT_EQ(animated.scene.removed.zero_area, 1u);
  EXPECT_DOUBLE_EQ(animated.start, 0.0);
  EXPECT_DOUBLE_EQ(animated.end, 2.0);
  EXPECT_EQ(animated.frame_times(5), (std::vector<double>{0.0, 0.5, 1.0, 1.5, 2.0}));

  std::vector<Triangle> got;
  for (double t : {0.0, 0.4, 0.99, 1.0, 1.3, 2.0, 3.0}) {
    SCOPED_TRACE("t = " + std::to_string(t));
    animated.positions_at(t, got);
    ASSERT_EQ(got.size(), 2u) << "the triangle removed at load stays out of every frame";
    // Frame triangle 0 is A (vertices 0, 1, 2), triangle 1 is C (vertices 6, 7, 8): B is skipped.
    expect_vec_near(got[0].v0, morph_expected(0, t));
    expect_vec_near(got[0].v1, morph_expected(1, t));
    expect_vec_near(got[0].v2, morph_expected(2, t));
    expect_vec_near(got[1].v0, morph_expected(6, t));
    expect_vec_near(got[1].v1, morph_expected(7, t));
    expect_vec_near(got[1].v2, morph_expected(8, t));
  }
}

TEST(AnimationGltf, DefaultMorphWeightsApplyWithoutAWeightsChannel) {
  TempDir dir;
  // Without the weights channel the mesh's default weights (0.5, 0) hold: vertex 1 is lifted by 0.5.
  std::string json = morph_file();
  const std::string channel = R"({"sampler": 0, "target": {"node": 0, "path": "weights"}},)";
  json.erase(json.find(channel), channel.size());
  const auto path = dir.write("defaults.gltf", json);
  const AnimatedScene animated = load_animated(path.string());
  std::vector<Triangle> got;
  animated.positions_at(0.0, got);
  ASSERT_EQ(got.size(), 2u);
  expect_vec_near(got[0].v1, {1, 0, 0.5f});
  expect_vec_near(got[0].v0, {0, 0, 0});
}

TEST(AnimationGltf, MalformedAnimationsNameTheFileAndChannel) {
  TempDir dir;
  const std::pair<std::string, std::string> cases[] = {
      {morph_file("SMOOTH"), "SMOOTH"},
      {morph_file("", R"(, {"sampler": 0, "target": {"node": 1, "path": "weights"}})"), "no morph targets"},
      {morph_file("", R"(, {"sampler": 9, "target": {"node": 0, "path": "scale"}})"), "channel 3: sampler 9"},
      // A weights channel reading the rotation sampler, whose output is VEC4.
      {morph_file("", R"(, {"sampler": 1, "target": {"node": 0, "path": "weights"}})"), "is not SCALAR"},
  };
  for (const auto& [json, expected] : cases) {
    const auto path = dir.write("broken.gltf", json);
    const std::string msg = error_message([&] { load_animated(path.string()); });
    EXPECT_NE(msg.find(path.string()), std::string::npos) << msg;
    EXPECT_NE(msg.find(expected), std::string::npos) << "expected '" << expected << "' in: " << msg;
  }
}

// ---------------------------------------------------------------------------------------------------
// Shared scenes, the procedural wave, static scenes.

TEST(AnimationShared, AnimatedSharedScenesLineUpWithTheStaticLoad) {
  test::Skips skips;
  for (const char* name : {"RiggedFigure", "CesiumMan", "BrainStem"}) {
    if (!skips.have_scene(name)) continue;
    SCOPED_TRACE(name);
    // load_animated checks that its rest pose reproduces the static load triangle for triangle.
    const AnimatedScene animated = load_animated(name);
    ASSERT_TRUE(animated.animated());
    EXPECT_GT(animated.end, animated.start);
    std::vector<Triangle> a, b;
    animated.positions_at(animated.start, a);
    animated.positions_at(0.5 * (animated.start + animated.end), b);
    ASSERT_EQ(a.size(), animated.scene.triangles.size());
    ASSERT_EQ(b.size(), animated.scene.triangles.size());
    EXPECT_NE(a, b);
    for (const Triangle& t : b) ASSERT_TRUE(is_finite(t.v0) && is_finite(t.v1) && is_finite(t.v2));
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

TEST(AnimationWave, LoopsIsDeterministicAndStartsAtTheStaticScene) {
  const AnimatedScene animated = load_animated("proc:wave:tris=2000,seed=3");
  ASSERT_TRUE(animated.animated());
  EXPECT_TRUE(animated.scene.animated);
  EXPECT_EQ(animated.start, 0.0);
  EXPECT_EQ(animated.end, 1.0);
  std::vector<Triangle> t0, t1, mid, again;
  animated.positions_at(0.0, t0);
  EXPECT_EQ(t0, animated.scene.triangles);
  animated.positions_at(1.0, t1);  // one period later: the same surface up to rounding
  ASSERT_EQ(t1.size(), t0.size());
  for (std::size_t i = 0; i < t0.size(); ++i) {
    ASSERT_NEAR(t1[i].v0.x, t0[i].v0.x, 1e-5f);
    ASSERT_NEAR(t1[i].v0.y, t0[i].v0.y, 1e-5f);
  }
  animated.positions_at(0.3, mid);
  EXPECT_NE(mid, t0);
  {
    const tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    animated.positions_at(0.3, again);
  }
  EXPECT_EQ(again, mid);
  // Sideways motion as well as vertical (Gerstner waves), so that boxes change in every axis.
  double dx = 0, dy = 0;
  for (std::size_t i = 0; i < t0.size(); ++i) {
    dx = std::max(dx, double(std::abs(mid[i].v0.x - t0[i].v0.x)));
    dy = std::max(dy, double(std::abs(mid[i].v0.y - t0[i].v0.y)));
  }
  EXPECT_GT(dx, 0.005);
  EXPECT_GT(dy, 0.01);
}

TEST(AnimationStatic, StaticScenesLoadWithoutAnimation) {
  const AnimatedScene animated = load_animated("proc:sphere:tris=200");
  EXPECT_FALSE(animated.animated());
  EXPECT_FALSE(animated.scene.animated);
  std::vector<Triangle> got;
  animated.positions_at(3.0, got);
  EXPECT_EQ(got, animated.scene.triangles);
  EXPECT_EQ(animated.frame_times(3), (std::vector<double>{0.0, 0.0, 0.0}));
  EXPECT_EQ(animated.frame_times(1), std::vector<double>{0.0});
}

}  // namespace
}  // namespace sahbench
