#include <gtest/gtest.h>

#include "core/bvh_stats.h"

namespace sahbench {
namespace {

// root [0,2]^3 with two leaves: [0,1]^3 holding 2 references and [1,2]^3 holding 1.
Bvh two_leaf_tree() {
  Bvh bvh;
  bvh.nodes = {{{{0, 0, 0}, {2, 2, 2}}, 1, 2, 0},
               {{{0, 0, 0}, {1, 1, 1}}, 0, 0, 2},
               {{{1, 1, 1}, {2, 2, 2}}, 2, 0, 1}};
  bvh.prim_refs = {0, 1, 2};
  return bvh;
}

TEST(CoreStats, HandMadeTree) {
  const SahCost cost{1.0f, 1.0f};
  const BvhStats s = compute_stats(two_leaf_tree(), 3, cost);
  EXPECT_EQ(s.nodes, 3u);
  EXPECT_EQ(s.leaves, 2u);
  EXPECT_EQ(s.max_depth, 1u);
  EXPECT_DOUBLE_EQ(s.mean_leaf_depth, 1.0);
  EXPECT_DOUBLE_EQ(s.mean_leaf_size, 1.5);
  EXPECT_EQ(s.max_leaf_size, 2u);
  EXPECT_DOUBLE_EQ(s.refs_per_prim, 1.0);
  EXPECT_EQ(s.bytes, 3 * 32 + 3 * 4u);
  // root 1 * c_trav + each leaf at area ratio 3/12 = 0.25: 0.25 * 2 + 0.25 * 1.
  EXPECT_DOUBLE_EQ(s.sah_cost, 1.0 + 0.5 + 0.25);
}

TEST(CoreStats, ConstantsChangeTheCost) {
  EXPECT_DOUBLE_EQ(sah_cost(two_leaf_tree(), {2.0f, 4.0f}), 2.0 + 0.25 * 4 * 3);
}

// The same tree scaled to coordinates near 1e38: float areas overflow (2e38 squared), the cost must not.
TEST(CoreStats, SahCostIsFiniteAtTheEdgeOfFloatRange) {
  Bvh bvh = two_leaf_tree();
  for (Node& n : bvh.nodes) {
    n.bounds.min = n.bounds.min * 1.5e38f;
    n.bounds.max = n.bounds.max * 1.5e38f;
  }
  EXPECT_DOUBLE_EQ(compute_stats(bvh, 3, {1.0f, 1.0f}).sah_cost, 1.0 + 0.5 + 0.25);
}

TEST(CoreStats, EmptyTree) {
  const BvhStats s = compute_stats(Bvh{}, 0, {});
  EXPECT_EQ(s.nodes, 0u);
  EXPECT_EQ(s.sah_cost, 0.0);
}

}  // namespace
}  // namespace sahbench
