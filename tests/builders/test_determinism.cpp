// Same input, same parameters: the same tree, whatever the thread count (DESIGN.md).

#include <gtest/gtest.h>

#include <tbb/task_arena.h>

#include "builders/registry.h"
#include "tests/support/test_scenes.h"

namespace sahbench {
namespace {

TEST(BuilderDeterminism, SameTreeForAnyThreadCount) {
  // Large enough for the parallel binning, partitioning and subtree tasks to run.
  const auto tris = test::random_triangles(150000, 77, 100.0f);
  const BuildInput input = BuildInput::from_triangles(tris);
  for (const auto& info : builders()) {
    // The SBVH clips every reference at every node of a soup like this one, which would take most of the
    // suite's time; Sbvh.SameTreeForAnyThreadCount checks it on inputs of its own.
    if (info.name == "sbvh") continue;
    const ParamSet params = resolve_params(info.name, info.params, {});
    auto build_with = [&](int threads) {
      tbb::task_arena arena(threads);
      return arena.execute([&] { return info.build(input, params); });
    };
    const Bvh one = build_with(1);
    ASSERT_FALSE(one.nodes.empty());
    for (int threads : {2, 3, 4}) {
      const Bvh many = build_with(threads);
      EXPECT_TRUE(one == many) << info.name << " differs between 1 and " << threads << " threads";
    }
  }
}

}  // namespace
}  // namespace sahbench
