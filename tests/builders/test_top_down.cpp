// The shared top-down recursion on its own, driven by a splitter that always proposes the worst split.

#include <gtest/gtest.h>

#include <atomic>
#include <numeric>

#include "builders/top_down.h"
#include "core/bvh_stats.h"
#include "core/validate.h"
#include "tests/support/test_scenes.h"

namespace sahbench {
namespace {

// Peels one primitive off every node at a cost below any leaf's: left unchecked, a tree of n primitives
// would be n deep and overflow the kernels' fixed stacks.
class PeelSplitter {
 public:
  explicit PeelSplitter(std::vector<Aabb> bounds) : bounds_(std::move(bounds)), order_(bounds_.size()) {
    std::iota(order_.begin(), order_.end(), 0u);
  }

  NodeRange root() const { return range(0, static_cast<uint32_t>(order_.size())); }
  Split find_split(const NodeRange&) const { return {0.5f, 0, 1}; }
  Partition partition(const NodeRange& r, const Split&) const { return split_at(r, r.begin + 1); }
  Partition partition_median(const NodeRange& r) const {
    ++median_splits;
    return split_at(r, r.begin + r.size() / 2);
  }
  uint32_t prim_id(uint32_t position) const { return order_[position]; }

  mutable std::atomic<int> median_splits{0};

 private:
  NodeRange range(uint32_t begin, uint32_t end) const {
    NodeRange r{begin, end, {}, {}};
    for (uint32_t i = begin; i < end; ++i) {
      r.bounds.extend(bounds_[order_[i]]);
      r.centroid_bounds.extend(bounds_[order_[i]].center());
    }
    return r;
  }
  Partition split_at(const NodeRange& r, uint32_t mid) const {
    return {range(r.begin, mid), range(mid, r.end)};
  }

  std::vector<Aabb> bounds_;
  std::vector<uint32_t> order_;
};

TEST(BuilderTopDown, WorstCaseSplitsStayWithinTheDepthLimitAndLeafSize) {
  const auto tris = test::random_triangles(3000, 12);
  std::vector<Aabb> bounds;
  for (const auto& t : tris) bounds.push_back(t.bounds());
  for (uint32_t max_leaf : {1u, 4u}) {
    PeelSplitter splitter(bounds);
    TopDownConfig config;
    config.max_leaf = max_leaf;
    const Bvh bvh = build_top_down(splitter, config, splitter.root());
    const ValidationReport report = validate(bvh, bounds);
    ASSERT_TRUE(report.ok()) << report.summary();
    const BvhStats stats = compute_stats(bvh, bounds.size(), config.cost);
    EXPECT_LT(stats.max_depth, kMaxDepth);
    // Peeling goes as deep as the bound allows (kMaxDepth - 1 - ceil(log2 n)), then halving takes over.
    EXPECT_GE(stats.max_depth, kMaxDepth - 2 - 12);
    EXPECT_GT(splitter.median_splits.load(), 0);
    EXPECT_LE(stats.max_leaf_size, max_leaf);
  }
}

}  // namespace
}  // namespace sahbench
