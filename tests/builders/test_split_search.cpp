// The full sweep considers every split a binned search can propose (bins are ordered by centroid, so each
// binned split is a prefix of the sorted order), and costs it with the same SahCost on the same exact
// bounds: its best split can never cost more.

#include <gtest/gtest.h>

#include <numeric>
#include <random>

#include "builders/binned_sah.h"
#include "builders/sweep_sah.h"
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

}  // namespace
}  // namespace sahbench
