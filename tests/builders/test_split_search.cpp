// The full sweep considers every split a binned search can propose (bins are ordered by centroid, so each
// binned split is a prefix of the sorted order), and costs it with the same SahCost on the same exact
// bounds: its best split can never cost more.

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "builders/binned_sah.h"
#include "builders/size_split.h"
#include "builders/sweep_sah.h"
#include "core/bvh_stats.h"
#include "tests/builders/builder_cases.h"

namespace sahbench {
namespace {

TEST(BuilderSplitSearch, SweepNeverCostsMoreThanBinned) {
  std::mt19937 rng(21);
  int compared = 0;
  for (const auto& scene : test::scene_cases()) {
    if (scene.triangles.size() < 2) continue;
    const BuildInput input = BuildInput::from_triangles(scene.triangles);
    // Node-like subsets: the whole scene, and random subsets of several sizes.
    for (int trial = 0; trial < 6; ++trial) {
      std::vector<uint32_t> prims(input.size());
      std::iota(prims.begin(), prims.end(), 0u);
      if (trial > 0) {
        std::shuffle(prims.begin(), prims.end(), rng);
        prims.resize(std::max<std::size_t>(2, prims.size() >> trial));
      }
      const Split sweep = find_sweep_split(input, prims, {});
      for (uint32_t bins : {4u, 8u, 16u, 32u, 64u, 256u}) {
        BinnedSahParams params;
        params.bins = bins;
        params.adaptive_bins = (bins % 16) == 0;
        const Split binned = find_binned_split(input, prims, params);
        if (!binned.valid()) continue;
        ++compared;
        ASSERT_TRUE(sweep.valid()) << scene.name;
        EXPECT_LE(sweep.cost, binned.cost) << scene.name << " trial " << trial << " bins " << bins;
      }
    }
  }
  EXPECT_GT(compared, 300);
}

TEST(BuilderSplitSearch, BinnedSplitOfTwoSeparatedClustersIsBetweenThem) {
  // Two unit triangles far apart on x: the best split separates them, at a cost well below a leaf's.
  std::vector<Triangle> tris;
  for (int i = 0; i < 8; ++i) {
    const float x = i < 4 ? 0.0f : 100.0f;
    tris.push_back({{x, 0, float(i)}, {x + 1, 0, float(i)}, {x, 1, float(i)}});
  }
  const BuildInput input = BuildInput::from_triangles(tris);
  std::vector<uint32_t> prims(8);
  std::iota(prims.begin(), prims.end(), 0u);
  const Split split = find_binned_split(input, prims, {});
  ASSERT_TRUE(split.valid());
  EXPECT_EQ(split.axis, 0u);
  EXPECT_LT(split.cost, SahCost{}.leaf_cost(8));
  const Split sweep = find_sweep_split(input, prims, {});
  EXPECT_EQ(sweep.axis, 0u);
  EXPECT_EQ(sweep.position, 4u);
  EXPECT_FLOAT_EQ(sweep.cost, split.cost);
}

// A room: its floor, ceiling and walls (two large triangles each) around small triangles in its middle.
// Every centroid plane leaves some of the shell with the contents, whose box then spans the room;
// splitting the twelve large triangles from the rest is cheaper, and both searches take it.
std::vector<Triangle> room(uint32_t contents, uint64_t seed) {
  std::vector<Triangle> tris;
  const float lo = -10.0f, hi = 10.0f;
  for (int axis = 0; axis < 3; ++axis) {
    for (const float at : {lo, hi}) {
      auto corner = [&](float u, float v) {
        Vec3 p;
        p[axis] = at;
        p[(axis + 1) % 3] = u;
        p[(axis + 2) % 3] = v;
        return p;
      };
      tris.push_back({corner(lo, lo), corner(hi, lo), corner(hi, hi)});
      tris.push_back({corner(lo, lo), corner(hi, hi), corner(lo, hi)});
    }
  }
  std::mt19937 rng(static_cast<std::mt19937::result_type>(seed));
  std::uniform_real_distribution<float> inside(-4.0f, 4.0f);
  for (uint32_t i = 0; i < contents; ++i) {
    const Vec3 c{inside(rng), inside(rng), inside(rng)};
    tris.push_back({c, c + Vec3{0.5f, 0.0f, 0.0f}, c + Vec3{0.0f, 0.5f, 0.2f}});
  }
  return tris;
}

// The primitives in the subtree of node `index`.
uint32_t subtree_prims(const Bvh& bvh, uint32_t index) {
  uint32_t count = 0;
  std::vector<uint32_t> stack{index};
  while (!stack.empty()) {
    const Node& n = bvh.nodes[stack.back()];
    stack.pop_back();
    if (n.is_leaf()) {
      count += n.prim_count;
    } else {
      for (uint32_t k = 0; k < n.child_count; ++k) stack.push_back(n.first + k);
    }
  }
  return count;
}

TEST(BuilderSplitSearch, BothSearchesSplitAnEnclosingShellFromItsContents) {
  const BuildInput input = BuildInput::from_triangles(room(500, 3));
  std::vector<uint32_t> prims(input.size());
  std::iota(prims.begin(), prims.end(), 0u);
  BinnedSahParams planes_only;
  planes_only.top_down.size_split = false;
  const Split plane = find_binned_split(input, prims, planes_only);
  const Split binned = find_binned_split(input, prims, {});
  const Split sweep = find_sweep_split(input, prims, {});
  ASSERT_TRUE(plane.valid());
  EXPECT_EQ(binned.axis, kSizeSplitAxis);
  EXPECT_EQ(sweep.axis, kSizeSplitAxis);
  // A wall triangle's box (20 x 20, flat) has a third of the room's half-area: class 1. The contents'
  // boxes are far smaller.
  EXPECT_EQ(binned.position, 1u);
  EXPECT_EQ(sweep.position, binned.position);
  EXPECT_EQ(sweep.cost, binned.cost);
  EXPECT_LT(binned.cost, 0.8f * plane.cost);
}

// Built whole: the root separates the shell, and the tree's SAH is lower than with planes alone, by more
// than a tenth for the binned builder.
TEST(BuilderSplitSearch, SizeSplitsLowerTheSahOfARoom) {
  const auto tris = room(2000, 5);
  const BuildInput input = BuildInput::from_triangles(tris);
  BinnedSahParams binned;
  BinnedSahParams binned_planes;
  binned_planes.top_down.size_split = false;
  SweepSahParams sweep;
  SweepSahParams sweep_planes;
  sweep_planes.top_down.size_split = false;
  const SahCost cost;
  const double with = sah_cost(build_binned_sah(input, binned), cost);
  const double without = sah_cost(build_binned_sah(input, binned_planes), cost);
  EXPECT_LT(with, 0.9 * without);

  // The sweep peels the walls off one plane at a time, which planes alone already do fairly well here.
  EXPECT_LT(sah_cost(build_sweep_sah(input, sweep), cost),
            sah_cost(build_sweep_sah(input, sweep_planes), cost));
  // The root's children: the twelve shell triangles in a subtree of their own.
  const Bvh bvh = build_binned_sah(input, binned);
  ASSERT_FALSE(bvh.root().is_leaf());
  EXPECT_EQ(std::min(subtree_prims(bvh, bvh.root().first), subtree_prims(bvh, bvh.root().first + 1)), 12u);
}

// A room of 70,000 triangles: its root takes the size split on the parallel paths (binning the classes and
// partitioning with several tasks, from 64K primitives on), and the binned and swept trees are the same
// for any thread count.
TEST(BuilderSplitSearch, SizeSplitsOfLargeNodesGiveOneTreeForAnyThreadCount) {
  const auto tris = room(70000, 9);
  const BuildInput input = BuildInput::from_triangles(tris);
  std::vector<uint32_t> prims(input.size());
  std::iota(prims.begin(), prims.end(), 0u);
  EXPECT_EQ(find_binned_split(input, prims, {}).axis, kSizeSplitAxis);
  EXPECT_EQ(find_sweep_split(input, prims, {}).axis, kSizeSplitAxis);
  for (const bool swept : {false, true}) {
    SCOPED_TRACE(swept ? "sweep_sah" : "binned_sah");
    auto build_with = [&](int threads) {
      tbb::task_arena arena(threads);
      return arena.execute([&] { return swept ? build_sweep_sah(input, {}) : build_binned_sah(input, {}); });
    };
    const Bvh one = build_with(1);
    EXPECT_EQ(std::min(subtree_prims(one, one.root().first), subtree_prims(one, one.root().first + 1)), 12u);
    for (const int threads : {2, 3}) EXPECT_TRUE(one == build_with(threads)) << threads << " threads";
  }
}

}  // namespace
}  // namespace sahbench
