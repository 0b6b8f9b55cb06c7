// Same input, same parameters: the same tree, whatever the thread count (DESIGN.md).

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <string>
#include <utility>
#include <vector>

#include "builders/binned_sah.h"
#include "builders/registry.h"
#include "tests/support/test_scenes.h"

namespace sahbench {
namespace {

TEST(BuilderDeterminism, SameTreeForAnyThreadCount) {
  // Large enough for the parallel binning, partitioning and subtree tasks to run.
  const auto tris = test::random_triangles(150000, 77, 100.0f);
  const BuildInput input = BuildInput::from_triangles(tris);
  std::vector<std::pair<std::string, ParamOverrides>> runs;
  for (const auto& info : builders()) runs.push_back({info.name, {}});
  // Passes in a chain, and the passes where every node searches (reinsert) or treelets are largest.
  runs.push_back({"wide_collapse",
                  {{"source", "treelet"},
                   {"source.iterations", "1"},
                   {"source.source", "reinsert"},
                   {"source.source.iterations", "2"}}});
  // A source that repeats references: the collapse's sets of distinct references merge in its tasks.
  runs.push_back({"wide_collapse", {{"source", "presplit"}, {"source.split_budget", "1"}}});
  runs.push_back({"reinsert", {{"batch", "1"}, {"iterations", "1"}}});
  runs.push_back({"treelet", {{"treelet_size", "9"}, {"iterations", "1"}}});
  for (const auto& [name, overrides] : runs) {
    // The SBVH clips every reference at every node of a soup like this one, which would take most of the
    // suite's time; Sbvh.SameTreeForAnyThreadCount checks both on inputs of their own.
    if (name == "sbvh" || name == "wide_sbvh") continue;
    const BuilderInfo& info = find_builder(name);
    const ParamSet params = resolve_params(info.name, info.params, overrides);
    auto build_with = [&](int threads) {
      tbb::task_arena arena(threads);
      return arena.execute([&] { return info.build(input, params); });
    };
    const Bvh one = build_with(1);
    ASSERT_FALSE(one.nodes.empty());
    for (int threads : {2, 3, 4}) {
      const Bvh many = build_with(threads);
      EXPECT_TRUE(one == many) << name << " [" << params.to_string() << "] differs between 1 and " << threads
                               << " threads";
    }
  }
}

// Checks the order every top-down build writes its tree in, whichever slots its tasks took while
// building: each inner node's children side by side, then the first child's subtree, then the second's,
// and the leaves' references in the order the leaves are met.
void expect_depth_first(const Bvh& bvh, const std::string& name) {
  ASSERT_FALSE(bvh.nodes.empty()) << name;
  uint32_t next_node = 1, next_ref = 0;
  std::vector<uint32_t> stack{0};
  while (!stack.empty()) {
    const Node& node = bvh.nodes[stack.back()];
    stack.pop_back();
    if (node.is_leaf()) {
      ASSERT_EQ(node.first, next_ref) << name;
      next_ref += node.prim_count;
      continue;
    }
    ASSERT_EQ(node.first, next_node) << name;
    next_node += node.child_count;
    for (uint32_t c = node.child_count; c-- > 0;) stack.push_back(node.first + c);
  }
  EXPECT_EQ(next_node, bvh.nodes.size()) << name;
  EXPECT_EQ(next_ref, bvh.prim_refs.size()) << name;
}

TEST(BuilderLayout, NodesComeOutDepthFirstWithSiblingsTogether) {
  // 40K triangles give subtrees large enough for the final copy's parallel tasks.
  const auto tris = test::random_triangles(40000, 5, 100.0f);
  const BuildInput input = BuildInput::from_triangles(tris);
  tbb::task_arena arena(4);
  for (const char* name :
       {"binned_sah", "sweep_sah", "sbvh", "reinsert", "treelet", "lbvh", "ploc", "presplit"}) {
    const BuilderInfo& info = find_builder(name);
    const ParamSet params = resolve_params(info.name, info.params, {});
    expect_depth_first(arena.execute([&] { return info.build(input, params); }), name);
  }
  // The wide builders then reorder each node's children for occlusion rays (builders/child_order.h),
  // which moves whole subtrees; the wide build itself, before that, is in the same order.
  BinnedSahParams wide;
  wide.top_down.arity = 8;
  expect_depth_first(arena.execute([&] { return build_binned_sah(input, wide); }), "binned SAH, arity 8");
}

}  // namespace
}  // namespace sahbench
