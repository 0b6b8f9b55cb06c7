// Ray/box tests: hand-made cases (origin on a face plane with +-0 direction components, grazing rays,
// flat boxes, [tmin, tmax]) for both tests, and a randomized check that RobustRayBox never misses a box
// that a double-precision slab test hits.

#include "traversal/ray_box.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <type_traits>
#include <vector>

#include "traversal/packed_bvh2.h"

namespace sahbench {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
const Aabb kUnitBox{{0.0f, 0.0f, 0.0f}, {1.0f, 1.0f, 1.0f}};

Ray make_ray(Vec3 org, Vec3 dir, float tmin = 0.0f, float tmax = kInf) {
  return {org, tmin, dir, tmax};
}

template <class BoxTest>
class TravRayBoxBoth : public ::testing::Test {};
using BoxTests = ::testing::Types<RobustRayBox, FastRayBox, FmaRayBox>;
TYPED_TEST_SUITE(TravRayBoxBoth, BoxTests);

// The tests whose (plane - org) / dir is inf or NaN by IEEE rules. FmaRayBox does not take these rays
// (FmaRayBox::takes): its kernels trace them with RobustRayBox, which `hits` does too.
template <class BoxTest>
class TravRayBoxIeee : public ::testing::Test {};
using IeeeBoxTests = ::testing::Types<RobustRayBox, FastRayBox, FmaRayBox>;
TYPED_TEST_SUITE(TravRayBoxIeee, IeeeBoxTests);

// The box test as the kernels run it: box=fma with the robust test for the rays outside its domain.
template <class BoxTest>
bool hits(const Ray& ray, const Aabb& box, float* t_entry = nullptr) {
  if constexpr (std::is_same_v<BoxTest, FmaRayBox>) {
    if (!FmaRayBox::takes(ray)) return hits<RobustRayBox>(ray, box, t_entry);
  }
  float t = -1.0f;
  const bool hit = BoxTest(ray).intersect(box, ray.tmin, ray.tmax, t);
  if (t_entry) *t_entry = t;
  return hit;
}

TYPED_TEST(TravRayBoxBoth, AxisParallelHitAndEntryDistance) {
  float t = 0.0f;
  EXPECT_TRUE(hits<TypeParam>(make_ray({-1.0f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f}), kUnitBox, &t));
  EXPECT_EQ(t, 1.0f);
  EXPECT_TRUE(hits<TypeParam>(make_ray({2.0f, 0.5f, 0.5f}, {-2.0f, -0.0f, 0.0f}), kUnitBox, &t));
  EXPECT_EQ(t, 0.5f);
  // Parallel to a slab and outside it: a miss whatever the other axes say.
  EXPECT_FALSE(hits<TypeParam>(make_ray({-1.0f, 1.5f, 0.5f}, {1.0f, 0.0f, 0.0f}), kUnitBox));
  EXPECT_FALSE(hits<TypeParam>(make_ray({-1.0f, -0.5f, 0.5f}, {1.0f, -0.0f, 0.0f}), kUnitBox));
  // Pointing away.
  EXPECT_FALSE(hits<TypeParam>(make_ray({-1.0f, 0.5f, 0.5f}, {-1.0f, 0.0f, 0.0f}), kUnitBox));
}

TYPED_TEST(TravRayBoxIeee, OriginOnFacePlaneWithSignedZeroDirection) {
  // (plane - org) * (1 / +-0) = 0 * inf = NaN on the planes the origin lies on; the NaN must count as
  // inside the slab for every sign combination of the zero components.
  for (float zy : {0.0f, -0.0f}) {
    for (float zz : {0.0f, -0.0f}) {
      for (float y : {0.0f, 1.0f}) {
        for (float z : {0.0f, 0.5f, 1.0f}) {
          SCOPED_TRACE(testing::Message() << "y=" << y << " z=" << z << " dy=" << zy << " dz=" << zz);
          float t = -1.0f;
          EXPECT_TRUE(hits<TypeParam>(make_ray({-1.0f, y, z}, {1.0f, zy, zz}), kUnitBox, &t));
          EXPECT_EQ(t, 1.0f);
          EXPECT_TRUE(hits<TypeParam>(make_ray({3.0f, y, z}, {-1.0f, zy, zz}), kUnitBox, &t));
          EXPECT_EQ(t, 2.0f);
          // Just outside the plane: a miss.
          const float outside_y = y == 0.0f ? -0x1p-20f : 1.0f + 0x1p-20f;
          EXPECT_FALSE(hits<TypeParam>(make_ray({-1.0f, outside_y, z}, {1.0f, zy, zz}), kUnitBox));
        }
      }
    }
  }
  // All three components of the origin on planes (a corner), direction along the box edge.
  EXPECT_TRUE(hits<TypeParam>(make_ray({0.0f, 0.0f, 0.0f}, {0.0f, -0.0f, 1.0f}), kUnitBox));
  EXPECT_TRUE(hits<TypeParam>(make_ray({1.0f, 1.0f, 1.0f}, {-0.0f, 0.0f, -1.0f}), kUnitBox));
}

TYPED_TEST(TravRayBoxBoth, OriginInsideEntersAtTmin) {
  float t = -1.0f;
  EXPECT_TRUE(hits<TypeParam>(make_ray({0.5f, 0.5f, 0.5f}, {0.3f, -0.2f, 0.1f}, 0.25f), kUnitBox, &t));
  EXPECT_EQ(t, 0.25f);
}

TYPED_TEST(TravRayBoxIeee, GrazingEdgesAndCornersExactly) {
  // Along an edge of the box.
  EXPECT_TRUE(hits<TypeParam>(make_ray({-1.0f, 1.0f, 1.0f}, {1.0f, 0.0f, 0.0f}), kUnitBox));
  EXPECT_TRUE(hits<TypeParam>(make_ray({-1.0f, 0.0f, 1.0f}, {1.0f, -0.0f, -0.0f}), kUnitBox));
  // Diagonal through the edge x = 1, y = 0 at t = 1 (exact arithmetic): the slabs meet in one point.
  float t = -1.0f;
  EXPECT_TRUE(hits<TypeParam>(make_ray({0.0f, -1.0f, 0.5f}, {1.0f, 1.0f, 0.0f}), kUnitBox, &t));
  EXPECT_EQ(t, 1.0f);
  // Through the corner (1, 1, 1) only.
  EXPECT_TRUE(hits<TypeParam>(make_ray({2.0f, 0.0f, 2.0f}, {-1.0f, 1.0f, -1.0f}), kUnitBox));
  // Passing just beside that corner.
  EXPECT_FALSE(hits<TypeParam>(make_ray({2.0f, 0.0f, 2.0f}, {-1.0f, 1.0f, -0.99f}), kUnitBox));
}

// box=fma's domain (FmaRayBox::takes) at both edges: a direction component of the smallest normal float
// is taken, the next float below and zero are not; org * (1 / d) up to the largest float is taken. Rays
// it does not take answer as RobustRayBox: an axis-parallel ray meets a box only 1e-20 thick around it
// (a clamped reciprocal of 1e18, as Embree's, put the far distance at 0.01 and missed it at t = 10),
// and an axis-parallel ray from 1e21 meets a box ahead of it (org * 1e18 overflowed).
TEST(FmaRayBox, TakesTheRaysOfItsDomainAndTheRobustTestAnswersTheOthers) {
  const float min = std::numeric_limits<float>::min();
  EXPECT_TRUE(FmaRayBox::takes(make_ray({1, 2, 3}, {min, -min, 1})));
  EXPECT_FALSE(FmaRayBox::takes(make_ray({1, 2, 3}, {std::nextafter(min, 0.0f), 1, 1})));
  EXPECT_FALSE(FmaRayBox::takes(make_ray({1, 2, 3}, {1, -0.0f, 1})));
  EXPECT_TRUE(FmaRayBox::takes(make_ray({1.7e38f, 2, 3}, {0.5f, 1, 1})));
  EXPECT_FALSE(FmaRayBox::takes(make_ray({1.8e38f, 2, 3}, {0.5f, 1, 1})));

  const Aabb thin{{-1e-20f, -1e-20f, 9.0f}, {1e-20f, 1e-20f, 11.0f}};
  float t = -1.0f;
  EXPECT_TRUE(hits<FmaRayBox>(make_ray({0, 0, 0}, {0, 0, 1}), thin, &t));
  EXPECT_EQ(t, 9.0f);
  const Aabb ahead{{1e21f, -1, 10}, {1e21f, 1, 11}};
  EXPECT_TRUE(hits<FmaRayBox>(make_ray({1e21f, 0, 0}, {0, 0, 1}), ahead, &t));
  EXPECT_EQ(t, 10.0f);
}

TEST(FmaRayBox, DistancesAreFused) {
  // The distances are the fused ones: plane * rdir - org * rdir, rounded once.
  const Ray ray = make_ray({0.1f, 0.2f, 0.3f}, {0.7f, -0.3f, 0.2f});
  float t = -1.0f;
  ASSERT_TRUE(hits<FmaRayBox>(ray, kUnitBox, &t));
  const float rdir_x = 1.0f / 0.7f, rdir_y = 1.0f / -0.3f, rdir_z = 1.0f / 0.2f;
  const float near_x = std::fma(0.0f, rdir_x, -(0.1f * rdir_x)),
              near_y = std::fma(1.0f, rdir_y, -(0.2f * rdir_y)),
              near_z = std::fma(0.0f, rdir_z, -(0.3f * rdir_z));
  EXPECT_EQ(t, std::max({0.0f, near_x, near_y, near_z}));
}

TYPED_TEST(TravRayBoxBoth, FlatBoxIsHit) {
  // A box of zero thickness (an axis-aligned triangle's bounds), hit perpendicularly and obliquely.
  const Aabb flat{{0.0f, 0.0f, 1.0f}, {1.0f, 1.0f, 1.0f}};
  float t = -1.0f;
  EXPECT_TRUE(hits<TypeParam>(make_ray({0.5f, 0.5f, 0.0f}, {0.0f, -0.0f, 1.0f}), flat, &t));
  EXPECT_EQ(t, 1.0f);
  EXPECT_TRUE(hits<TypeParam>(make_ray({0.0f, 0.0f, 0.0f}, {0.5f, 0.25f, 1.0f}), flat, &t));
  EXPECT_EQ(t, 1.0f);
}

TYPED_TEST(TravRayBoxBoth, IntervalIsClosedAndRespected) {
  const Ray base = make_ray({-1.0f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f});
  auto with = [&](float tmin, float tmax) {
    Ray r = base;
    r.tmin = tmin;
    r.tmax = tmax;
    return r;
  };
  EXPECT_TRUE(hits<TypeParam>(with(0.0f, 1.0f), kUnitBox));   // enters at exactly tmax
  EXPECT_FALSE(hits<TypeParam>(with(0.0f, 0.5f), kUnitBox));  // ends before the box
  EXPECT_TRUE(hits<TypeParam>(with(2.0f, 3.0f), kUnitBox));   // leaves at exactly tmin
  EXPECT_FALSE(hits<TypeParam>(with(2.5f, 3.0f), kUnitBox));  // starts after the box
  EXPECT_FALSE(hits<TypeParam>(with(0.0f, 0.999f), kUnitBox));
}

// bvh2_packed's test of both children at once answers as the box test does on each: hit, entry and exit
// distance (the exits order its closest hit's ties), on the IEEE cases
// above (origins on face planes with +-0 direction components, grazing edges and corners, tmin and tmax at a
// face) and on random rays; the NaN rule lives in the order of the operands of its max, so only cases where
// (plane - org) / dir is NaN can check it.
TYPED_TEST(TravRayBoxBoth, PairNodeTestAgreesWithTheBoxTestOnEachChild) {
  std::vector<Ray> rays;
  for (float zy : {0.0f, -0.0f})
    for (float zz : {0.0f, -0.0f})
      for (float y : {0.0f, 1.0f, -0x1p-20f, 1.0f + 0x1p-20f})
        for (float z : {0.0f, 0.5f, 1.0f}) {
          rays.push_back(make_ray({-1.0f, y, z}, {1.0f, zy, zz}));
          rays.push_back(make_ray({3.0f, y, z}, {-1.0f, zy, zz}, 0.5f, 2.0f));
          rays.push_back(make_ray({-1.0f, y, z}, {1.0f, zy, zz}, 0.0f, 1.0f));
        }
  rays.push_back(make_ray({0.0f, 0.0f, 0.0f}, {0.0f, -0.0f, 1.0f}));
  rays.push_back(make_ray({1.0f, 1.0f, 1.0f}, {-0.0f, 0.0f, -1.0f}));
  rays.push_back(make_ray({0.0f, -1.0f, 0.5f}, {1.0f, 1.0f, 0.0f}));
  rays.push_back(make_ray({2.0f, 0.0f, 2.0f}, {-1.0f, 1.0f, -1.0f}));
  rays.push_back(make_ray({2.0f, 0.0f, 2.0f}, {-1.0f, 1.0f, -0.99f}));
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coord(-2.0f, 3.0f), dir(-1.0f, 1.0f);
  for (int i = 0; i < 2000; ++i)
    rays.push_back(make_ray({coord(rng), coord(rng), coord(rng)}, {dir(rng), dir(rng), dir(rng)}));
  const Aabb others[] = {
      kUnitBox, {{0.0f, 0.0f, 1.0f}, {1.0f, 1.0f, 1.0f}}, {{1.0f, -0.5f, 0.25f}, {2.0f, 0.0f, 0.75f}}};
  for (const Aabb& right : others) {
    PairNode node{};
    node.set_box(0, kUnitBox);
    node.set_box(1, right);
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const Ray& ray = rays[i];
      if constexpr (std::is_same_v<TypeParam, FmaRayBox>) {
        if (!FmaRayBox::takes(ray)) continue;  // traced with RobustRayBox, tested as that type
      }
      SCOPED_TRACE(testing::Message() << "ray " << i);
      float t_left = -1.0f, t_right = -1.0f, e_left = -1.0f, e_right = -1.0f;
      const unsigned mask = detail::PairSlabs<TypeParam>(ray).intersect(
          node, detail::PairSlabs<TypeParam>::interval(ray.tmin, ray.tmax), t_left, t_right, e_left, e_right);
      const TypeParam box(ray);
      float want_left = -1.0f, want_right = -1.0f, exit_left = -1.0f, exit_right = -1.0f;
      const bool left = box.intersect(kUnitBox, ray.tmin, ray.tmax, want_left, exit_left);
      const bool right_hit = box.intersect(right, ray.tmin, ray.tmax, want_right, exit_right);
      ASSERT_EQ((mask & 1u) != 0, left);
      ASSERT_EQ((mask & 2u) != 0, right_hit);
      if (left) {
        ASSERT_EQ(t_left, want_left);
        ASSERT_EQ(e_left, exit_left);
      }
      if (right_hit) {
        ASSERT_EQ(t_right, want_right);
        ASSERT_EQ(e_right, exit_right);
      }
    }
  }
}

// Exact-enough slab test in double: a difference of two floats is exact in double unless their exponents
// differ by more than 29, and one division adds a relative error of 2^-53, far below float rounding.
bool double_slab_hits(const Ray& ray, const Aabb& box) {
  double t_near = 0.0, t_far = std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < 3; ++a) {
    const double o = ray.org[a], d = ray.dir[a], lo = box.min[a], hi = box.max[a];
    if (d == 0.0) {
      if (o < lo || o > hi) return false;
      continue;
    }
    double t0 = (lo - o) / d, t1 = (hi - o) / d;
    if (t0 > t1) std::swap(t0, t1);
    t_near = std::max(t_near, t0);
    t_far = std::min(t_far, t1);
  }
  return t_near <= t_far;
}

// The float nearest to x from below and from above.
float round_down(double x) {
  const auto f = static_cast<float>(x);
  return static_cast<double>(f) > x ? std::nextafter(f, -kInf) : f;
}
float round_up(double x) {
  const auto f = static_cast<float>(x);
  return static_cast<double>(f) < x ? std::nextafter(f, kInf) : f;
}

TEST(TravRayBoxRobust, NeverMissesWhereDoublePrecisionHits) {
  // Rays of varied scale and direction (with +-0 components), and boxes as tight as float allows around
  // a point of the ray computed in double, some grown on random sides so the ray grazes faces or edges.
  constexpr int kRays = 200000;
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::uniform_int_distribution<int> exponent(-8, 12);
  std::uniform_int_distribution<int> coin(0, 7);
  int double_hits = 0, robust_misses = 0, fast_misses = 0;
  for (int i = 0; i < kRays; ++i) {
    const float scale = std::ldexp(1.0f, exponent(rng));
    Ray ray;
    ray.org = Vec3{unit(rng), unit(rng), unit(rng)} * scale;
    ray.dir = {unit(rng), unit(rng), unit(rng)};
    for (std::size_t a = 0; a < 3; ++a) {
      const int c = coin(rng);
      if (c == 0) ray.dir[a] = 0.0f;
      if (c == 1) ray.dir[a] = -0.0f;
    }
    if (ray.dir == Vec3{}) ray.dir.x = 1.0f;
    const double t = std::ldexp(static_cast<double>(unit(rng)) + 1.0, exponent(rng));
    Aabb box;
    for (std::size_t a = 0; a < 3; ++a) {
      const double p = static_cast<double>(ray.org[a]) + t * static_cast<double>(ray.dir[a]);
      box.min[a] = round_down(p);
      box.max[a] = round_up(p);
      // Grow some sides so that the point lies on a face, an edge or a corner of a bigger box.
      if (coin(rng) < 2) box.min[a] -= scale * static_cast<float>(coin(rng));
      if (coin(rng) < 2) box.max[a] += scale * static_cast<float>(coin(rng));
    }
    if (!double_slab_hits(ray, box)) continue;
    ++double_hits;
    float t_entry;
    if (!RobustRayBox(ray).intersect(box, 0.0f, kInf, t_entry)) {
      if (++robust_misses <= 5)
        ADD_FAILURE() << "robust miss: org " << ray.org.x << " " << ray.org.y << " " << ray.org.z << " dir "
                      << ray.dir.x << " " << ray.dir.y << " " << ray.dir.z;
    }
    if (!FastRayBox(ray).intersect(box, 0.0f, kInf, t_entry)) ++fast_misses;
  }
  EXPECT_EQ(robust_misses, 0);
  EXPECT_GT(double_hits, kRays / 2);
  // The boxes must be tight enough that rounding loses some of them: where the fast test misses none,
  // the robust test's zero misses show nothing.
  EXPECT_GT(fast_misses, 0) << "no box here is hard enough to tell the robust test from the fast one";
  std::printf("[ info ] %d boxes hit in double: RobustRayBox missed %d, FastRayBox missed %d\n", double_hits,
              robust_misses, fast_misses);
}

}  // namespace
}  // namespace sahbench
