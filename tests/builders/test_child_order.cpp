#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "builders/binned_sah.h"
#include "builders/child_order.h"
#include "builders/registry.h"
#include "core/bvh_stats.h"
#include "core/validate.h"
#include "tests/support/test_scenes.h"
#include "traversal/bvh2_traversal.h"

namespace sahbench {
namespace {

// Every node's children, as (box, leaf range or child count) records, sorted: the same multiset before
// and after a reordering that only permutes siblings.
std::vector<std::vector<float>> sorted_records(const Bvh& bvh) {
  std::vector<std::vector<float>> out;
  for (const Node& n : bvh.nodes)
    out.push_back({n.bounds.min.x, n.bounds.min.y, n.bounds.min.z, n.bounds.max.x, n.bounds.max.y,
                   n.bounds.max.z, float(n.child_count), float(n.prim_count)});
  std::sort(out.begin(), out.end());
  return out;
}

// Siblings in non-increasing key order.
void expect_ordered(const Bvh& bvh, std::span<const Triangle> tris, const SahCost& cost) {
  const std::vector<double> keys = occlusion_order_keys(bvh, tris, cost);
  for (std::size_t i = 0; i < bvh.nodes.size(); ++i) {
    const Node& n = bvh.nodes[i];
    if (n.is_leaf()) continue;
    for (uint32_t c = 1; c < n.child_count; ++c)
      ASSERT_GE(keys[n.first + c - 1], keys[n.first + c]) << "node " << i << " child " << c;
  }
}

TEST(ChildOrder, PermutesSiblingsOnlyAndKeepsTheTreeValid) {
  const auto tris = test::random_triangles(3000, 4);
  const Bvh built = build_binned_sah(BuildInput::from_triangles(tris), {});
  Bvh ordered = built;
  order_children_for_occlusion(ordered, tris, SahCost{});
  ASSERT_TRUE(validate(ordered, tris).ok()) << validate(ordered, tris).summary();
  expect_ordered(ordered, tris, SahCost{});
  EXPECT_NE(ordered.nodes, built.nodes) << "random triangles must give some node whose children move";
  EXPECT_EQ(sorted_records(ordered), sorted_records(built));
  EXPECT_EQ(sah_cost(ordered, SahCost{}), sah_cost(built, SahCost{}));
  // Ordering twice changes nothing (stable, and already in order).
  Bvh twice = ordered;
  order_children_for_occlusion(twice, tris, SahCost{});
  EXPECT_EQ(twice.nodes, ordered.nodes);
}

// Three leaves under one root, stored worst first: a large box around one small triangle (rarely
// occludes: key 2e-5), a flat 2 x 2 box half covered by its one triangle (key 0.5 / 1) and the same box
// with 9 such triangles in 3 blocks (sure to occlude, at 3 times the cost: key 1 / 3). Area alone would
// put the large box first.
TEST(ChildOrder, PutsTheLikeliestOccluderPerCostFirst) {
  std::vector<Triangle> tris;
  tris.push_back({{0, 0, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}});  // in a 10 x 10 x 10 box
  tris.push_back({{20, 0, 0}, {22, 0, 0}, {20, 2, 0}});     // half of a flat 2 x 2 box
  for (int i = 0; i < 9; ++i) tris.push_back({{30, 0, 0}, {32, 0, 0}, {30, 2, 0}});  // the same, 9 times
  Bvh bvh;
  bvh.arity = 4;
  Aabb scene;
  for (const Triangle& t : tris) scene.extend(t.bounds());
  const Aabb sparse{{0, 0, 0}, {10, 10, 10}};
  scene.extend(sparse);
  bvh.nodes = {Node{scene, 1, 3, 0}, Node{sparse, 0, 0, 1}, Node{tris[1].bounds(), 1, 0, 1},
               Node{tris[2].bounds(), 2, 0, 9}};
  bvh.prim_refs = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  ASSERT_TRUE(validate(bvh, tris).ok()) << validate(bvh, tris).summary();
  const SahCost blocks_of_4{1.0f, 1.0f, 4};
  order_children_for_occlusion(bvh, tris, blocks_of_4);
  ASSERT_TRUE(validate(bvh, tris).ok()) << validate(bvh, tris).summary();
  EXPECT_EQ(bvh.nodes[1].prim_count, 1u);
  EXPECT_EQ(bvh.nodes[1].first, 1u) << "the filled box, one block";
  EXPECT_EQ(bvh.nodes[2].prim_count, 9u) << "the filled box, three blocks";
  EXPECT_EQ(bvh.nodes[3].first, 0u) << "the sparse box last";
}

// The wide builders store children in this order, the order in which any hit visits a wide tree's
// children after the nearest (bvh2_traversal.h: resolve_any_hit_order); binary trees keep their
// builders' order.
TEST(ChildOrder, EveryWideBuilderWritesTheOcclusionOrder) {
  const auto tris = test::random_triangles(2000, 8);
  int wide_builders = 0;
  for (const BuilderInfo& info : builders()) {
    SCOPED_TRACE(info.name);
    const ParamSet params = resolve_params(info.name, info.params, {});
    const Bvh bvh = info.build(BuildInput::from_triangles(tris), params);
    ASSERT_TRUE(validate(bvh, tris).ok()) << validate(bvh, tris).summary();
    EXPECT_EQ(resolve_any_hit_order(bvh), bvh.arity > 2 ? AnyHitOrder::kStored : AnyHitOrder::kNearest);
    if (bvh.arity <= 2) continue;
    ++wide_builders;
    expect_ordered(bvh, tris, sah_cost_of(params));
  }
  EXPECT_GE(wide_builders, 3) << "wide_binned_sah, wide_collapse and wide_sbvh";
}

}  // namespace
}  // namespace sahbench
