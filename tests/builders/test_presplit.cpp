// The presplit builder: the split budget, splits that pay off where large triangles overlap, no splits
// giving the binned SAH tree itself, and its errors. (The shared scene cases, with the validator's
// coverage check of split triangles, run through BuilderVsReference.)

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "builders/registry.h"
#include "core/bvh_stats.h"
#include "core/validate.h"
#include "scenes/generators.h"
#include "tests/builders/builder_cases.h"
#include "tests/support/hit_check.h"
#include "tests/support/test_scenes.h"
#include "traversal/brute_force.h"
#include "traversal/bvh2_traversal.h"

namespace sahbench {
namespace {

// Long thin triangles in random directions (aspect 1000): boxes that overlap everything, what splitting
// is for; and a soup of small triangles, which gain little from it.
std::vector<Triangle> needles_in_soup() {
  std::vector<Triangle> tris = generate_needles(10000, 5, 1000.0);
  const auto small = test::random_triangles(5000, 6, 1.0f, 0.05f);
  tris.insert(tris.end(), small.begin(), small.end());
  return tris;
}

TEST(Presplit, ReferencesStayWithinTheBudget) {
  const auto tris = needles_in_soup();
  for (const char* budget : {"0.01", "0.3", "1", "4"}) {
    SCOPED_TRACE(budget);
    const Bvh bvh = test::build_tree("presplit", tris, {{"split_budget", budget}});
    const ValidationReport report = validate(bvh, tris);
    ASSERT_TRUE(report.ok()) << report.summary();
    ASSERT_TRUE(test::leaves_hold_parts_of_their_triangles(bvh, tris));
    const double most = std::floor((1.0 + double(std::stof(budget))) * double(tris.size()));
    EXPECT_LE(double(bvh.prim_refs.size()), most);
    EXPECT_GT(bvh.prim_refs.size(), tris.size()) << "nothing was split";
  }
}

TEST(Presplit, SplitsLowerTheSahWhereLargeTrianglesOverlap) {
  const auto tris = needles_in_soup();
  const SahCost cost;
  const double binned = sah_cost(test::build_tree("binned_sah", tris), cost);
  const Bvh split = test::build_tree("presplit", tris);
  EXPECT_LT(sah_cost(split, cost), 0.97 * binned);
  EXPECT_LT(sah_cost(test::build_tree("presplit", tris, {{"split_budget", "1"}}), cost), 0.85 * binned);
  const auto rays = test::random_rays(tris, 2000, 13);
  std::size_t hits = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const Hit ref = brute_force_closest(tris, rays[i]);
    hits += ref.found();
    ASSERT_TRUE(test::same_closest_hit(closest_hit(split, tris, rays[i]), ref, tris, rays[i])) << "ray " << i;
    ASSERT_EQ(any_hit(split, tris, rays[i]), brute_force_any(tris, rays[i])) << "ray " << i;
  }
  EXPECT_GT(hits, rays.size() / 20);
}

TEST(Presplit, LeavesHoldEachTriangleOnce) {
  // A large budget puts several pieces of a triangle next to each other; a leaf keeps one reference.
  const auto tris = needles_in_soup();
  const Bvh bvh = test::build_tree("presplit", tris, {{"split_budget", "4"}, {"max_leaf", "16"}});
  for (const Node& node : bvh.nodes) {
    if (!node.is_leaf()) continue;
    std::vector<uint32_t> refs(bvh.prim_refs.begin() + node.first,
                               bvh.prim_refs.begin() + node.first + node.prim_count);
    std::sort(refs.begin(), refs.end());
    ASSERT_EQ(std::adjacent_find(refs.begin(), refs.end()), refs.end());
  }
}

TEST(Presplit, NoBudgetIsTheBinnedSahTree) {
  const auto tris = needles_in_soup();
  EXPECT_TRUE(test::build_tree("presplit", tris, {{"split_budget", "0"}, {"bins", "16"}}) ==
              test::build_tree("binned_sah", tris, {{"bins", "16"}}));
}

TEST(Presplit, RejectsBadParametersAndMissingTriangles) {
  const BuilderInfo& info = find_builder("presplit");
  EXPECT_THROW(resolve_params(info.name, info.params, {{"split_budget", "-0.1"}}), Error);
  EXPECT_THROW(resolve_params(info.name, info.params, {{"split_budget", "5"}}), Error);
  const auto tris = test::random_triangles(10, 1);
  BuildInput input = BuildInput::from_triangles(tris);
  input.triangles = {};
  try {
    info.build(input, resolve_params(info.name, info.params, {}));
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("needs the triangles"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sahbench
