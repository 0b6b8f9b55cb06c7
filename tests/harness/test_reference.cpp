// The reference a run's cells are checked against: above the brute-force limit Embree's robust mode, its
// disagreements with a cell settled by the exact reference, so that a mismatch is a wrong answer of the
// cell and not a rounding of Embree's.

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "core/error.h"
#include "harness/run/reference.h"
#include "scenes/load.h"
#include "traversal/brute_force.h"

namespace sahbench {
namespace {

// Rays from outside a sphere towards points around its centre: most hit, those aimed wide miss.
RaySet rays_at(bool occlusion) {
  RaySet set;
  set.name = occlusion ? "shadow" : "primary";
  set.occlusion = occlusion;
  for (int i = 0; i < 64; ++i) {
    const float x = -1.6f + 0.05f * static_cast<float>(i);
    Ray ray;
    ray.org = {x, 0.1f, 5.0f};
    ray.dir = {0.0f, 0.0f, -1.0f};
    if (occlusion) ray.tmax = 6.0f;
    set.rays.push_back(ray);
  }
  return set;
}

TEST(Reference, EmbreesDisagreementsWithACellAreSettledExactly) {
  const Scene scene = load_scene("proc:sphere:tris=2000");
  const float diagonal = scene_diagonal(scene.triangles);
  const RaySet set = rays_at(false);
  Reference ref = make_reference(scene, set, ReferencePolicy::kEmbree, 0);
  EXPECT_EQ(ref.name, "embree_robust+exact");
  ASSERT_NE(ref.settler, nullptr);
  std::vector<Hit> truth;
  for (const Ray& ray : set.rays) truth.push_back(brute_force_closest(scene.triangles, ray));
  EXPECT_EQ(count_mismatches(ref, set, diagonal, truth, {}), 0u);

  // Embree (here made) wrong on ray 20, a hit: the cell that answers right is not counted.
  const std::size_t hit = 20;
  ASSERT_TRUE(truth[hit].found());
  ref.hits[hit] = Hit{};
  EXPECT_EQ(count_mismatches(ref, set, diagonal, truth, {}), 0u);
  Reference unsettled = ref;
  unsettled.settler = nullptr;
  EXPECT_EQ(count_mismatches(unsettled, set, diagonal, truth, {}), 1u);

  // A cell wrong where Embree is right, and one wrong where Embree is wrong too: both counted.
  std::vector<Hit> wrong = truth;
  wrong[hit] = Hit{};
  EXPECT_EQ(count_mismatches(ref, set, diagonal, wrong, {}), 0u) << "agrees with Embree: not checked";
  const std::size_t other = 30;
  ASSERT_TRUE(truth[other].found());
  wrong[other] = Hit{};
  EXPECT_EQ(count_mismatches(ref, set, diagonal, wrong, {}), 1u);
  // Another primitive at another distance is wrong; the exact closest one is right.
  std::vector<Hit> far = truth;
  far[other].prim = (truth[other].prim + 1) % static_cast<uint32_t>(scene.triangles.size());
  far[other].t = truth[other].t + 1.0f;
  EXPECT_EQ(count_mismatches(ref, set, diagonal, far, {}), 1u);
}

TEST(Reference, OcclusionIsSettledByWhetherTheExactSegmentMeetsATriangle) {
  const Scene scene = load_scene("proc:sphere:tris=2000");
  const float diagonal = scene_diagonal(scene.triangles);
  const RaySet set = rays_at(true);
  Reference ref = make_reference(scene, set, ReferencePolicy::kEmbree, 0);
  std::vector<uint8_t> truth;
  for (const Ray& ray : set.rays) truth.push_back(brute_force_any(scene.triangles, ray) ? 1 : 0);
  EXPECT_EQ(count_mismatches(ref, set, diagonal, {}, truth), 0u);
  const std::size_t blocked = 20;
  ASSERT_EQ(truth[blocked], 1);
  ref.occluded[blocked] = 0;
  EXPECT_EQ(count_mismatches(ref, set, diagonal, {}, truth), 0u);
  std::vector<uint8_t> wrong = truth;
  wrong[30] = static_cast<uint8_t>(!wrong[30]);
  EXPECT_EQ(count_mismatches(ref, set, diagonal, {}, wrong), 1u);
}

TEST(Reference, BruteForceNeedsNoSettling) {
  const Scene scene = load_scene("proc:sphere:tris=2000");
  const Reference ref = make_reference(scene, rays_at(false), ReferencePolicy::kAuto, 1u << 20);
  EXPECT_EQ(ref.name, "brute_force");
  EXPECT_EQ(ref.settler, nullptr);
}

// Brute force is cut into chunks of rays, after each of which the caller may stop it (Ctrl-C in a run).
TEST(Reference, BruteForceCallsBackBetweenChunksAndStopsWhenItThrows) {
  const Scene scene = load_scene("proc:sphere:tris=200");
  RaySet set = rays_at(false);
  const std::vector<Ray> some = set.rays;
  while (set.rays.size() < 2 * kReferenceChunk + 1) set.rays.insert(set.rays.end(), some.begin(), some.end());
  std::size_t calls = 0;
  const Reference ref = make_reference(scene, set, ReferencePolicy::kBruteForce, 0, [&] { ++calls; });
  EXPECT_EQ(calls, (set.rays.size() + kReferenceChunk - 1) / kReferenceChunk);
  ASSERT_EQ(ref.hits.size(), set.rays.size());
  EXPECT_EQ(ref.hits.back().prim, brute_force_closest(scene.triangles, set.rays.back()).prim);
  calls = 0;
  EXPECT_THROW(make_reference(scene, set, ReferencePolicy::kBruteForce, 0,
                              [&] {
                                if (++calls == 1) throw Error("stop");
                              }),
               Error);
  EXPECT_EQ(calls, 1u) << "stopped after the first chunk";
}

}  // namespace
}  // namespace sahbench
