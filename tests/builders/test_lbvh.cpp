// The LBVH builder: its radix tree split where Karras 2012 splits, duplicate Morton codes (identical
// centres, two clusters of them), the depth bound on a scene whose radix tree is deeper than the
// kernels allow, and the leaf collapse. (The shared scene cases run through BuilderVsReference.)

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <bit>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "builders/leaf_collapse.h"
#include "builders/morton.h"
#include "builders/registry.h"
#include "core/bvh_stats.h"
#include "core/validate.h"
#include "tests/builders/builder_cases.h"
#include "tests/support/hit_check.h"
#include "tests/support/test_scenes.h"
#include "traversal/brute_force.h"
#include "traversal/bvh2_traversal.h"

namespace sahbench {
namespace {

void expect_same_hits_as_brute_force(const Bvh& bvh, const std::vector<Triangle>& tris, std::size_t count) {
  const auto rays = test::random_rays(tris, count, 17);
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const Hit ref = brute_force_closest(tris, rays[i]);
    ASSERT_TRUE(test::same_closest_hit(closest_hit(bvh, tris, rays[i]), ref, tris, rays[i])) << "ray " << i;
    ASSERT_EQ(any_hit(bvh, tris, rays[i]), brute_force_any(tris, rays[i])) << "ray " << i;
  }
}

// A small triangle whose box is centred exactly on p, `r` from it on every axis.
Triangle around(Vec3 p, float r) {
  return {p + Vec3{-r, -r, -r}, p + Vec3{r, r, r}, p + Vec3{r, -r, 0}};
}

// For each node, the range [first, last] of references under it, in tree order.
struct Range {
  uint32_t first, last;
};
Range range_of(const Bvh& bvh, uint32_t index) {
  const Node& node = bvh.nodes[index];
  if (node.is_leaf()) return {node.first, node.first + node.prim_count - 1};
  return {range_of(bvh, node.first).first, range_of(bvh, node.first + node.child_count - 1).last};
}

template <class Code>
int key_delta(const HugePageArray<Code>& codes, uint32_t i, uint32_t j) {
  if (codes[i] != codes[j]) return std::countl_zero(static_cast<Code>(codes[i] ^ codes[j]));
  return int(8 * sizeof(Code)) + std::countl_zero(i ^ j);
}

template <class Code>
void expect_radix_tree(const std::vector<Triangle>& tris, const std::string& bits) {
  SCOPED_TRACE(bits);
  const Bvh bvh = test::build_tree("lbvh", tris, {{"bits", bits}, {"max_leaf", "1"}});
  const BuildInput input = BuildInput::from_triangles(tris);
  const MortonOrder<Code> sorted = sort_by_morton<Code>(input.bounds.span());
  // Leaves left to right are the primitives in Morton order.
  ASSERT_EQ(bvh.prim_refs.size(), tris.size());
  for (std::size_t i = 0; i < tris.size(); ++i) ASSERT_EQ(bvh.prim_refs[i], sorted.ids[i]) << i;
  // Every inner node splits its range where its keys' common prefix ends: the two keys either side of
  // the split differ at the range's highest differing bit (Karras 2012, section 3).
  for (uint32_t n = 0; n < bvh.nodes.size(); ++n) {
    const Node& node = bvh.nodes[n];
    if (node.is_leaf()) continue;
    const Range all = range_of(bvh, n), left = range_of(bvh, node.first),
                right = range_of(bvh, node.first + 1);
    ASSERT_EQ(left.first, all.first);
    ASSERT_EQ(left.last + 1, right.first);
    ASSERT_EQ(key_delta(sorted.codes, left.last, right.first), key_delta(sorted.codes, all.first, all.last))
        << "node " << n;
  }
}

TEST(Lbvh, InnerNodesSplitAtTheHighestDifferingBit) {
  const auto tris = test::random_triangles(20000, 31);
  expect_radix_tree<uint32_t>(tris, "30");
  expect_radix_tree<uint64_t>(tris, "63");
  // Many equal codes: clusters of identical triangles.
  std::vector<Triangle> clustered;
  for (int i = 0; i < 3000; ++i) clustered.push_back(around({float(i % 7), float(i % 3), 0.0f}, 0.25f));
  expect_radix_tree<uint32_t>(clustered, "30");
}

TEST(Lbvh, IdenticalCentresGiveABalancedTree) {
  // One Morton code for all: the positions appended to the keys split the run in halves by their bits.
  const std::vector<Triangle> tris(10000, around({1, 2, 3}, 0.5f));
  for (const char* bits : {"30", "63"}) {
    const Bvh bvh = test::build_tree("lbvh", tris, {{"bits", bits}, {"max_leaf", "1"}});
    ASSERT_TRUE(validate(bvh, tris).ok());
    const BvhStats stats = compute_stats(bvh, tris.size(), SahCost{});
    EXPECT_EQ(stats.max_depth, uint32_t(std::bit_width(tris.size() - 1))) << bits;
    EXPECT_EQ(stats.leaves, tris.size());
  }
}

TEST(Lbvh, TwoClustersOfEqualCodesSplitAtTheRoot) {
  std::vector<Triangle> tris(5000, around({-50, 0, 0}, 0.5f));
  tris.insert(tris.end(), 3000, around({50, 10, 0}, 0.5f));
  const Bvh bvh = test::build_tree("lbvh", tris);
  ASSERT_TRUE(validate(bvh, tris).ok());
  const Node& root = bvh.root();
  ASSERT_EQ(root.child_count, 2u);
  // Each child holds one cluster: the first 5000 primitives, then the other 3000.
  const Range left = range_of(bvh, root.first), right = range_of(bvh, root.first + 1);
  ASSERT_EQ(left.last - left.first + 1, 5000u);
  ASSERT_EQ(right.last - right.first + 1, 3000u);
  for (uint32_t r = left.first; r <= left.last; ++r) ASSERT_LT(bvh.prim_refs[r], 5000u);
  for (uint32_t r = right.first; r <= right.last; ++r) ASSERT_GE(bvh.prim_refs[r], 5000u);
  EXPECT_EQ(bvh.nodes[root.first].bounds, tris.front().bounds());
  EXPECT_EQ(bvh.nodes[root.first + 1].bounds, tris.back().bounds());
  // Within each cluster, halving by position.
  EXPECT_LE(compute_stats(bvh, tris.size(), SahCost{}).max_depth, 1u + std::bit_width(5000u - 1));
}

// Height of the radix tree over sorted keys [a, b] (Karras's tree, found top-down here).
template <class Code>
uint32_t radix_height(const HugePageArray<Code>& codes, uint32_t a, uint32_t b) {
  if (a == b) return 0;
  const int common = key_delta(codes, a, b);
  uint32_t split = a;
  while (key_delta(codes, a, split + 1) > common) ++split;
  return 1 + std::max(radix_height(codes, a, split), radix_height(codes, split + 1, b));
}

// Centres on the three axes at 1, 2, 4, ..., 2^20 (the 63-bit grid's cells are one unit wide, fixed by a
// corner at 2^21): their codes are single bits, each splitting off at the next bit, a chain 63 deep; and
// 1024 copies at the origin, whose equal codes add 10 levels below it.
std::vector<Triangle> axis_chain() {
  std::vector<Triangle> tris(1024, around({0, 0, 0}, 0.25f));
  for (int i = 0; i <= 20; ++i) {
    const float c = std::ldexp(1.0f, i);
    tris.push_back(around({c, 0, 0}, 0.25f));
    tris.push_back(around({0, c, 0}, 0.25f));
    tris.push_back(around({0, 0, c}, 0.25f));
  }
  const float corner = std::ldexp(1.0f, 21);
  tris.push_back(around({corner, corner, corner}, 0.25f));
  return tris;
}

TEST(Lbvh, DeepRadixTreesAreRebuiltWithinTheDepthLimit) {
  const auto tris = axis_chain();
  const BuildInput input = BuildInput::from_triangles(tris);
  const MortonOrder<uint64_t> sorted = sort_by_morton<uint64_t>(input.bounds.span());
  const uint32_t height = radix_height(sorted.codes, 0, static_cast<uint32_t>(tris.size() - 1));
  ASSERT_GT(height, kClusterDepthLimit) << "the scene no longer tests the depth bound";
  for (const char* max_leaf : {"1", "8"}) {
    SCOPED_TRACE(max_leaf);
    const Bvh bvh = test::build_tree("lbvh", tris, {{"bits", "63"}, {"max_leaf", max_leaf}});
    const ValidationReport report = validate(bvh, tris);
    ASSERT_TRUE(report.ok()) << report.summary();
    const BvhStats stats = compute_stats(bvh, tris.size(), SahCost{});
    EXPECT_LE(stats.max_depth, kClusterDepthLimit);
    // Only the part below the limit is rebuilt: the chain above it stays.
    EXPECT_GE(stats.max_depth, 50u);
    expect_same_hits_as_brute_force(bvh, tris, 2000);
  }
  // With 30-bit codes the same centres fall into few cells, and the tree stays shallow.
  const Bvh coarse = test::build_tree("lbvh", tris);
  EXPECT_TRUE(validate(coarse, tris).ok());
  EXPECT_LT(compute_stats(coarse, tris.size(), SahCost{}).max_depth, 50u);
}

TEST(Lbvh, ApetreisPassFindsKarrasTree) {
  // Apetrei's pass walks the leaves in chunks of 4096 and takes atomics only at the nodes over a chunk
  // boundary: scenes of one chunk and of many, and runs of equal codes thousands long that straddle the
  // boundaries.
  std::vector<Triangle> clustered, long_runs, one_run;
  for (int i = 0; i < 3000; ++i) clustered.push_back(around({float(i % 7), float(i % 3), 0.0f}, 0.25f));
  for (int i = 0; i < 40000; ++i) long_runs.push_back(around({float(i % 7), float(i % 3), 0.0f}, 0.25f));
  // One run of equal codes over several whole chunks, between a few distinct primitives.
  for (int i = 0; i < 20000; ++i) one_run.push_back(around({1.0f, 2.0f, 3.0f}, 0.25f));
  for (int i = 0; i < 5; ++i) one_run.push_back(around({float(i), 0.0f, 0.0f}, 0.25f));
  // Counts that end a chunk exactly, and one past it (a last chunk of one leaf).
  for (const auto& tris : {test::random_triangles(50000, 41), test::random_triangles(8192, 42),
                           test::random_triangles(8193, 43), clustered, long_runs, one_run, axis_chain()}) {
    for (const char* bits : {"30", "63"}) {
      for (const char* max_leaf : {"1", "8"}) {
        auto with = [&](const char* hierarchy) {
          return test::build_tree("lbvh", tris,
                                  {{"bits", bits}, {"max_leaf", max_leaf}, {"hierarchy", hierarchy}});
        };
        EXPECT_TRUE(with("karras") == with("apetrei")) << bits << " " << max_leaf;
      }
    }
  }
}

TEST(Lbvh, LeafCollapseNeverRaisesTheSah) {
  // Collapsing a subtree into a leaf is taken only where it costs no more, so the tree with leaves of up
  // to 8 costs no more than the same radix tree with single-primitive leaves.
  for (const auto& tris : {test::random_triangles(30000, 8), test::cube_grid(30, 1.0f)}) {
    for (const char* builder : {"lbvh", "ploc"}) {
      const SahCost cost;
      const double fine = sah_cost(test::build_tree(builder, tris, {{"max_leaf", "1"}}), cost);
      const double collapsed = sah_cost(test::build_tree(builder, tris), cost);
      EXPECT_LE(collapsed, fine * (1 + 1e-6)) << builder;
      EXPECT_LT(collapsed, fine) << builder << ": nothing was collapsed";
    }
  }
}

TEST(Lbvh, SameTreeForAnyThreadCount) {
  const auto tris = test::random_triangles(200000, 12, 100.0f);
  for (const char* hierarchy : {"karras", "apetrei"}) {
    for (const char* bits : {"30", "63"}) {
      auto with = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        return test::build_tree("lbvh", tris, {{"bits", bits}, {"hierarchy", hierarchy}});
      };
      const Bvh one = with(1), two = with(2);
      ASSERT_EQ(one.nodes.size(), two.nodes.size());
      ASSERT_EQ(one.prim_refs, two.prim_refs);
      EXPECT_EQ(std::memcmp(one.nodes.data(), two.nodes.data(), one.nodes.size() * sizeof(Node)), 0)
          << hierarchy << " " << bits;
    }
  }
}

TEST(Lbvh, RejectsBadParameters) {
  const auto& info = find_builder("lbvh");
  EXPECT_THROW(resolve_params(info.name, info.params, {{"bits", "32"}}), Error);
  const auto params = resolve_params(info.name, info.params, {{"min_leaf", "9"}});
  EXPECT_THROW(info.check(params), Error);
}

}  // namespace
}  // namespace sahbench
