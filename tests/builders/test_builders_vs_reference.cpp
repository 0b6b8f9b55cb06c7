// Every builder variant, on every scene case: the tree is valid, leaves respect the parameters, and
// closest-hit and any-hit traversal agree with brute force.

#include <gtest/gtest.h>

#include <algorithm>

#include "core/bvh_stats.h"
#include "core/validate.h"
#include "tests/builders/builder_cases.h"
#include "tests/support/hit_check.h"
#include "traversal/brute_force.h"
#include "traversal/bvh2_traversal.h"

namespace sahbench {
namespace {

using test::BuilderVariant;
using test::SceneCase;

class BuilderVsReference : public ::testing::TestWithParam<BuilderVariant> {
 protected:
  static const std::vector<SceneCase>& scenes() {
    static const auto cases = test::scene_cases();
    return cases;
  }
};

TEST_P(BuilderVsReference, ValidTreesAndSameHitsAsBruteForce) {
  const BuilderInfo& info = find_builder(GetParam().builder);
  const ParamSet params = resolve_params(info.name, info.params, GetParam().params);
  for (const SceneCase& scene : scenes()) {
    SCOPED_TRACE(scene.name);
    const BuildInput input = BuildInput::from_triangles(scene.triangles);
    const Bvh bvh = info.build(input, params);

    // With the triangles, the validator also checks that split triangles are covered by their leaves.
    const ValidationReport report = validate(bvh, std::span<const Triangle>(scene.triangles));
    ASSERT_TRUE(report.ok()) << report.summary();
    ASSERT_TRUE(test::leaves_hold_parts_of_their_triangles(bvh, scene.triangles));
    ASSERT_EQ(bvh.arity, info.arity ? info.arity(params) : 2u);
    for (const Node& node : bvh.nodes) ASSERT_LE(node.child_count, bvh.arity);
    const BvhStats stats = compute_stats(bvh, scene.triangles.size(), sah_cost_of(params));
    EXPECT_LE(stats.max_leaf_size, test::max_leaf_of(params));
    EXPECT_LE(stats.max_depth, kMaxDepth);
    EXPECT_GE(bvh.prim_refs.size(), scene.triangles.size());
    EXPECT_LE(bvh.prim_refs.size(), test::max_references(info, params, scene.triangles.size()));

    // Brute force is O(triangles) per ray: fewer rays on the larger scenes keep the suite quick.
    const std::size_t ray_count = std::clamp<std::size_t>(4'000'000 / scene.triangles.size(), 200, 3000);
    const auto rays = test::random_rays(scene.triangles, ray_count, 99);
    std::size_t hits = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const Ray& ray = rays[i];
      const Hit ref = brute_force_closest(scene.triangles, ray);
      hits += ref.found();
      ASSERT_TRUE(test::same_closest_hit(closest_hit(bvh, scene.triangles, ray), ref, scene.triangles, ray))
          << "ray " << i;
      ASSERT_EQ(any_hit(bvh, scene.triangles, ray), brute_force_any(scene.triangles, ray)) << "ray " << i;
    }
    // The rays must exercise hits, not only misses, or the comparison proves little.
    EXPECT_GT(hits, ray_count / 20) << "too few rays hit " << scene.name;
  }
}

INSTANTIATE_TEST_SUITE_P(AllBuilders, BuilderVsReference, ::testing::ValuesIn(test::builder_variants()),
                         [](const auto& info) { return info.param.label(); });

TEST(BuilderEdgeCases, EmptyInputGivesEmptyTree) {
  for (const auto& info : builders()) {
    const Bvh bvh = info.build(BuildInput::from_triangles({}), resolve_params(info.name, info.params, {}));
    EXPECT_TRUE(bvh.nodes.empty()) << info.name;
    EXPECT_TRUE(validate(bvh, std::span<const Aabb>{}).ok());
  }
}

TEST(BuilderEdgeCases, SingleTriangleIsOneLeaf) {
  const std::vector<Triangle> tris{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}};
  for (const auto& info : builders()) {
    const Bvh bvh = info.build(BuildInput::from_triangles(tris), resolve_params(info.name, info.params, {}));
    ASSERT_EQ(bvh.nodes.size(), 1u) << info.name;
    EXPECT_TRUE(bvh.root().is_leaf());
    EXPECT_EQ(bvh.root().bounds, tris[0].bounds());
  }
}

TEST(BuilderEdgeCases, IdenticalTrianglesBeyondMaxLeafAreSplitByCount) {
  const std::vector<Triangle> tris(100000, Triangle{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
  for (const auto& info : builders()) {
    const auto params = resolve_params(info.name, info.params, {test::max_leaf_override(info, "4")});
    const Bvh bvh = info.build(BuildInput::from_triangles(tris), params);
    ASSERT_TRUE(validate(bvh, tris).ok()) << info.name;
    const auto stats = compute_stats(bvh, tris.size(), sah_cost_of(params));
    EXPECT_LE(stats.max_leaf_size, 4u);
    // Median splits halve the count: the depth stays logarithmic.
    EXPECT_LE(stats.max_depth, 17u) << info.name;
  }
}

TEST(BuilderEdgeCases, ExtremeCoordinatesStillGiveValidTrees) {
  // Areas overflow to infinity (1e30) or underflow to zero (1e-25): the SAH has nothing to compare, and
  // the builders must fall back to splits by count rather than loop or produce NaN boxes.
  for (float scale : {1e30f, 1e-25f}) {
    auto tris = test::random_triangles(5000, 8);
    for (auto& t : tris) t = {t.v0 * scale, t.v1 * scale, t.v2 * scale};
    for (const auto& info : builders()) {
      const Bvh bvh =
          info.build(BuildInput::from_triangles(tris), resolve_params(info.name, info.params, {}));
      EXPECT_TRUE(validate(bvh, tris).ok()) << info.name << " at scale " << scale;
    }
  }
}

}  // namespace
}  // namespace sahbench
