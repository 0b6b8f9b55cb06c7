#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "builders/binned_sah.h"
#include "builders/child_order.h"
#include "builders/registry.h"
#include "core/bvh_stats.h"
#include "core/validate.h"
#include "traversal/bvh2_traversal.h"
#include "tests/support/test_scenes.h"

namespace sahbench {
namespace {

// Every node's children, as (box, leaf range or child count) records, sorted: the same multiset before
// and after a reordering that only permutes siblings.
std::vector<std::vector<float>> sorted_records(const Bvh& bvh) {
  std::vector<std::vector<float>> out;
  for (const Node& n : bvh.nodes)
    out.push_back({n.bounds.min.x, n.bounds.min.y, n.bounds.min.z, n.bounds.max.x, n.bounds.max.y, n.bounds.max.z,
                   float(n.child_count), float(n.prim_count)});
  std::sort(out.begin(), out.end());
  return out;
}

void expect_largest_first(const Bvh& bvh) {
  for (std::size_t i = 0; i < bvh.nodes.size(); ++i) {
    const Node& n = bvh.nodes[i];
    if (n.is_leaf()) continue;
    for (uint32_t c = 1; c < n.child_count; ++c)
      ASSERT_GE(bvh.nodes[n.first + c - 1].bounds.half_area(), bvh.nodes[n.first + c].bounds.half_area())
          << "node " << i << " child " << c;
  }
}

TEST(ChildOrder, PermutesSiblingsOnlyAndKeepsTheTreeValid) {
  const auto tris = test::random_triangles(3000, 4);
  const Bvh built = build_binned_sah(BuildInput::from_triangles(tris), {});
  Bvh ordered = built;
  order_children_by_area(ordered);
  ASSERT_TRUE(validate(ordered, tris).ok()) << validate(ordered, tris).summary();
  expect_largest_first(ordered);
  EXPECT_NE(ordered.nodes, built.nodes) << "random triangles must give some node whose children move";
  EXPECT_EQ(sorted_records(ordered), sorted_records(built));
  EXPECT_EQ(sah_cost(ordered, SahCost{}), sah_cost(built, SahCost{}));
  // Ordering twice changes nothing (stable, and already in order).
  Bvh twice = ordered;
  order_children_by_area(twice);
  EXPECT_EQ(twice.nodes, ordered.nodes);
}

// The wide builders store children largest first, the order in which any hit visits a wide tree's
// children (bvh2_traversal.h: any_hit_in_storage_order); binary trees keep their builders' order.
TEST(ChildOrder, EveryWideBuilderWritesChildrenLargestFirst) {
  const auto tris = test::random_triangles(2000, 8);
  int wide_builders = 0;
  for (const BuilderInfo& info : builders()) {
    SCOPED_TRACE(info.name);
    const Bvh bvh = info.build(BuildInput::from_triangles(tris), resolve_params(info.name, info.params, {}));
    ASSERT_TRUE(validate(bvh, tris).ok()) << validate(bvh, tris).summary();
    EXPECT_EQ(any_hit_in_storage_order(bvh), bvh.arity > 2);
    if (bvh.arity <= 2) continue;
    ++wide_builders;
    expect_largest_first(bvh);
  }
  EXPECT_GE(wide_builders, 2) << "wide_binned_sah and wide_collapse";
}

}  // namespace
}  // namespace sahbench
