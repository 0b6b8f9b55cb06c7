// Ray/triangle tests on hand-made cases: hits, back faces, barycentrics, the closed [tmin, tmax], +-0
// directions, rays exactly through shared edges and vertices, and Möller-Trumbore's epsilon.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <random>
#include <type_traits>
#include <vector>

#include "traversal/triangle_lanes.h"
#include "traversal/triangle_tests.h"

namespace sahbench {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// Exact-input cases below give results within a few ulps; this bounds them loosely.
constexpr float kBaryTolerance = 1e-6f;
// Random triangles include slivers, on which Möller-Trumbore's t and (u, v) are off by up to ~1e-4.
constexpr float kConventionTolerance = 1e-3f;

Ray make_ray(Vec3 org, Vec3 dir, float tmin = 0.0f, float tmax = kInf) {
  return {org, tmin, dir, tmax};
}

// A unit right triangle in the plane z = 1.
const Triangle kTri{{0.0f, 0.0f, 1.0f}, {1.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 1.0f}};

// Points whose coordinates are multiples of 1/16 in [-2, 2]: sums and products of a few are exact.
class DyadicPoints {
 public:
  explicit DyadicPoints(std::mt19937& rng) : rng_(rng) {}
  Vec3 operator()() {
    const float x = sixteenth(), y = sixteenth();
    return {x, y, sixteenth()};
  }
  /// One coordinate.
  float sixteenth() { return static_cast<float>(sixteenths_(rng_)) / 16.0f; }

 private:
  std::mt19937& rng_;
  std::uniform_int_distribution<int> sixteenths_{-32, 32};
};

struct Result {
  bool hit = false;
  float t = 0.0f, u = 0.0f, v = 0.0f;
};

template <class Test>
Result run(const Ray& ray, const Triangle& tri) {
  Result r;
  r.hit = Test(ray).intersect(tri, ray.tmin, ray.tmax, r.t, r.u, r.v);
  return r;
}

template <class Test>
class TravTriangleBoth : public ::testing::Test {};
using TriangleTests = ::testing::Types<WatertightTriangleTest, MollerTrumboreTest, MollerTrumboreNormalTest>;
TYPED_TEST_SUITE(TravTriangleBoth, TriangleTests);

TYPED_TEST(TravTriangleBoth, FrontAndBackFacesHitWithBarycentrics) {
  for (const Ray& ray :
       {make_ray({0.25f, 0.5f, 0.0f}, {0.0f, 0.0f, 1.0f}), make_ray({0.25f, 0.5f, 2.0f}, {0.0f, 0.0f, -1.0f}),
        make_ray({0.25f, 0.5f, 0.0f}, {-0.0f, 0.0f, 1.0f}),
        make_ray({0.25f, 0.5f, 2.0f}, {0.0f, -0.0f, -1.0f})}) {
    const Result r = run<TypeParam>(ray, kTri);
    ASSERT_TRUE(r.hit);
    EXPECT_FLOAT_EQ(r.t, 1.0f);
    // p = (1-u-v) v0 + u v1 + v v2 = (u, v, 1).
    EXPECT_NEAR(r.u, 0.25f, kBaryTolerance);
    EXPECT_NEAR(r.v, 0.5f, kBaryTolerance);
  }
}

TYPED_TEST(TravTriangleBoth, BarycentricsReconstructTheHitPoint) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  int hits = 0;
  for (int i = 0; i < 1000; ++i) {
    const Triangle tri{{unit(rng), unit(rng), unit(rng)},
                       {unit(rng), unit(rng), unit(rng)},
                       {unit(rng), unit(rng), unit(rng)}};
    const Vec3 target = tri.v0 * 0.3f + tri.v1 * 0.3f + tri.v2 * 0.4f;
    const Vec3 org{unit(rng) * 4.0f, unit(rng) * 4.0f, unit(rng) * 4.0f};
    const Ray ray = make_ray(org, target - org);
    const Result r = run<TypeParam>(ray, tri);
    if (!r.hit) continue;  // nearly edge-on triangles may be rejected by Möller-Trumbore's epsilon
    ++hits;
    // A check of the (u, v) convention, not of accuracy: Möller-Trumbore loses digits on slivers.
    // The stored-normal form's worst case here, a sliver seen at a grazing angle, is 1.04e-3 off
    // (Möller–Trumbore's is 4.1e-4 on the same triangle); over many triangles the two are as accurate
    // (TravTriangleMollerTrumboreNormal below).
    const float tolerance =
        std::is_same_v<TypeParam, MollerTrumboreNormalTest> ? 2 * kConventionTolerance : kConventionTolerance;
    const Vec3 on_ray = org + ray.dir * r.t;
    const Vec3 on_tri = tri.v0 * (1.0f - r.u - r.v) + tri.v1 * r.u + tri.v2 * r.v;
    EXPECT_LT(length(on_ray - on_tri), tolerance);
    EXPECT_NEAR(r.t, 1.0f, tolerance);
  }
  EXPECT_GT(hits, 990);
}

TYPED_TEST(TravTriangleBoth, MissesOutsideParallelAndBehind) {
  EXPECT_FALSE(run<TypeParam>(make_ray({0.75f, 0.75f, 0.0f}, {0.0f, 0.0f, 1.0f}), kTri).hit);
  EXPECT_FALSE(run<TypeParam>(make_ray({-0.1f, 0.5f, 0.0f}, {0.0f, 0.0f, 1.0f}), kTri).hit);
  // In the triangle's plane (determinant 0).
  EXPECT_FALSE(run<TypeParam>(make_ray({-1.0f, 0.25f, 1.0f}, {1.0f, 0.0f, 0.0f}), kTri).hit);
  // The triangle lies behind the origin.
  EXPECT_FALSE(run<TypeParam>(make_ray({0.25f, 0.25f, 2.0f}, {0.0f, 0.0f, 1.0f}), kTri).hit);
  // Degenerate (collinear) triangle.
  const Triangle line{{0.0f, 0.0f, 1.0f}, {1.0f, 1.0f, 1.0f}, {2.0f, 2.0f, 1.0f}};
  EXPECT_FALSE(run<TypeParam>(make_ray({1.0f, 1.0f, 0.0f}, {0.0f, 0.0f, 1.0f}), line).hit);
}

TYPED_TEST(TravTriangleBoth, IntervalIsClosed) {
  const Vec3 org{0.25f, 0.25f, 0.0f}, dir{0.0f, 0.0f, 1.0f};  // hits at t = 1 exactly
  EXPECT_TRUE(run<TypeParam>(make_ray(org, dir, 0.0f, 1.0f), kTri).hit);
  EXPECT_TRUE(run<TypeParam>(make_ray(org, dir, 1.0f, 2.0f), kTri).hit);
  EXPECT_TRUE(run<TypeParam>(make_ray(org, dir, 1.0f, 1.0f), kTri).hit);
  EXPECT_FALSE(run<TypeParam>(make_ray(org, dir, 0.0f, std::nextafter(1.0f, 0.0f)), kTri).hit);
  EXPECT_FALSE(run<TypeParam>(make_ray(org, dir, std::nextafter(1.0f, 2.0f), 2.0f), kTri).hit);
}

// True when `dir` lies in the plane of one of `tris`: such a ray sees that triangle edge-on (a miss by
// definition), so it proves nothing about gaps. Products of these small dyadic inputs are exact.
bool in_a_plane(Vec3 dir, const std::vector<Triangle>& tris) {
  for (const Triangle& t : tris)
    if (dot(dir, t.normal()) == 0.0f) return true;
  return false;
}

// Rays exactly through a point that the triangles share, from directions whose components are small
// dyadic numbers (so org = point - dir is exact and the ray passes through the point at t = 1).
std::vector<Ray> rays_through(Vec3 point, const std::vector<Triangle>& tris) {
  std::vector<Ray> rays;
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> eighths(-16, 16);
  while (rays.size() < 200) {
    const Vec3 dir{eighths(rng) / 8.0f, eighths(rng) / 8.0f, eighths(rng) / 8.0f};
    if (!in_a_plane(dir, tris)) rays.push_back(make_ray(point - dir, dir));
  }
  // Axis-parallel, with either zero sign.
  for (std::size_t axis = 0; axis < 3; ++axis)
    for (float z0 : {0.0f, -0.0f})
      for (float z1 : {0.0f, -0.0f})
        for (float d : {1.0f, -1.0f}) {
          Vec3 dir{z0, z0, z1};
          dir[axis] = d;
          dir[(axis + 1) % 3] = z1;
          if (!in_a_plane(dir, tris)) rays.push_back(make_ray(point - dir, dir));
        }
  return rays;
}

// Counts the rays that hit none of `tris`.
int leaks(const std::vector<Triangle>& tris, const std::vector<Ray>& rays) {
  int missed = 0;
  for (const Ray& ray : rays) {
    bool any = false;
    for (const Triangle& tri : tris) any = any || run<WatertightTriangleTest>(ray, tri).hit;
    missed += any ? 0 : 1;
  }
  return missed;
}

TEST(TravTriangleWatertight, SharedEdgeOfTwoTriangles) {
  // A quad split along its diagonal; rays through the diagonal's midpoint and other points on it.
  const Vec3 a{0.0f, 0.0f, 1.0f}, b{1.0f, 0.0f, 1.0f}, c{1.0f, 1.0f, 1.0f}, d{0.0f, 1.0f, 1.0f};
  const std::vector<Triangle> quad{{a, b, c}, {a, c, d}};
  for (float s : {0.5f, 0.25f, 0.125f, 0.875f}) EXPECT_EQ(leaks(quad, rays_through({s, s, 1.0f}, quad)), 0);
  // A ray exactly through the shared edge is on both triangles' boundary: both report it here.
  const Ray ray = make_ray({0.5f, 0.5f, 0.0f}, {0.0f, 0.0f, 1.0f});
  EXPECT_TRUE(run<WatertightTriangleTest>(ray, quad[0]).hit);
  EXPECT_TRUE(run<WatertightTriangleTest>(ray, quad[1]).hit);
}

TEST(TravTriangleWatertight, HugeAndTinyCoordinatesStayWatertightAndFinite) {
  // Beyond about 1e12 from the origin the float edge functions overflow, below about 1e-19 their
  // products underflow: the test finishes such triangles in double instead of leaking or returning inf.
  // Powers of two keep every ray below exact: it passes through the shared edge at t = 1.
  for (float scale : {0x1p66f, 0x1p100f, 0x1p-66f, 0x1p-83f}) {
    SCOPED_TRACE(scale);
    const Vec3 a{0.0f, 0.0f, scale}, b{scale, 0.0f, scale}, c{scale, scale, scale}, d{0.0f, scale, scale};
    const std::vector<Triangle> quad{{a, b, c}, {a, c, d}};
    // The unit quad's rays, scaled (rays_through's plane test wants unit-sized triangles).
    const std::vector<Triangle> unit_quad{{{0, 0, 1}, {1, 0, 1}, {1, 1, 1}},
                                          {{0, 0, 1}, {1, 1, 1}, {0, 1, 1}}};
    std::vector<Ray> rays;
    for (float s : {0.5f, 0.25f, 0.375f})
      for (const Ray& unit : rays_through({s, s, 1.0f}, unit_quad)) {
        if (unit.dir.z == 0.0f) continue;  // in the quad's plane
        rays.push_back(make_ray(unit.org * scale, unit.dir * scale));
      }
    EXPECT_EQ(leaks(quad, rays), 0);
    // Straight down the shared edge's midpoint from the plane z = 0: t is the quad's height.
    const auto hit = run<WatertightTriangleTest>(
        make_ray({0.5f * scale, 0.5f * scale, 0.0f}, {0.0f, 0.0f, 1.0f}), quad[0]);
    ASSERT_TRUE(hit.hit);
    EXPECT_EQ(hit.t, scale);
    // A ray a whole triangle away still misses.
    EXPECT_FALSE(
        run<WatertightTriangleTest>(make_ray({2.5f * scale, 0.5f * scale, 0.0f}, {0.0f, 0.0f, 1.0f}), quad[0])
            .hit);
  }
}

TEST(TravTriangleWatertight, SharedVertexOfAFan) {
  // Eight triangles around the vertex (0, 0, 1), with both windings.
  const Vec3 center{0.0f, 0.0f, 1.0f};
  const Vec3 ring[8] = {{1, 0, 1},  {1, 1, 1},   {0, 1, 1},  {-1, 1, 1},
                        {-1, 0, 1}, {-1, -1, 1}, {0, -1, 1}, {1, -1, 1}};
  std::vector<Triangle> fan;
  for (int i = 0; i < 8; ++i) {
    const Vec3 p = ring[i], q = ring[(i + 1) % 8];
    fan.push_back(i % 2 ? Triangle{center, p, q} : Triangle{q, center, p});
  }
  EXPECT_EQ(leaks(fan, rays_through(center, fan)), 0);
  // And through the shared edges (center to a ring vertex), at a dyadic point on each.
  for (const Vec3& p : ring) EXPECT_EQ(leaks(fan, rays_through((center + p) * 0.5f, fan)), 0);
}

TEST(TravTriangleWatertight, TiltedSharedEdge) {
  // Two triangles in the plane x - 2y + z = 0 (aligned with no axis), on either side of their shared edge
  // from (0,0,0) to (1,1,1); rays through dyadic points on it from many directions. (Coplanar, because an
  // edge between two triangles that fold is a silhouette for some directions, and a ray that grazes a
  // silhouette may pass outside both: no hole, but no hit either.)
  const Vec3 a{0.0f, 0.0f, 0.0f}, b{1.0f, 1.0f, 1.0f}, c{1.0f, 0.5f, 0.0f}, d{0.0f, 0.5f, 1.0f};
  const std::vector<Triangle> pair{{a, b, c}, {b, a, d}};
  for (float s : {0.5f, 0.25f, 0.75f, 0.0625f}) EXPECT_EQ(leaks(pair, rays_through(Vec3{s, s, s}, pair)), 0);
}

TEST(TravTriangleWatertight, WindingDoesNotChangeTheAnswer) {
  // Reversing a triangle's winding negates its edge functions exactly (no fused multiply-add may round
  // one product and not the other), so every ray, including those exactly through an edge or vertex,
  // gets the same hit, the same t and swapped barycentrics (up to the order of a sum).
  std::mt19937 rng(11);
  DyadicPoints dyadic(rng);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    const Triangle tri{dyadic(), dyadic(), dyadic()};
    const Triangle reversed{tri.v0, tri.v2, tri.v1};
    // A point on an edge or a vertex, or a random point, seen from a random direction.
    const float w = dyadic.sixteenth() / 4.0f + 0.5f;
    const Vec3 target = i % 3 == 0 ? tri.v1 : (i % 3 == 1 ? tri.v0 * w + tri.v2 * (1.0f - w) : dyadic());
    const Vec3 dir = i % 2 ? dyadic() : Vec3{unit(rng), unit(rng), unit(rng)};
    if (dir == Vec3{}) continue;
    // An unbounded line, so that only the edge tests decide (not the sign of t near the origin).
    const Ray ray = make_ray(target - dir, dir, -kInf, kInf);
    const Result a = run<WatertightTriangleTest>(ray, tri);
    const Result b = run<WatertightTriangleTest>(ray, reversed);
    ASSERT_EQ(a.hit, b.hit) << "triangle " << i;
    if (!a.hit) continue;
    ++hits;
    // det and t sum the same terms in another order, so they may differ in the last bits.
    EXPECT_NEAR(a.t, b.t, 1e-5f * std::max(1.0f, std::abs(a.t)));
    EXPECT_NEAR(a.u, b.v, 1e-5f);
    EXPECT_NEAR(a.v, b.u, 1e-5f);
  }
  EXPECT_GT(hits, 1000);
}

TEST(TravTriangleMollerTrumbore, EpsilonAndZeroEpsilon) {
  const Ray ray = make_ray({0.25f, 0.25f, 0.0f}, {0.0f, 0.0f, 1.0f});
  float t, u, v;
  // Simple case: both settings hit.
  EXPECT_TRUE(MollerTrumboreTest(ray).intersect(kTri, 0.0f, kInf, t, u, v));
  EXPECT_TRUE(MollerTrumboreTest(ray, 0.0f).intersect(kTri, 0.0f, kInf, t, u, v));
  EXPECT_FLOAT_EQ(t, 1.0f);
  // A small triangle: det = |dir| * |e1 x e2| = 2^-22 < 1e-6. The default epsilon rejects it although
  // the ray hits its middle; epsilon 0 and the watertight test hit it.
  const float s = 0x1p-11f;
  const Triangle small{{0.0f, 0.0f, 1.0f}, {s, 0.0f, 1.0f}, {0.0f, s, 1.0f}};
  const Ray at_small = make_ray({s / 4, s / 4, 0.0f}, {0.0f, 0.0f, 1.0f});
  EXPECT_FALSE(MollerTrumboreTest(at_small).intersect(small, 0.0f, kInf, t, u, v));
  EXPECT_TRUE(MollerTrumboreTest(at_small, 0.0f).intersect(small, 0.0f, kInf, t, u, v));
  EXPECT_FLOAT_EQ(t, 1.0f);
  EXPECT_TRUE(WatertightTriangleTest(at_small).intersect(small, 0.0f, kInf, t, u, v));
  // Zero epsilon still rejects the exactly parallel ray (det == 0).
  EXPECT_FALSE(MollerTrumboreTest(make_ray({-1.0f, 0.25f, 1.0f}, {1.0f, 0.0f, 0.0f}), 0.0f)
                   .intersect(kTri, 0.0f, kInf, t, u, v));
}

// The stored-normal form is the same Cramer's rule rearranged. On triangles of random size (1e-3 to 1e3),
// shape and orientation, seen from random directions: where Möller–Trumbore clearly hits (barycentrics
// 1e-3 inside) or misses, it does too; its distances are about as accurate, measured against t computed
// in double from the same float triangle (relative error: the median below Möller–Trumbore's, the 99.9th
// percentile 1.6x its; both lose digits on slivers seen at grazing angles).
TEST(TravTriangleMollerTrumboreNormal, AsAccurateAsMollerTrumbore) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), scale(-3.0f, 3.0f);
  std::vector<double> error_mt, error_mtn;
  int misses = 0;
  for (int i = 0; i < 40000; ++i) {
    const float size = std::pow(10.0f, scale(rng));
    const Vec3 v0{unit(rng), unit(rng), unit(rng)};
    const Triangle tri{v0, v0 + Vec3{unit(rng), unit(rng), unit(rng)} * size,
                       v0 + Vec3{unit(rng), unit(rng), unit(rng)} * size};
    const Vec3 target = tri.v0 + (tri.v1 - tri.v0) * (unit(rng) * 0.75f + 0.25f) +
                        (tri.v2 - tri.v0) * (unit(rng) * 0.75f + 0.25f);
    const Vec3 dir{unit(rng), i % 7 == 0 ? 0.0f : unit(rng), unit(rng)};
    const Ray ray = make_ray(target - dir * 2.0f, dir);
    const Result a = run<MollerTrumboreNoEpsilonTest>(ray, tri);
    const Result b = run<MollerTrumboreNormalTest>(ray, tri);
    const bool inside = a.hit && a.u > 1e-3f && a.v > 1e-3f && a.u + a.v < 1.0f - 1e-3f;
    if (!a.hit) {
      // A clear miss: the line meets the plane well outside (or the ray points away).
      misses += !b.hit;
      continue;
    }
    if (!inside) continue;
    ASSERT_TRUE(b.hit) << "triangle " << i;
    // The exact distance to the float triangle's plane: num / den in double, each product exact.
    const Vec3 e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
    auto d = [](float x) { return static_cast<double>(x); };
    const double nx = d(e1.y) * d(e2.z) - d(e1.z) * d(e2.y), ny = d(e1.z) * d(e2.x) - d(e1.x) * d(e2.z),
                 nz = d(e1.x) * d(e2.y) - d(e1.y) * d(e2.x);
    const double t = ((d(tri.v0.x) - d(ray.org.x)) * nx + (d(tri.v0.y) - d(ray.org.y)) * ny +
                      (d(tri.v0.z) - d(ray.org.z)) * nz) /
                     (d(ray.dir.x) * nx + d(ray.dir.y) * ny + d(ray.dir.z) * nz);
    error_mt.push_back(std::abs(a.t - t) / t);
    error_mtn.push_back(std::abs(b.t - t) / t);
  }
  ASSERT_GT(error_mt.size(), 5000u);
  EXPECT_GT(misses, 1000);
  auto quantile = [](std::vector<double> v, double q) {
    std::sort(v.begin(), v.end());
    return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
  };
  std::printf(
      "[ info ] relative error of t over %zu hits, median / 99.9th percentile: mt0 %.2e / %.2e, mtn %.2e / "
      "%.2e\n",
      error_mt.size(), quantile(error_mt, 0.5), quantile(error_mt, 0.999), quantile(error_mtn, 0.5),
      quantile(error_mtn, 0.999));
  EXPECT_LT(quantile(error_mtn, 0.5), 1.5 * quantile(error_mt, 0.5));
  EXPECT_LT(quantile(error_mtn, 0.999), 2.0 * quantile(error_mt, 0.999));
  EXPECT_LT(quantile(error_mtn, 0.5), 1e-6);
}

// Like mt0 it has no epsilon: a triangle of edge 2^-11 is hit. It rejects an edge-on triangle (det == 0)
// and a line (normal 0). A triangle so small that its float det would be subnormal (1 / |det| infinite:
// at edge 2^-66 it made a hit at t = inf, and then a miss) is tested in double and hit.
TEST(TravTriangleMollerTrumboreNormal, RejectsEdgeOnAndHitsTinyTrianglesInDouble) {
  float t, u, v;
  const float s = 0x1p-11f;
  const Triangle small{{0.0f, 0.0f, 1.0f}, {s, 0.0f, 1.0f}, {0.0f, s, 1.0f}};
  EXPECT_TRUE(MollerTrumboreNormalTest(make_ray({s / 4, s / 4, 0.0f}, {0.0f, 0.0f, 1.0f}))
                  .intersect(small, 0.0f, kInf, t, u, v));
  EXPECT_FLOAT_EQ(t, 1.0f);
  EXPECT_FALSE(MollerTrumboreNormalTest(make_ray({-1.0f, 0.25f, 1.0f}, {1.0f, 0.0f, 0.0f}))
                   .intersect(kTri, 0.0f, kInf, t, u, v));
  const Triangle line{{0.0f, 0.0f, 1.0f}, {1.0f, 1.0f, 1.0f}, {2.0f, 2.0f, 1.0f}};
  EXPECT_FALSE(MollerTrumboreNormalTest(make_ray({0.5f, 0.5f, 0.0f}, {0.0f, 0.0f, 1.0f}))
                   .intersect(line, 0.0f, kInf, t, u, v));
  // det = tiny^2 = 2^-132, below the smallest normal float 2^-126: the normal is below the float test's
  // range (mtn_triangle_in_range), and the test in double hits it where the float one missed.
  const float tiny = 0x1p-66f;
  const Triangle speck{{0.0f, 0.0f, 1.0f}, {tiny, 0.0f, 1.0f}, {0.0f, tiny, 1.0f}};
  const Ray at_speck = make_ray({tiny / 4, tiny / 4, 0.0f}, {0.0f, 0.0f, 1.0f});
  EXPECT_TRUE(MollerTrumboreNormalTest(at_speck).intersect(speck, 0.0f, kInf, t, u, v));
  EXPECT_FLOAT_EQ(t, 1.0f);
  EXPECT_FLOAT_EQ(u, 0.25f);
  EXPECT_FLOAT_EQ(v, 0.25f);
  EXPECT_TRUE(WatertightTriangleTest(at_speck).intersect(speck, 0.0f, kInf, t, u, v));
  EXPECT_FLOAT_EQ(t, 1.0f);
}

#if defined(__SSE2__)
// Whether WatertightTriangleTest finishes `tri` in double for `ray`: its float edge functions or
// determinant cannot be trusted (the same operations as the test, to count how often the lanes' double
// finish is exercised below).
bool decided_in_double(const Ray& ray, const Triangle& tri) {
  const WatertightShear s = watertight_shear(ray.dir);
  auto sheared = [&](Vec3 p) {
    const auto r = std::bit_cast<std::array<float, 3>>(p - ray.org);
    return std::array<float, 3>{r[s.kx] - s.sx * r[s.kz], r[s.ky] - s.sy * r[s.kz], s.sz * r[s.kz]};
  };
  const auto a = sheared(tri.v0), b = sheared(tri.v1), c = sheared(tri.v2);
  const float e0 = c[0] * b[1] - c[1] * b[0], e1 = a[0] * c[1] - a[1] * c[0], e2 = b[0] * a[1] - b[1] * a[0];
  if (!watertight_float_ok(e0, e1, e2)) return true;
  if ((e0 < 0.0f || e1 < 0.0f || e2 < 0.0f) && (e0 > 0.0f || e1 > 0.0f || e2 > 0.0f)) return false;
  return !watertight_det_ok(e0 + e1 + e2, e0 * a[2] + e1 * b[2] + e2 * c[2]);
}

// One case of the four-lane tests below: a leaf of one to four triangles in a buffer of exactly that
// many (a read past them is caught by the sanitizers), the same triangles among others reached through
// shuffled references, and a ray aimed at a vertex, an edge's dyadic point or anywhere, from a dyadic
// direction (often with zero components, some of them -0) or a random one, some of them tiny. Scales
// 2^66 and 2^-70 overflow or underflow the float paths. tmin or tmax lies exactly at the aimed
// triangle's distance by `Scalar` some of the time, so that the closed interval counts; the walks' far
// limit FLT_MAX some of the time.
struct LaneCase {
  std::vector<Triangle> leaf, pool;
  std::vector<uint32_t> refs;
  Ray ray;
};

template <class Scalar>
std::optional<LaneCase> lane_case(int i, std::mt19937& rng) {
  DyadicPoints dyadic(rng);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const float scales[] = {1.0f, 0x1p66f, 0x1p-70f};
  const float scale = scales[i % 3];
  const auto n = static_cast<uint32_t>(1 + i / 4 % 4);
  LaneCase c;
  c.leaf.resize(n);
  for (Triangle& tri : c.leaf) tri = {dyadic() * scale, dyadic() * scale, dyadic() * scale};
  Triangle& aim = c.leaf[std::min<std::size_t>(static_cast<std::size_t>(i % 4), n - 1)];
  // Some of the time the aimed triangle is 2^-70 times the others, and the ray meets it inside: lanes
  // in and out of a test's float range in one call.
  if (i % 10 == 4) aim = {aim.v0 * 0x1p-70f, aim.v1 * 0x1p-70f, aim.v2 * 0x1p-70f};
  const Vec3 target = i % 5 == 0   ? aim.v1
                      : i % 5 == 1 ? (aim.v0 + aim.v2) * 0.5f
                      : i % 5 == 4 ? (aim.v0 + aim.v1 + aim.v2 * 2.0f) * 0.25f
                                   : dyadic() * scale;
  Vec3 dir = i % 2 ? dyadic() : Vec3{unit(rng), unit(rng), unit(rng)};
  if (i % 7 == 0) dir.y = -0.0f;
  if (dir.x == 0.0f && dir.y == 0.0f && dir.z == 0.0f) return std::nullopt;
  const Vec3 org = target - dir * scale;
  if (i % 13 == 0) dir = dir * 0x1p-45f;
  float tmin = 0.0f, tmax = i % 6 == 5 ? std::numeric_limits<float>::max() : kInf;
  float t, u, v;
  if (i % 4 == 3 && Scalar(make_ray(org, dir)).intersect(aim, 0.0f, kInf, t, u, v))
    (i % 8 == 3 ? tmax : tmin) = t;
  c.ray = make_ray(org, dir, tmin, tmax);
  c.pool.assign(8, Triangle{dyadic(), dyadic(), dyadic()});
  c.refs.resize(n);
  for (uint32_t k = 0; k < n; ++k) {
    c.refs[k] = 7 - 2 * k;
    c.pool[c.refs[k]] = c.leaf[k];
  }
  return c;
}

// What every four-lane test's cases reach, counted over lanes.
struct LaneCounts {
  int lanes = 0, hits = 0, in_double = 0, at_tmin = 0, at_tmax = 0;
};

// `mask`, t, u and v of a four-lane test on case `c` against `one`'s answer on each triangle alone: the
// same hits and misses, and the same bits of t, u and v on every hit.
template <class One>
void expect_lanes_as_one(const LaneCase& c, unsigned mask, const float* t, const float* u, const float* v,
                         One one, LaneCounts& counts) {
  const auto n = static_cast<uint32_t>(c.leaf.size());
  EXPECT_EQ(mask >> n, 0u);
  for (uint32_t k = 0; k < n; ++k) {
    SCOPED_TRACE(testing::Message() << "lane " << k);
    float tk = 0.0f, uk = 0.0f, vk = 0.0f;
    const bool hit = one(c.leaf[k], tk, uk, vk);
    ++counts.lanes;
    ASSERT_EQ((mask >> k & 1u) != 0, hit);
    if (!hit) continue;
    ++counts.hits;
    counts.at_tmin += tk == c.ray.tmin ? 1 : 0;
    counts.at_tmax += tk == c.ray.tmax ? 1 : 0;
    EXPECT_EQ(std::bit_cast<uint32_t>(t[k]), std::bit_cast<uint32_t>(tk));
    EXPECT_EQ(std::bit_cast<uint32_t>(u[k]), std::bit_cast<uint32_t>(uk));
    EXPECT_EQ(std::bit_cast<uint32_t>(v[k]), std::bit_cast<uint32_t>(vk));
  }
}

// Every path was taken: hits, and hits at exactly tmin and at exactly tmax.
void expect_every_path(const LaneCounts& counts) {
  EXPECT_GT(counts.hits, counts.lanes / 20);
  EXPECT_GT(counts.at_tmin, 100);
  EXPECT_GT(counts.at_tmax, 100);
}

// WatertightLanes decides each of its four lanes as WatertightTriangleTest decides that triangle alone,
// with the refined distance and with the float one, on rays exactly through edges and vertices (edge
// functions of 0, finished in double) among lane_case's others.
TEST(TravTriangleWatertightLanes, EveryLaneAsTheScalarTest) {
  std::mt19937 rng(29);
  LaneCounts counts;
  for (int i = 0; i < 20000; ++i) {
    const std::optional<LaneCase> c = lane_case<WatertightTriangleTest>(i, rng);
    if (!c) continue;
    SCOPED_TRACE(testing::Message() << "case " << i);
    const Ray& ray = c->ray;
    const auto n = static_cast<uint32_t>(c->leaf.size());
    const WatertightLanes four(ray);
    const WatertightTriangleTest one(ray);
    for (const Triangle& tri : c->leaf) counts.in_double += decided_in_double(ray, tri) ? 4 : 0;
    for (int form = 0; form < 4; ++form) {
      SCOPED_TRACE(testing::Message() << "form " << form);
      const bool refine = form % 2 == 0, gathered = form >= 2;
      alignas(16) float t[4], u[4], v[4];
      const unsigned mask =
          gathered
              ? (refine
                     ? four.intersect<true>(c->pool.data(), c->refs.data(), n, ray.tmin, ray.tmax, t, u, v)
                     : four.intersect<false>(c->pool.data(), c->refs.data(), n, ray.tmin, ray.tmax, t, u, v))
              : (refine ? four.intersect<true>(c->leaf.data(), n, ray.tmin, ray.tmax, t, u, v)
                        : four.intersect<false>(c->leaf.data(), n, ray.tmin, ray.tmax, t, u, v));
      expect_lanes_as_one(
          *c, mask, t, u, v,
          [&](const Triangle& tri, float& tk, float& uk, float& vk) {
            return refine ? one.intersect(tri, ray.tmin, ray.tmax, tk, uk, vk)
                          : one.intersect_float(tri, ray.tmin, ray.tmax, tk, uk, vk);
          },
          counts);
    }
  }
  expect_every_path(counts);
  EXPECT_GT(counts.in_double, counts.lanes / 100);  // lanes finished in double
}

// The Möller-Trumbore tests' four-lane forms decide each lane as the scalar test decides that triangle
// alone; mtn's lanes outside its float range (the 2^66 and 2^-70 scales, the tiny directions) are
// finished in double.
template <class Test>
class TravTriangleMollerTrumboreLanes : public ::testing::Test {};
using MollerTrumboreTests = ::testing::Types<MollerTrumboreTest, MollerTrumboreNoEpsilonTest
#if defined(__FMA__)
                                             ,
                                             MollerTrumboreNormalTest
#endif
                                             >;
TYPED_TEST_SUITE(TravTriangleMollerTrumboreLanes, MollerTrumboreTests);

TYPED_TEST(TravTriangleMollerTrumboreLanes, EveryLaneAsTheScalarTest) {
  static_assert(kTestsInLanes<TypeParam>);
  std::mt19937 rng(31);
  LaneCounts counts;
  int mixed_double_hits = 0;  // mtn: hits finished in double beside lanes decided in float
  for (int i = 0; i < 20000; ++i) {
    const std::optional<LaneCase> c = lane_case<TypeParam>(i, rng);
    if (!c) continue;
    SCOPED_TRACE(testing::Message() << "case " << i);
    const Ray& ray = c->ray;
    const auto n = static_cast<uint32_t>(c->leaf.size());
    const LeafTestOf<TypeParam> four(ray);
    const TypeParam one(ray);
    if constexpr (std::is_same_v<TypeParam, MollerTrumboreNormalTest>) {
      int in_range = 0, double_hits = 0;
      for (const Triangle& tri : c->leaf) {
        const Vec3 e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
        float t, u, v;
        if (mtn_ray_in_range(ray.org, ray.dir) &&
            mtn_triangle_in_range(tri.v0, e1, e2, stored_normal(e1, e2)))
          ++in_range;
        else
          double_hits += one.intersect(tri, ray.tmin, ray.tmax, t, u, v) ? 1 : 0;
      }
      counts.in_double += 2 * (static_cast<int>(n) - in_range);
      mixed_double_hits += in_range > 0 ? double_hits : 0;
    }
    for (bool gathered : {false, true}) {
      SCOPED_TRACE(testing::Message() << "gathered " << gathered);
      alignas(16) float t[4], u[4], v[4];
      const unsigned mask =
          gathered
              ? four.template intersect<false>(c->pool.data(), c->refs.data(), n, ray.tmin, ray.tmax, t, u, v)
              : four.template intersect<false>(c->leaf.data(), n, ray.tmin, ray.tmax, t, u, v);
      expect_lanes_as_one(
          *c, mask, t, u, v,
          [&](const Triangle& tri, float& tk, float& uk, float& vk) {
            return one.intersect(tri, ray.tmin, ray.tmax, tk, uk, vk);
          },
          counts);
    }
  }
  expect_every_path(counts);
  if constexpr (std::is_same_v<TypeParam, MollerTrumboreNormalTest>) {
    EXPECT_GT(counts.in_double, counts.lanes / 20);
    EXPECT_GT(mixed_double_hits, 100);
  }
}
#endif

}  // namespace
}  // namespace sahbench
