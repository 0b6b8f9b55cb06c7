// The kernels at the edges of float, against the exact reference, in every layout and on every
// instruction set available here:
// - the distance of a hit on thin triangles: the watertight test returns t within kMaxUlps of the exact
//   distance for rays that cross a 1000:1 needle well inside it and at a fair angle (triangle_tests.h:
//   plane_distance_in_double says why the float t was thousands of ulps off);
// - the fast variants outside their float range: box=fma on axis-parallel rays through triangles 1e-20
//   across and from origins at 1e21 (ray_box.h: FmaRayBox's domain), tri=mtn on closed meshes at the
//   1e13, 1e30 and 1e-18 scales (triangle_tests.h: MollerTrumboreNormalTest's range) miss nothing the
//   exact reference hits, with both edges of each range taken.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "builders/registry.h"
#include "harness/run/ray_sets.h"
#include "scenes/rng.h"
#include "scenes/stress_cases.h"
#include "tests/support/prerequisites.h"
#include "traversal/exact_reference.h"
#include "traversal/layout.h"
#include "traversal/triangle_tests.h"
#include "traversal/ulp_distance.h"

namespace sahbench {
namespace {

// The bound stated in the README for non-grazing hits (|cos| >= kMinCosine between ray and normal):
// the distance is rounded once from a double computation whose own error is far below half an ulp.
constexpr uint32_t kMaxUlps = 1;
constexpr double kMinCosine = 0.3;
constexpr double kAspect = 1000.0;

struct NeedleScene {
  std::vector<Triangle> triangles;
  std::vector<Ray> rays;  ///< ray i is aimed at triangle i
};

Vec3 to_vec(double x, double y, double z) {
  return {static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)};
}

// Needles of length 1 to 10 and width length / kAspect in random orientations, one per cell of a grid
// spaced 12 apart around (100, 100, 100), each with one ray that crosses it at barycentrics of at least
// 0.15 and at |cos| >= kMinCosine to its normal, from 2 to 8 units away.
NeedleScene needles(uint64_t seed) {
  SplitMix64 rng(seed);
  auto unit = [&] {
    while (true) {
      const double x = rng.uniform(-1, 1), y = rng.uniform(-1, 1), z = rng.uniform(-1, 1);
      const double n = std::sqrt(x * x + y * y + z * z);
      if (n > 0.1 && n <= 1.0) return std::array<double, 3>{x / n, y / n, z / n};
    }
  };
  auto cross = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                 a[0] * b[1] - a[1] * b[0]};
  };
  NeedleScene scene;
  for (int gx = 0; gx < 6; ++gx)
    for (int gy = 0; gy < 6; ++gy)
      for (int gz = 0; gz < 6; ++gz) {
        const std::array<double, 3> centre = {70.0 + 12 * gx + rng.uniform(-0.5, 0.5),
                                              70.0 + 12 * gy + rng.uniform(-0.5, 0.5),
                                              70.0 + 12 * gz + rng.uniform(-0.5, 0.5)};
        const std::array<double, 3> along = unit();
        std::array<double, 3> across = cross(along, unit());
        const double across_norm = std::hypot(across[0], across[1], across[2]);
        if (across_norm < 0.1) continue;
        for (double& c : across) c /= across_norm;
        const std::array<double, 3> normal = cross(along, across);
        const double length = rng.uniform(1.0, 10.0), width = length / kAspect;
        Triangle tri;
        tri.v0 = to_vec(centre[0] - along[0] * length / 2, centre[1] - along[1] * length / 2,
                        centre[2] - along[2] * length / 2);
        tri.v1 = to_vec(centre[0] + along[0] * length / 2, centre[1] + along[1] * length / 2,
                        centre[2] + along[2] * length / 2);
        tri.v2 = to_vec(centre[0] + across[0] * width, centre[1] + across[1] * width,
                        centre[2] + across[2] * width);
        // A point well inside, and a direction at a fair angle to the normal.
        const double w1 = rng.uniform(0.15, 0.7), w2 = rng.uniform(0.15, 0.85 - w1), w0 = 1.0 - w1 - w2;
        std::array<double, 3> target;
        for (int k = 0; k < 3; ++k)
          target[k] = w0 * tri.v0[static_cast<std::size_t>(k)] + w1 * tri.v1[static_cast<std::size_t>(k)] +
                      w2 * tri.v2[static_cast<std::size_t>(k)];
        std::array<double, 3> dir = unit();
        if (std::abs(dir[0] * normal[0] + dir[1] * normal[1] + dir[2] * normal[2]) < kMinCosine + 0.05)
          continue;
        const double distance = rng.uniform(2.0, 8.0);
        Ray ray;
        ray.org = to_vec(target[0] - dir[0] * distance, target[1] - dir[1] * distance,
                         target[2] - dir[2] * distance);
        ray.dir = to_vec(dir[0], dir[1], dir[2]);
        ray.tmax = static_cast<float>(distance + 0.5);
        scene.triangles.push_back(tri);
        scene.rays.push_back(ray);
      }
  return scene;
}

// |cos| between the float ray and the float triangle's normal, in double.
double cosine(const Ray& ray, const Triangle& tri) {
  const Vec3 e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
  const double nx = static_cast<double>(e1.y) * e2.z - static_cast<double>(e1.z) * e2.y;
  const double ny = static_cast<double>(e1.z) * e2.x - static_cast<double>(e1.x) * e2.z;
  const double nz = static_cast<double>(e1.x) * e2.y - static_cast<double>(e1.y) * e2.x;
  const double d = nx * ray.dir.x + ny * ray.dir.y + nz * ray.dir.z;
  return std::abs(d) / (std::hypot(nx, ny, nz) * std::hypot(ray.dir.x, ray.dir.y, ray.dir.z));
}

// A tree of `triangles` for `layout`: binned SAH for the binary layouts, the wide collapse of its arity
// for the others.
Bvh tree_for(const LayoutInfo& layout, const std::vector<Triangle>& triangles) {
  const BuilderInfo& builder = find_builder(layout.arity == 2 ? "binned_sah" : "wide_collapse");
  const ParamOverrides overrides =
      layout.arity == 2 ? ParamOverrides{} : ParamOverrides{{"arity", std::to_string(layout.arity)}};
  return builder.build(BuildInput::from_triangles(triangles),
                       resolve_params(builder.name, builder.params, overrides));
}

// The watertight variant of every layout on every instruction set available here.
std::vector<std::string> watertight_specs(const LayoutInfo& layout, test::Skips& skips) {
  std::vector<std::string> out;
  if (!layout.has_isa) {
    out.push_back(layout.name + ":tri=watertight");
    // The binary layouts' packet kernels, with the instruction set isa=auto picks and with AVX2's.
    if (layout.has_packet && skips.have_isa(KernelIsa::kAvx2)) out.push_back(layout.name + ":packet=8");
    if (layout.has_packet && skips.have_isa(KernelIsa::kAvx512)) {
      out.push_back(layout.name + ":packet=16");
      out.push_back(layout.name + ":packet=8,isa=avx2");
    }
    return out;
  }
  for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kSse, KernelIsa::kAvx2, KernelIsa::kAvx512})
    if (skips.have_isa(isa))
      out.push_back(layout.name + ":tri=watertight,isa=" + std::string(to_string(isa)));
  return out;
}

TEST(FloatEdges, WatertightTIsWithinAnUlpOfExactOnNeedles) {
  const NeedleScene scene = needles(17);
  ASSERT_GT(scene.rays.size(), 100u);
  const ExactReference reference(scene.triangles);
  const std::vector<ExactHit> exact = reference.closest(scene.rays);

  // The rays whose exact closest hit is their own needle (another needle may lie in front).
  std::vector<std::size_t> own;
  for (std::size_t i = 0; i < scene.rays.size(); ++i)
    if (exact[i].found() && exact[i].accepts(static_cast<uint32_t>(i)) &&
        cosine(scene.rays[i], scene.triangles[i]) >= kMinCosine)
      own.push_back(i);
  ASSERT_GT(own.size(), scene.rays.size() * 9 / 10);

  // The scalar test on its own triangle.
  uint32_t worst = 0;
  for (std::size_t i : own) {
    float t = 0, u = 0, v = 0;
    const WatertightTriangleTest test(scene.rays[i]);
    ASSERT_TRUE(test.intersect(scene.triangles[i], scene.rays[i].tmin, scene.rays[i].tmax, t, u, v))
        << "ray " << i;
    worst = std::max(worst, ulp_distance(t, exact[i].t));
  }
  EXPECT_LE(worst, kMaxUlps) << "WatertightTriangleTest";

  // Every layout's watertight kernels, on a tree of the needles.
  test::Skips skips;
  for (const LayoutInfo& layout : layouts()) {
    const Bvh bvh = tree_for(layout, scene.triangles);
    for (const std::string& spec : watertight_specs(layout, skips)) {
      SCOPED_TRACE(spec);
      const auto compiled = compile_layout(spec, bvh, scene.triangles);
      std::vector<Hit> hits(scene.rays.size());
      compiled->trace_closest(scene.rays, hits);
      uint32_t layout_worst = 0;
      for (std::size_t i : own) {
        ASSERT_TRUE(exact[i].accepts(hits[i].prim)) << "ray " << i << " hit " << hits[i].prim;
        layout_worst = std::max(layout_worst, ulp_distance(hits[i].t, exact[i].t));
      }
      EXPECT_LE(layout_worst, kMaxUlps);
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

// Every layout's variants with `option` (box=fma or tri=mtn), on every instruction set available here.
std::vector<std::string> specs_with(const LayoutInfo& layout, const std::string& option, test::Skips& skips) {
  std::vector<std::string> out;
  for (const char* other : option.starts_with("box=") ? std::vector<const char*>{"tri=watertight", "tri=mtn"}
                                                      : std::vector<const char*>{"box=robust", "box=fma"}) {
    const std::string variant = layout.name + ":" + option + "," + other;
    if (!layout.has_isa) {
      out.push_back(variant);
      if (layout.has_packet && skips.have_isa(KernelIsa::kAvx512)) {
        out.push_back(variant + ",packet=16");
        out.push_back(variant + ",packet=8,isa=avx2");
      }
      continue;
    }
    for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kSse, KernelIsa::kAvx2, KernelIsa::kAvx512})
      if (skips.have_isa(isa)) out.push_back(variant + ",isa=" + std::string(to_string(isa)));
  }
  return out;
}

// Every layout variant with `option` traces `rays` among `triangles`: no ray the exact reference hits is
// missed, closest and any hit, and every closest hit is on a primitive hit at the exact distance.
void expect_no_false_misses(const std::vector<Triangle>& triangles, const std::vector<Ray>& rays,
                            const std::string& option, test::Skips& skips) {
  const ExactReference reference(triangles);
  const std::vector<ExactHit> exact = reference.closest(rays);
  std::size_t exact_hits = 0;
  for (const ExactHit& e : exact) exact_hits += e.found();
  ASSERT_GT(exact_hits, rays.size() * 9 / 10);
  for (const LayoutInfo& layout : layouts()) {
    const Bvh bvh = tree_for(layout, triangles);
    for (const std::string& spec_text : specs_with(layout, option, skips)) {
      SCOPED_TRACE(spec_text);
      const auto compiled = compile_layout(spec_text, bvh, triangles);
      std::vector<Hit> hits(rays.size());
      std::vector<uint8_t> occluded(rays.size(), 0);
      compiled->trace_closest(rays, hits);
      compiled->trace_any(rays, occluded);
      std::size_t misses = 0, any_misses = 0, wrong = 0;
      for (std::size_t i = 0; i < rays.size(); ++i) {
        if (!exact[i].found()) continue;
        misses += !hits[i].found();
        any_misses += !occluded[i];
        wrong += hits[i].found() && !exact[i].accepts(hits[i].prim);
      }
      EXPECT_EQ(misses, 0u);
      EXPECT_EQ(any_misses, 0u);
      EXPECT_EQ(wrong, 0u);
    }
  }
}

// Secondary rays start at a surface point moved off the surface (offset_ray_origin, as the ray sets do)
// and may leave it at a shallow angle. On a large triangle, across coordinates of about 100, the float
// vertex transform of the watertight test rounds by more than that offset, and its float distance to the
// surface left behind can come out as -0 or just above 0 where the exact one is below 0 (Sponza's floor,
// whose two triangles these are like, did so for 0.08% of its AO rays). Every layout's watertight
// variant, packets included, must find no hit for rays leaving the floor upwards, closest or any, as the
// exact reference finds none; and for rays from the same origins heading down into the floor, which the
// exact reference hits a hair away, any hit must agree with closest hit ray by ray.
TEST(FloatEdges, RaysLeavingASurfaceAreNotOccludedByIt) {
  // A floor of two triangles over x in [-143, 130] and z in [-64, 57], 6e-5 higher at z = -64, and 64
  // small triangles 20 below it, so that every tree has inner nodes and the packet kernels run.
  const Vec3 a{-143.0f, -0.250648f, 57.403f}, b{130.219f, -0.250648f, 57.403f},
      c{130.219f, -0.250589f, -64.336f}, d{-143.0f, -0.250589f, -64.336f};
  std::vector<Triangle> scene{{a, b, c}, {a, c, d}};
  for (int i = 0; i < 64; ++i) {
    const float x = -140.0f + 4.0f * static_cast<float>(i), y = -20.0f,
                z = -60.0f + 1.5f * static_cast<float>(i);
    scene.push_back({{x, y, z}, {x + 3.0f, y, z}, {x, y, z + 3.0f}});
  }
  SplitMix64 rng(7);
  std::vector<Ray> up, down;
  for (int f = 0; f < 2; ++f) {
    const Triangle& tri = scene[f];
    const Vec3 e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
    Vec3 n{e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
    n = n * ((n.y < 0.0f ? -1.0f : 1.0f) / length(n));  // up
    for (int k = 0; k < 2000; ++k) {
      // A point well inside the triangle, as a primary ray's hit point is rounded; origins moved up.
      double u = rng.uniform(0.05, 0.9), v = rng.uniform(0.05, 0.9);
      if (u + v > 0.95) u = 0.95 - u, v = 0.95 - v;
      const auto at = [&](int axis) {
        return static_cast<float>(tri.v0[axis] + u * (static_cast<double>(tri.v1[axis]) - tri.v0[axis]) +
                                  v * (static_cast<double>(tri.v2[axis]) - tri.v0[axis]));
      };
      Ray ray;
      ray.org = offset_ray_origin({at(0), at(1), at(2)}, n);
      // 3 to 40 degrees above the floor, so that a horizontal axis is the ray's largest and the shear mixes
      // the floor's coordinates into the distance.
      const double elevation = rng.uniform(0.05, 0.7), azimuth = rng.uniform(0.0, 2.0 * std::numbers::pi);
      ray.dir = {static_cast<float>(std::cos(elevation) * std::cos(azimuth)),
                 static_cast<float>(std::sin(elevation)),
                 static_cast<float>(std::cos(elevation) * std::sin(azimuth))};
      ray.tmax = 1000.0f;
      up.push_back(ray);
      ray.dir.y = -ray.dir.y;
      down.push_back(ray);
    }
  }
  const ExactReference reference(scene);
  for (const ExactHit& e : reference.closest(up)) ASSERT_FALSE(e.found());
  for (const ExactHit& e : reference.closest(down)) ASSERT_TRUE(e.found());
  test::Skips skips;
  for (const LayoutInfo& layout : layouts()) {
    const Bvh bvh = tree_for(layout, scene);
    std::vector<std::string> specs = watertight_specs(layout, skips);
    if (layout.has_isa && skips.have_isa(KernelIsa::kAvx2)) specs.push_back(layout.name + ":packet=8");
    if (layout.has_isa && skips.have_isa(KernelIsa::kAvx512)) specs.push_back(layout.name + ":packet=16");
    for (const std::string& spec_text : specs) {
      SCOPED_TRACE(spec_text);
      const auto compiled = compile_layout(spec_text, bvh, scene);
      for (const std::vector<Ray>* rays : {&up, &down}) {
        std::vector<Hit> hits(rays->size());
        std::vector<uint8_t> occluded(rays->size(), 0);
        compiled->trace_closest(*rays, hits);
        compiled->trace_any(*rays, occluded);
        std::size_t found = 0, disagree = 0;
        for (std::size_t i = 0; i < rays->size(); ++i) {
          found += hits[i].found();
          disagree += hits[i].found() != (occluded[i] != 0);
        }
        if (rays == &up) {
          EXPECT_EQ(found, 0u) << "rays leaving the floor";
        } else {
          EXPECT_GT(found, rays->size() / 2) << "rays into the floor";
        }
        EXPECT_EQ(disagree, 0u) << (rays == &up ? "rays leaving the floor" : "rays into the floor");
      }
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

StressCaseSpec stress_case(const std::string& kind, double scale, double offset, uint32_t rays) {
  StressCaseSpec spec;
  spec.name = kind;
  spec.kind = kind;
  spec.size = kind == "sphere" ? 320 : rays;
  spec.rays = rays;
  spec.scale = scale;
  spec.offset = offset;
  return spec;
}

// The stress suite's generator for box=fma's edge: axis-parallel rays, each through the inside of a
// triangle `scale` across it, from `offset` on its axis.
TEST(FloatEdges, FmaBoxTestMissesNothingOnAxisRaysThroughThinTrianglesAndFromFarOrigins) {
  test::Skips skips;
  for (const auto& [scale, offset] : {std::pair{1e-3, 0.0}, {1e-20, 0.0}, {1e-3, 1e21}}) {
    const StressCase c = generate_stress_case(stress_case("axis_thin", scale, offset, 300));
    SCOPED_TRACE(testing::Message() << "axis_thin at scale " << scale << ", offset " << offset);
    ASSERT_EQ(c.scene.removed.total(), 0u);
    expect_no_false_misses(c.scene.triangles, c.rays, "box=fma", skips);
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

// The stress suite's icospheres at scales inside tri=mtn's float range (1e11: edges and coordinates
// within 2^40) and outside it (1e13 just beyond, 1e30, and 1e-18 where the normals are below 2^-60),
// each ray from the centre through a point well inside a face, so that no edge is near it (Möller–
// Trumbore is not watertight: rays through edges are not this test's subject). Unit directions and
// directions as long as the sphere's radius take both the ray's and the triangle's side of the range.
TEST(FloatEdges, StoredNormalTestMissesNothingAtExtremeScales) {
  test::Skips skips;
  for (double scale : {1e11, 1e13, 1e30, 1e-18}) {
    const StressCase c = generate_stress_case(stress_case("sphere", scale, 0.0, 1));
    SCOPED_TRACE(testing::Message() << "sphere at scale " << scale);
    ASSERT_EQ(c.scene.removed.total(), 0u);
    const std::vector<Triangle>& tris = c.scene.triangles;
    std::vector<Ray> rays;
    SplitMix64 rng(5);
    for (std::size_t k = 0; k < tris.size(); ++k) {
      const double w1 = rng.uniform(0.2, 0.5), w2 = rng.uniform(0.2, 0.5), w0 = 1.0 - w1 - w2;
      const Vec3 target = to_vec(w0 * tris[k].v0.x + w1 * tris[k].v1.x + w2 * tris[k].v2.x,
                                 w0 * tris[k].v0.y + w1 * tris[k].v1.y + w2 * tris[k].v2.y,
                                 w0 * tris[k].v0.z + w1 * tris[k].v1.z + w2 * tris[k].v2.z);
      const double length = std::hypot(target.x, target.y, target.z);
      rays.push_back(Ray{{0, 0, 0}, 0.0f, target, std::numeric_limits<float>::infinity()});
      rays.push_back(Ray{{0, 0, 0},
                         0.0f,
                         to_vec(target.x / length, target.y / length, target.z / length),
                         std::numeric_limits<float>::infinity()});
    }
    expect_no_false_misses(tris, rays, "tri=mtn", skips);
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

}  // namespace
}  // namespace sahbench
