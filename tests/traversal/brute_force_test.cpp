// The brute-force reference itself: closed interval, ties, any-hit.

#include "traversal/brute_force.h"

#include <gtest/gtest.h>

#include <limits>
#include <vector>

namespace sahbench {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

TEST(TravBruteForce, ClosestAmongSeveral) {
  const std::vector<Triangle> tris{{{0, 0, 3}, {1, 0, 3}, {0, 1, 3}},
                                   {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}},
                                   {{0, 0, 2}, {1, 0, 2}, {0, 1, 2}},
                                   {{5, 5, 0.5f}, {6, 5, 0.5f}, {5, 6, 0.5f}}};
  const Ray ray{{0.25f, 0.25f, 0.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, kInf};
  const Hit hit = brute_force_closest(tris, ray);
  EXPECT_EQ(hit.prim, 1u);
  EXPECT_EQ(hit.t, 1.0f);
  EXPECT_EQ(brute_force_closest(tris, {ray.org, 1.5f, ray.dir, kInf}).prim, 2u);
  EXPECT_EQ(brute_force_closest(tris, {ray.org, 2.0f, ray.dir, kInf}).prim, 2u);  // tmin inclusive
  EXPECT_EQ(brute_force_closest(tris, {ray.org, 0.0f, ray.dir, 1.0f}).prim, 1u);  // tmax inclusive
  EXPECT_FALSE(brute_force_closest(tris, {ray.org, 3.5f, ray.dir, kInf}).found());
  EXPECT_TRUE(brute_force_any(tris, {ray.org, 2.5f, ray.dir, 3.0f}));
  EXPECT_FALSE(brute_force_any(tris, {ray.org, 2.5f, ray.dir, 2.9f}));
}

TEST(TravBruteForce, TiesGoToTheLowestIndex) {
  // Two different triangles meeting the ray at the same t (the shared edge of a quad), and a copy.
  const std::vector<Triangle> tris{{{5, 5, 0}, {6, 5, 0}, {5, 6, 0}},
                                   {{0, 0, 1}, {1, 1, 1}, {0, 1, 1}},
                                   {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}},
                                   {{0, 0, 1}, {1, 1, 1}, {0, 1, 1}}};
  const Ray ray{{0.5f, 0.5f, 0.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, kInf};
  EXPECT_EQ(brute_force_closest(tris, ray).prim, 1u);
  EXPECT_EQ(brute_force_closest<MollerTrumboreTest>(tris, ray).prim, 1u);
}

}  // namespace
}  // namespace sahbench
