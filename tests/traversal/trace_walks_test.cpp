// detail::trace_walks, the binary layouts' single-ray loop, on a real tree: each ray of an index map
// that is not the identity answered once, by the answer it gets alone; box=fma's rays outside that
// test's domain sent to `alone`; rays that no walk takes (untraceable, missing the root) answered too.

#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <vector>

#include "core/ray.h"
#include "core/triangle.h"
#include "tests/support/test_scenes.h"
#include "tests/traversal/median_builder.h"
#include "traversal/bvh2_traversal.h"
#include "traversal/ray_box.h"
#include "traversal/triangle_tests.h"

namespace sahbench {
namespace {

constexpr std::size_t kFirst = 5, kStride = 3;  // ray j of the walks is rays[kFirst + kStride * j]

// Random rays, and among them axis-parallel ones (outside box=fma's domain), one with a NaN origin (not
// traceable), one that starts beside the scene pointing away (misses the root) and one with an empty
// interval.
std::vector<Ray> mixed_rays(const std::vector<Triangle>& scene) {
  std::vector<Ray> rays = test::random_rays(scene, 61, 7);
  for (std::size_t i = 0; i < rays.size(); i += 6) {
    rays[i].dir = {0.0f, rays[i].dir.y, 0.0f};
    if (rays[i].dir.y == 0.0f) rays[i].dir.y = 1.0f;
  }
  rays[1].org.x = std::numeric_limits<float>::quiet_NaN();
  rays[2] = Ray{{1e6f, 1e6f, 1e6f}, 0.0f, {1.0f, 1.0f, 1.0f}};
  rays[4].tmax = -1.0f;
  return rays;
}

template <class Box, bool kAnyHit>
void check_against_alone() {
  const std::vector<Triangle> triangles = test::random_triangles(300, 11);
  const Bvh bvh = test::build_median_bvh(triangles, 2);
  const std::vector<Ray> walked = mixed_rays(triangles);
  // The walked rays spread over a larger span, the others a poison that no answer may come from.
  std::vector<Ray> rays(kFirst + kStride * walked.size(), Ray{{0, 0, 0}, 0.0f, {0, 0, 0}});
  for (std::size_t j = 0; j < walked.size(); ++j) rays[kFirst + kStride * j] = walked[j];

  using Walk = detail::BinaryWalk<WatertightTriangleTest, Box, kAnyHit, false>;
  const AnyHitOrder order = resolve_any_hit_order(bvh);
  std::vector<int> answers(rays.size(), 0);
  std::vector<Hit> hits(rays.size());
  std::size_t alone_calls = 0;
  detail::trace_walks<Walk, Box>(
      rays, walked.size(), [](std::size_t j) { return kFirst + kStride * j; },
      [&](std::optional<Walk>& walk, const Ray& ray) {
        walk.emplace(bvh, triangles.data(), ray, nullptr, order);
      },
      [&](const Ray& ray) {
        ++alone_calls;
        return detail::traverse<WatertightTriangleTest, RobustRayBox, kAnyHit, false>(bvh, triangles, ray,
                                                                                      nullptr, order);
      },
      [&](std::size_t i, const Hit& hit) {
        ++answers[i];
        hits[i] = hit;
      });

  std::size_t outside_domain = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const bool walked_ray = i >= kFirst && (i - kFirst) % kStride == 0;
    EXPECT_EQ(answers[i], walked_ray ? 1 : 0) << "ray " << i;
    if (!walked_ray) continue;
    if (std::is_same_v<Box, FmaRayBox> && !FmaRayBox::takes(rays[i])) ++outside_domain;
    const Hit alone = detail::traverse<WatertightTriangleTest, Box, kAnyHit, false>(bvh, triangles, rays[i],
                                                                                    nullptr, order);
    if (kAnyHit) {
      EXPECT_EQ(hits[i].found(), alone.found()) << "ray " << i;
    } else {
      EXPECT_EQ(hits[i].prim, alone.prim) << "ray " << i;
      if (alone.found()) {
        EXPECT_EQ(hits[i].t, alone.t) << "ray " << i;
      }
    }
  }
  // The axis-parallel rays and the NaN one: box=fma sends them alone, the robust test never does.
  if (std::is_same_v<Box, FmaRayBox>) {
    EXPECT_GE(outside_domain, 10u);
    EXPECT_EQ(alone_calls, outside_domain);
  } else {
    EXPECT_EQ(alone_calls, 0u);
  }
}

TEST(TravTraceWalks, ClosestHitsOfAnIndexMapAreEachRaysOwn) {
  check_against_alone<RobustRayBox, false>();
  check_against_alone<FmaRayBox, false>();
}

TEST(TravTraceWalks, AnyHitsOfAnIndexMapAreEachRaysOwn) {
  check_against_alone<RobustRayBox, true>();
  check_against_alone<FmaRayBox, true>();
}

TEST(TravTraceWalks, TheTestRaysReachEveryPath) {
  // Guards the test above: some walked rays hit, some miss, some are untraceable or outside box=fma's
  // domain, so each path of trace_walks is taken.
  const std::vector<Triangle> triangles = test::random_triangles(300, 11);
  const Bvh bvh = test::build_median_bvh(triangles, 2);
  const std::vector<Ray> rays = mixed_rays(triangles);
  std::size_t hit = 0, miss = 0, untraceable = 0;
  for (const Ray& ray : rays) {
    if (!traceable(ray)) ++untraceable;
    (closest_hit(bvh, triangles, ray).found() ? hit : miss) += 1;
  }
  EXPECT_GE(hit, 10u);
  EXPECT_GE(miss, 3u);
  EXPECT_EQ(untraceable, 1u);
}

}  // namespace
}  // namespace sahbench
