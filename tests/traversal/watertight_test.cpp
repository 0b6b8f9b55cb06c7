// No leaks on a closed mesh: rays aimed exactly at the shared vertices and edges of test::cube_grid, from
// inside and from outside, must hit something, through the brute-force reference and through the BVH
// kernels (whose conservative box test must not cull the triangle either).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <set>
#include <tuple>
#include <vector>

#include "tests/support/test_scenes.h"
#include "tests/traversal/median_builder.h"
#include "traversal/brute_force.h"
#include "traversal/bvh2_traversal.h"
#include "traversal/triangle_tests.h"

namespace sahbench {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// 8 quads per side of a cube of half size 1: every vertex coordinate is a multiple of 1/4 and every edge
// midpoint a multiple of 1/8, so targets and dyadic origins below are exact and their differences too.
constexpr int kQuadsPerSide = 8;
constexpr float kHalfSize = 1.0f;

struct Point {
  float x, y, z;
  auto operator<=>(const Point&) const = default;
};

// Every vertex and every edge midpoint of the mesh, once each.
std::vector<Vec3> shared_points(const std::vector<Triangle>& mesh) {
  std::set<Point> points;
  auto add = [&](Vec3 p) { points.insert({p.x, p.y, p.z}); };
  for (const Triangle& t : mesh) {
    for (Vec3 p : {t.v0, t.v1, t.v2, (t.v0 + t.v1) * 0.5f, (t.v1 + t.v2) * 0.5f, (t.v2 + t.v0) * 0.5f})
      add(p);
  }
  std::vector<Vec3> out;
  for (const Point& p : points) out.push_back({p.x, p.y, p.z});
  return out;
}

// Leak counts of each kernel over a set of rays that all must hit.
struct Leaks {
  int rays = 0;
  int brute_watertight = 0;
  int bvh_closest = 0;   // WatertightTriangleTest + RobustRayBox
  int bvh_any = 0;       // WatertightTriangleTest + RobustRayBox
  int bvh_fast_box = 0;  // WatertightTriangleTest + FastRayBox, reported only
  int brute_moller = 0;  // MollerTrumboreTest, default epsilon, reported only

  void add(const Bvh& bvh, const std::vector<Triangle>& mesh, const Ray& ray) {
    ++rays;
    brute_watertight += brute_force_any(mesh, ray) ? 0 : 1;
    bvh_closest += closest_hit(bvh, mesh, ray).found() ? 0 : 1;
    bvh_any += any_hit(bvh, mesh, ray) ? 0 : 1;
    bvh_fast_box += closest_hit<WatertightTriangleTest, FastRayBox>(bvh, mesh, ray).found() ? 0 : 1;
    brute_moller += brute_force_any<MollerTrumboreTest>(mesh, ray) ? 0 : 1;
  }

  void expect_none(const char* what) const {
    EXPECT_GT(rays, 1000);
    EXPECT_EQ(brute_watertight, 0);
    EXPECT_EQ(bvh_closest, 0);
    EXPECT_EQ(bvh_any, 0);
    std::printf(
        "[ info ] %s: %d rays; leaks: watertight %d, BVH closest %d, BVH any %d; "
        "reported only: FastRayBox %d, Moller-Trumbore %d\n",
        what, rays, brute_watertight, bvh_closest, bvh_any, bvh_fast_box, brute_moller);
  }
};

class TravWatertight : public ::testing::Test {
 protected:
  const std::vector<Triangle> mesh_ = test::cube_grid(kQuadsPerSide, kHalfSize);
  const Bvh bvh_ = test::build_median_bvh(mesh_);
  const std::vector<Vec3> targets_ = shared_points(mesh_);
};

TEST_F(TravWatertight, NoLeaksFromInside) {
  // Dyadic origins (the ray passes exactly through the target) and random ones (it passes within
  // rounding of it), including the centre, from which face centres are reached along an axis.
  std::vector<Vec3> origins{{0.0f, 0.0f, 0.0f},
                            {0.125f, -0.375f, 0.25f},
                            {-0.5f, 0.625f, -0.875f},
                            {0.9375f, 0.0f, -0.0625f},
                            {-0.0f, 0.5f, -0.0f}};
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> inside(-0.95f, 0.95f);
  for (int i = 0; i < 3; ++i) origins.push_back({inside(rng), inside(rng), inside(rng)});
  Leaks leaks;
  for (const Vec3& org : origins)
    for (const Vec3& target : targets_) leaks.add(bvh_, mesh_, {org, 0.0f, target - org, kInf});
  leaks.expect_none("from inside");
}

TEST_F(TravWatertight, NoLeaksFromOutside) {
  // Targets strictly inside a face (not on the cube's own edges, which a ray from outside may graze),
  // approached from the outer side of that face.
  Leaks leaks;
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> offset(-0.7f, 0.7f);
  for (const Vec3& target : targets_) {
    std::size_t face_axis = 3;
    int on_boundary = 0;
    for (std::size_t a = 0; a < 3; ++a) {
      if (std::abs(target[a]) == kHalfSize) {
        face_axis = a;
        ++on_boundary;
      }
    }
    if (on_boundary != 1) continue;
    Vec3 normal{0.0f, 0.0f, 0.0f};
    normal[face_axis] = target[face_axis] > 0.0f ? 1.0f : -1.0f;
    const std::size_t t1 = (face_axis + 1) % 3, t2 = (face_axis + 2) % 3;
    Vec3 along1{}, along2{};
    along1[t1] = 1.0f;
    along2[t2] = 1.0f;
    const Vec3 origins[] = {
        target + normal * 1.0f,
        target + normal * 0.5f + along1 * 0.25f + along2 * 0.125f,
        target + normal * 2.0f - along1 * 0.75f + along2 * 0.5f,
        target + normal * 0.25f - along1 * 3.0f - along2 * 1.5f,  // shallow angle
        target + normal * (0.5f + std::abs(offset(rng))) + along1 * offset(rng) + along2 * offset(rng),
    };
    for (const Vec3& org : origins) leaks.add(bvh_, mesh_, {org, 0.0f, target - org, kInf});
    // Straight in along the axis, with every sign of the zero components.
    for (float z1 : {0.0f, -0.0f})
      for (float z2 : {0.0f, -0.0f}) {
        Vec3 dir = -normal;
        dir[t1] = z1;
        dir[t2] = z2;
        leaks.add(bvh_, mesh_, {target + normal, 0.0f, dir, kInf});
      }
  }
  leaks.expect_none("from outside");
}

// A ray that passes within rounding of the edge v1-v2 (edge function e0) shared by two triangles, where
// the float products of e0 round to the same value: the float path sees e0 = 0 and leaves the decision to
// watertight_in_double, whose exact sign must pick the one triangle on the ray's side. Along z through
// the origin the shear is exact (sx = sy = 0, sz = 1), so the sheared x and y are the vertices' own and the
// side is the exact orientation of the origin against the edge. A sign error in that path still hits one
// triangle (the leak tests above cannot see it) but the wrong one.
TEST(TravWatertightDoublePath, RayWithinRoundingOfASharedV1V2EdgeHitsTheTriangleOnItsSide) {
  const Vec3 p{3.0f, 0.3f, 0.0f}, q{-5.0f, -0.5f, 0.0f};
  // The case reaches the double path: the float products of e0 are equal, the exact ones are not.
  ASSERT_EQ(q.x * p.y, q.y * p.x);
  const double orientation = static_cast<double>(p.x) * q.y - static_cast<double>(p.y) * q.x;
  ASSERT_NE(orientation, 0.0);
  // The shared edge is v1-v2 of both, in opposite directions, and both wind the same way; the third
  // vertices lie far on either side.
  const std::vector<Triangle> mesh = {{{0.0f, 3.0f, 0.0f}, p, q}, {{0.0f, -3.0f, 0.0f}, q, p}};
  // The origin lies left of p -> q (orientation > 0) as the second triangle's third vertex does.
  const uint32_t expected = orientation > 0.0 ? 1 : 0;
  const Bvh bvh = test::build_median_bvh(mesh);
  for (const float dz : {1.0f, -1.0f}) {
    SCOPED_TRACE(dz > 0.0f ? "from below" : "from above");
    const Ray ray{{0.0f, 0.0f, -dz}, 0.0f, {0.0f, 0.0f, dz}, kInf};
    for (uint32_t i = 0; i < mesh.size(); ++i) {
      float t, u, v;
      EXPECT_EQ(WatertightTriangleTest(ray).intersect(mesh[i], 0.0f, kInf, t, u, v), i == expected) << i;
    }
    const Hit brute = brute_force_closest(mesh, ray);
    EXPECT_EQ(brute.prim, expected);
    EXPECT_EQ(brute.t, 1.0f);
    EXPECT_EQ(closest_hit(bvh, mesh, ray).prim, expected);
    EXPECT_TRUE(any_hit(bvh, mesh, ray));
  }
}

}  // namespace
}  // namespace sahbench
