// The BVH kernels against the brute-force reference: every combination of box and triangle test, trees
// of arity 2, 4 and 8, random scenes and rays (with +-0 and axis-parallel directions and bounded
// segments), plus the counted variants, [tmin, tmax], ties, empty trees and the depth limit.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/validate.h"
#include "tests/support/test_scenes.h"
#include "tests/traversal/median_builder.h"
#include "traversal/brute_force.h"
#include "traversal/bvh2_traversal.h"

namespace sahbench {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// Two hits tie when their distances agree to this relative tolerance (a few float ulps; the box test and
// the triangle test round differently, so a kernel may legitimately find another triangle at the same
// distance as the reference).
constexpr float kTieTolerance = 1e-6f;

constexpr std::size_t kSceneTriangles = 3000;
constexpr std::size_t kRays = 4000;

template <class TriangleTest_, class BoxTest_>
struct Kernel {
  using TriangleTest = TriangleTest_;
  using BoxTest = BoxTest_;
};
using Kernels =
    ::testing::Types<Kernel<WatertightTriangleTest, RobustRayBox>, Kernel<WatertightTriangleTest, FastRayBox>,
                     Kernel<MollerTrumboreTest, RobustRayBox>, Kernel<MollerTrumboreTest, FastRayBox>,
                     Kernel<MollerTrumboreTest, FmaRayBox>, Kernel<MollerTrumboreNormalTest, FmaRayBox>>;

// Same hit as the reference, or a tie: the same distance within the tolerance, with the kernel's
// primitive also hit at that distance by the same triangle test. Returns an explanation, empty if agreed.
template <class TriangleTest>
std::string disagreement(const Hit& got, const Hit& ref, std::span<const Triangle> tris, const Ray& ray) {
  if (got.found() != ref.found()) return got.found() ? "kernel hit, reference missed" : "kernel missed";
  if (!got.found() || got.prim == ref.prim) {
    if (got.found() && (got.t != ref.t || got.u != ref.u || got.v != ref.v)) return "same prim, other t/u/v";
    return {};
  }
  if (std::abs(got.t - ref.t) > kTieTolerance * std::max(1.0f, std::abs(ref.t)))
    return "prim " + std::to_string(got.prim) + " at t " + std::to_string(got.t) + ", reference prim " +
           std::to_string(ref.prim) + " at t " + std::to_string(ref.t);
  float t, u, v;
  if (!TriangleTest(ray).intersect(tris[got.prim], ray.tmin, ray.tmax, t, u, v) || t != got.t)
    return "tie claimed on a primitive the test does not hit there";
  return {};
}

template <class K>
class TravBvhKernels : public ::testing::Test {
 protected:
  // The binary trees' own loop (BinaryWalk) against the general loop on the same binary tree: the
  // same hit and the same counters, for closest hit and for any hit in each child order.
  static void check_binary_loop(const Bvh& bvh, std::span<const Triangle> tris, const Ray& ray,
                                std::size_t i) {
    using TriangleTest = typename K::TriangleTest;
    using BoxTest = typename K::BoxTest;
    TraversalCounters binary, general;
    const Hit a = detail::traverse<TriangleTest, BoxTest, false, true, true>(bvh, tris, ray, &binary,
                                                                             AnyHitOrder::kAuto);
    const Hit b = detail::traverse<TriangleTest, BoxTest, false, true, false>(bvh, tris, ray, &general,
                                                                              AnyHitOrder::kAuto);
    EXPECT_TRUE(a.prim == b.prim && a.t == b.t && a.u == b.u && a.v == b.v) << "closest, ray " << i;
    EXPECT_EQ(binary, general) << "closest counters, ray " << i;
    for (AnyHitOrder order : {AnyHitOrder::kNearest, AnyHitOrder::kStored, AnyHitOrder::kNearestStored,
                              AnyHitOrder::kFarthestStored}) {
      TraversalCounters any_binary, any_general;
      const Hit c =
          detail::traverse<TriangleTest, BoxTest, true, true, true>(bvh, tris, ray, &any_binary, order);
      const Hit d =
          detail::traverse<TriangleTest, BoxTest, true, true, false>(bvh, tris, ray, &any_general, order);
      EXPECT_EQ(c.prim, d.prim) << "any hit, order " << int(order) << ", ray " << i;
      EXPECT_EQ(any_binary, any_general) << "any-hit counters, order " << int(order) << ", ray " << i;
    }
  }

  // Checks closest_hit, any_hit and the counted variants of kernel K against brute force.
  void check(const std::vector<Triangle>& tris, const std::vector<Ray>& rays, uint32_t arity,
             int allowed_mismatches) {
    using TriangleTest = typename K::TriangleTest;
    using BoxTest = typename K::BoxTest;
    const Bvh bvh = test::build_median_bvh(tris, arity);
    ASSERT_TRUE(validate(bvh, std::span<const Triangle>(tris)).ok());
    int closest_mismatches = 0, any_mismatches = 0, hits = 0, ties = 0;
    TraversalCounters counters;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const Ray& ray = rays[i];
      const Hit ref = brute_force_closest<TriangleTest>(tris, ray);
      const Hit got = closest_hit<TriangleTest, BoxTest>(bvh, tris, ray);
      hits += got.found() ? 1 : 0;
      ties += got.found() && ref.found() && got.prim != ref.prim ? 1 : 0;
      const std::string why = disagreement<TriangleTest>(got, ref, tris, ray);
      if (!why.empty() && ++closest_mismatches <= 5) ADD_FAILURE() << "closest, ray " << i << ": " << why;

      const bool any = any_hit<TriangleTest, BoxTest>(bvh, tris, ray);
      if (any != brute_force_any<TriangleTest>(tris, ray) && ++any_mismatches <= 5)
        ADD_FAILURE() << "any, ray " << i << ": kernel says " << any;

      // The counted kernels run the same traversal and must return exactly the same.
      const Hit counted = closest_hit_counted<TriangleTest, BoxTest>(bvh, tris, ray, counters);
      EXPECT_EQ(counted.prim, got.prim);
      EXPECT_EQ(counted.t, got.t);
      TraversalCounters any_counters;
      EXPECT_EQ((any_hit_counted<TriangleTest, BoxTest>(bvh, tris, ray, any_counters)), any);
      EXPECT_EQ(any_counters.rays, 1u);
      if (arity == 2) check_binary_loop(bvh, tris, ray, i);
    }
    if (allowed_mismatches == 0) {
      EXPECT_EQ(closest_mismatches, 0);
      EXPECT_EQ(any_mismatches, 0);
    } else {
      EXPECT_LE(closest_mismatches + any_mismatches, allowed_mismatches);
    }
    EXPECT_GT(hits, static_cast<int>(rays.size() / 10));
    EXPECT_EQ(counters.rays, rays.size());
    EXPECT_GT(counters.box_tests, counters.rays);
    EXPECT_GT(counters.inner_visits, 0u);
    EXPECT_GT(counters.leaf_visits, 0u);
    EXPECT_GT(counters.prim_tests, 0u);
    EXPECT_GE(counters.prim_tests, counters.leaf_visits);
    // Every inner node visited tests all its children, and the root is tested once per ray.
    EXPECT_GE(counters.box_tests, counters.rays + 2 * counters.inner_visits);
    std::printf(
        "[ info ] arity %u: %d/%zu rays hit, %d ties; per ray: %.1f nodes, %.1f box tests, %.1f prims\n",
        arity, hits, rays.size(), ties, double(counters.nodes_visited()) / double(counters.rays),
        double(counters.box_tests) / double(counters.rays),
        double(counters.prim_tests) / double(counters.rays));
  }
};
TYPED_TEST_SUITE(TravBvhKernels, Kernels);

TYPED_TEST(TravBvhKernels, RandomTrianglesMatchBruteForce) {
  const auto tris = test::random_triangles(kSceneTriangles, 42);
  const auto rays = test::random_rays(tris, kRays, 43);
  for (uint32_t arity : {2u, 4u, 8u}) {
    SCOPED_TRACE(testing::Message() << "arity " << arity);
    this->check(tris, rays, arity, 0);
  }
}

TYPED_TEST(TravBvhKernels, CubeGridMatchesBruteForce) {
  // Flat boxes and many exact ties at shared edges and vertices.
  const auto tris = test::cube_grid(16, 4.0f);
  const auto rays = test::random_rays(tris, kRays, 44);
  this->check(tris, rays, 2, 0);
}

TEST(TravBvh, EmptyTreeIsAMiss) {
  const Bvh empty;
  const std::vector<Triangle> none;
  const Ray ray;
  EXPECT_FALSE(closest_hit(empty, none, ray).found());
  EXPECT_FALSE(any_hit(empty, none, ray));
  TraversalCounters counters;
  EXPECT_FALSE(closest_hit_counted(empty, none, ray, counters).found());
  EXPECT_EQ(counters.rays, 1u);
  EXPECT_EQ(counters.box_tests, 0u);
  EXPECT_FALSE(brute_force_closest(none, ray).found());
  EXPECT_FALSE(brute_force_any(none, ray));
  EXPECT_TRUE(test::build_median_bvh(none).nodes.empty());
}

TEST(TravBvh, RootLeaf) {
  const std::vector<Triangle> one{{{0, 0, 1}, {1, 0, 1}, {0, 1, 1}}};
  const Bvh bvh = test::build_median_bvh(one);
  ASSERT_EQ(bvh.nodes.size(), 1u);
  const Hit hit = closest_hit(bvh, one, {{0.25f, 0.25f, 0.0f}, 0.0f, {0.0f, -0.0f, 1.0f}, kInf});
  ASSERT_TRUE(hit.found());
  EXPECT_EQ(hit.t, 1.0f);
  EXPECT_FALSE(closest_hit(bvh, one, {{0.75f, 0.75f, 0.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, kInf}).found());
}

// Unit squares (two triangles each) in the planes z = 1 .. kLayers, one above the other.
std::vector<Triangle> stacked_squares(int layers) {
  std::vector<Triangle> tris;
  for (int i = 1; i <= layers; ++i) {
    const auto z = static_cast<float>(i);
    tris.push_back({{0, 0, z}, {1, 0, z}, {1, 1, z}});
    tris.push_back({{0, 0, z}, {1, 1, z}, {0, 1, z}});
  }
  return tris;
}

TEST(TravBvh, RayIntervalIsRespectedAndClosed) {
  constexpr int kLayers = 40;
  const auto tris = stacked_squares(kLayers);
  const Bvh bvh = test::build_median_bvh(tris);
  const Vec3 org{0.75f, 0.25f, 0.0f}, dir{0.0f, 0.0f, 1.0f};  // hits layer i at t = i, in triangle 2i-2
  auto closest_t = [&](float tmin, float tmax) {
    const Hit hit = closest_hit(bvh, tris, {org, tmin, dir, tmax});
    return hit.found() ? hit.t : -1.0f;
  };
  EXPECT_EQ(closest_t(0.0f, kInf), 1.0f);
  EXPECT_EQ(closest_t(2.5f, kInf), 3.0f);
  EXPECT_EQ(closest_t(3.0f, kInf), 3.0f);  // tmin is inclusive
  EXPECT_EQ(closest_t(0.5f, 1.0f), 1.0f);  // tmax is inclusive
  EXPECT_EQ(closest_t(1.5f, 1.9f), -1.0f);
  EXPECT_EQ(closest_t(40.5f, kInf), -1.0f);
  EXPECT_EQ(closest_t(39.5f, 41.0f), 40.0f);
  EXPECT_FALSE(any_hit(bvh, tris, {org, 1.5f, dir, 1.9f}));
  EXPECT_TRUE(any_hit(bvh, tris, {org, 1.5f, dir, 2.0f}));
  // Pointing away from all of them.
  EXPECT_FALSE(any_hit(bvh, tris, {org, 0.0f, -dir, kInf}));
}

TEST(TravBvh, TiesGoToTheLowestPrimitiveIndex) {
  // Copies of one triangle spread over the index range, among other triangles, so they land in different
  // leaves or at different places in one: every kernel and the reference must return the first copy.
  auto tris = test::random_triangles(500, 9);
  const Triangle copy{{-20, -20, 30}, {20, -20, 30}, {0, 20, 30}};
  for (std::size_t i : {123u, 7u, 499u, 250u}) tris[i] = copy;
  const Ray ray{{0.0f, 0.0f, 40.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf};
  for (uint32_t arity : {2u, 4u, 8u}) {
    const Bvh bvh = test::build_median_bvh(tris, arity);
    EXPECT_EQ(closest_hit(bvh, tris, ray).prim, 7u);
    EXPECT_EQ((closest_hit<MollerTrumboreTest, FastRayBox>(bvh, tris, ray).prim), 7u);
  }
  EXPECT_EQ(brute_force_closest(tris, ray).prim, 7u);
  EXPECT_EQ(brute_force_closest<MollerTrumboreTest>(tris, ray).prim, 7u);
}

TEST(TravBvh, RepeatedReferencesAreHarmless) {
  // A hand-made tree in which leaves reference the same primitives (as spatial splits make).
  const auto tris = stacked_squares(2);
  Bvh bvh;
  bvh.arity = 2;
  Aabb all;
  for (const Triangle& t : tris) all.extend(t.bounds());
  bvh.nodes.push_back({all, 1, 2, 0});
  bvh.nodes.push_back({all, 0, 0, 4});
  bvh.nodes.push_back({all, 4, 0, 4});
  bvh.prim_refs = {0, 1, 2, 3, 3, 2, 1, 0};
  const Hit hit = closest_hit(bvh, tris, {{0.25f, 0.75f, 0.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, kInf});
  EXPECT_EQ(hit.prim, 1u);
  TraversalCounters counters;
  closest_hit_counted(bvh, tris, {{0.25f, 0.75f, 0.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, kInf}, counters);
  EXPECT_EQ(counters.prim_tests, 8u);
  EXPECT_EQ(counters.nodes_visited(), 3u);
  EXPECT_EQ(counters.box_tests, 3u);
}

TEST(TravBvh, TreeDeeperThanTheLimitThrows) {
  // A chain: each inner node has a leaf (far along the ray, so it is pushed) and the next inner node
  // (near, so it is taken next). The stack grows by one per level, and a chain far deeper than
  // kMaxDepth must make the kernel throw rather than write past its stack.
  constexpr uint32_t kChain = 2000;
  std::vector<Triangle> tris;
  for (uint32_t i = 0; i < kChain; ++i) {
    const float x = static_cast<float>(kChain + 10) + static_cast<float>(i) * 0.001f;
    tris.push_back({{x, -1, -1}, {x, 1, -1}, {x, 0, 1}});
  }
  Aabb scene;
  for (const Triangle& t : tris) scene.extend(t.bounds());
  // Inner node k spans from x = k to the end of the scene, so the ray enters it at t = k + 1.
  auto inner = [&](uint32_t k) {
    return Node{merge(scene, Aabb::from_point({static_cast<float>(k), 0.0f, 0.0f})), 0, 2, 0};
  };
  auto leaf = [&](uint32_t k) { return Node{tris[k].bounds(), k, 0, 1}; };
  Bvh bvh;
  bvh.nodes.push_back(inner(0));
  uint32_t current = 0;
  for (uint32_t k = 0; k < kChain; ++k) {
    const auto first = static_cast<uint32_t>(bvh.nodes.size());
    bvh.nodes[current].first = first;
    // Inner node first: any hit visits in storage order and closest hit nearest first, so both take the
    // inner node next and leave the leaf waiting on the stack.
    bvh.nodes.push_back(k + 1 < kChain ? inner(k + 1) : leaf(k));
    bvh.nodes.push_back(leaf(k));
    current = first;
  }
  bvh.prim_refs.resize(kChain);
  for (uint32_t i = 0; i < kChain; ++i) bvh.prim_refs[i] = i;
  // Through every box but beside every triangle, so that neither kernel stops early.
  const Ray ray{{-1.0f, 0.9f, 0.9f}, 0.0f, {1.0f, 0.0f, 0.0f}, kInf};
  ASSERT_FALSE(brute_force_any(tris, ray));
  EXPECT_THROW(closest_hit(bvh, tris, ray), Error);
  EXPECT_THROW(any_hit(bvh, tris, ray), Error);
}

}  // namespace
}  // namespace sahbench
