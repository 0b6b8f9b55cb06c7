#include "builders/sweep_sah.h"

#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <array>
#include <limits>
#include <numeric>
#include <vector>

#include "builders/size_split.h"

namespace sahbench {
namespace {

// Nodes at least this large run their three axes as parallel tasks; only speed depends on it.
constexpr uint32_t kParallelThreshold = 1u << 14;

// Keeps, for each axis, the primitive ids sorted by (box centre on that axis, id) within every node's
// range. Partitioning a node keeps the three orders sorted by stable-partitioning the two other axes.
class SweepSplitter {
 public:
  SweepSplitter(const BuildInput& input, std::span<const uint32_t> prims, const TopDownConfig& config)
      : input_(input), config_(config), side_(input.size(), 0) {
    auto sort_axis = [&](int axis) {
      auto& order = order_[axis];
      order.assign(prims.begin(), prims.end());
      // (centroid, id) is a total order, so the unstable parallel sort is deterministic.
      tbb::parallel_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
        const float ca = input_.bounds[a].center()[axis], cb = input_.bounds[b].center()[axis];
        return ca < cb || (ca == cb && a < b);
      });
    };
    tbb::parallel_invoke([&] { sort_axis(0); }, [&] { sort_axis(1); }, [&] { sort_axis(2); });
  }

  Split find_split(const NodeRange& range) const {
    const float parent_area = range.bounds.half_area();
    if (!(parent_area > 0.0f)) return {};
    std::array<Split, 3> best;
    auto sweep = [&](int axis) { best[axis] = sweep_axis(range, axis, parent_area); };
    if (range.size() >= kParallelThreshold) {
      tbb::parallel_invoke([&] { sweep(0); }, [&] { sweep(1); }, [&] { sweep(2); });
    } else {
      for (int a = 0; a < 3; ++a) sweep(a);
    }
    // Ties keep the lowest axis, as the binned builder does, and planes over a size split.
    Split result = best[0];
    for (int a = 1; a < 3; ++a)
      if (best[a].cost < result.cost) result = best[a];
    if (config_.size_split && range.size() >= kSizeSplitMinPrims) {
      const SizeBins bins = bin_sizes(
          range.size(), [&](uint32_t i) -> const Aabb& { return input_.bounds[order_[0][range.begin + i]]; },
          parent_area);
      const SizeSplit by_size = best_size_split(bins, range.size(), parent_area, config_.cost);
      if (by_size.split.cost < result.cost) result = by_size.split;
    }
    return result;
  }

  Partition partition(const NodeRange& range, const Split& split) {
    // A plane's left side is a prefix of its axis's order; a size split's is the large primitives, and
    // all three orders are partitioned stably.
    const bool by_size = split.axis == kSizeSplitAxis;
    const auto axis = by_size ? 0 : static_cast<int>(split.axis);
    const float node_area = range.bounds.half_area();
    uint32_t mid = range.begin + split.position;
    const auto& order = order_[axis];
    Aabb left, right, left_c, right_c;
    uint32_t left_count = 0;
    for (uint32_t i = range.begin; i < range.end; ++i) {
      const uint32_t p = order[i];
      const bool is_left =
          by_size ? goes_left_of_size_split(split, input_.bounds[p].half_area(), node_area) : i < mid;
      side_[p] = is_left;
      left_count += is_left;
      (is_left ? left : right).extend(input_.bounds[p]);
      (is_left ? left_c : right_c).extend(input_.bounds[p].center());
    }
    if (by_size) mid = range.begin + left_count;
    auto reorder = [&](int other) {
      if (by_size || other != axis) stable_partition(order_[other], range);
    };
    if (range.size() >= kParallelThreshold) {
      tbb::parallel_invoke([&] { reorder(0); }, [&] { reorder(1); }, [&] { reorder(2); });
    } else {
      for (int a = 0; a < 3; ++a) reorder(a);
    }
    return {{range.begin, mid, left, left_c}, {mid, range.end, right, right_c}};
  }

  // The sorted order makes the object median exact: the first half on the axis of largest extent.
  Partition partition_median(const NodeRange& range) {
    const auto axis = static_cast<uint32_t>(largest_axis(range.centroid_bounds.extent()));
    return partition(range, {0.0f, axis, range.size() / 2});
  }

  uint32_t prim_id(uint32_t position) const { return order_[0][position]; }

 private:
  // Right-to-left prefix areas, then a left-to-right scan evaluating a split after each position.
  Split sweep_axis(const NodeRange& range, int axis, float parent_area) const {
    const auto& order = order_[axis];
    const uint32_t n = range.size();
    // Weighted areas (area * count) compared as in the binned search; only the winner becomes a cost.
    std::vector<float> right_weighted(n);
    Aabb acc;
    for (uint32_t i = n; i-- > 1;) {
      acc.extend(input_.bounds[order[range.begin + i]]);
      right_weighted[i] = acc.half_area() * static_cast<float>(n - i);
    }
    Split best;
    float best_weighted = std::numeric_limits<float>::infinity();
    acc = Aabb{};
    for (uint32_t i = 1; i < n; ++i) {
      acc.extend(input_.bounds[order[range.begin + i - 1]]);
      const float weighted = acc.half_area() * static_cast<float>(i) + right_weighted[i];
      if (weighted < best_weighted) {
        best_weighted = weighted;
        best.axis = static_cast<uint32_t>(axis);
        best.position = i;
      }
    }
    if (best_weighted < std::numeric_limits<float>::infinity())
      best.cost = config_.cost.split_cost_from_weighted(parent_area, best_weighted);
    return best;
  }

  void stable_partition(std::vector<uint32_t>& order, const NodeRange& range) const {
    std::vector<uint32_t> right;
    right.reserve(range.size());
    uint32_t out = range.begin;
    for (uint32_t i = range.begin; i < range.end; ++i) {
      const uint32_t p = order[i];
      if (side_[p])
        order[out++] = p;
      else
        right.push_back(p);
    }
    std::copy(right.begin(), right.end(), order.begin() + out);
  }

  const BuildInput& input_;
  const TopDownConfig& config_;
  std::array<std::vector<uint32_t>, 3> order_;
  std::vector<uint8_t> side_;  // per primitive: 1 when it goes left; nodes own disjoint primitives
};

NodeRange root_range(const BuildInput& input, std::span<const uint32_t> prims) {
  struct Bounds {
    Aabb box, centroids;
  };
  const Bounds all = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, prims.size(), 4096), Bounds{},
      [&](const tbb::blocked_range<std::size_t>& r, Bounds acc) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
          acc.box.extend(input.bounds[prims[i]]);
          acc.centroids.extend(input.bounds[prims[i]].center());
        }
        return acc;
      },
      [](Bounds a, const Bounds& b) {
        a.box.extend(b.box);
        a.centroids.extend(b.centroids);
        return a;
      });
  return {0, static_cast<uint32_t>(prims.size()), all.box, all.centroids};
}

}  // namespace

Bvh build_sweep_sah(const BuildInput& input, const SweepSahParams& params) {
  check_config(params.top_down, "sweep_sah");
  check_prim_count(input.size(), "sweep_sah");
  std::vector<uint32_t> prims(input.size());
  std::iota(prims.begin(), prims.end(), 0u);
  SweepSplitter splitter(input, prims, params.top_down);
  return build_top_down(splitter, params.top_down, root_range(input, prims));
}

Split find_sweep_split(const BuildInput& input, std::span<const uint32_t> prims,
                       const SweepSahParams& params) {
  SweepSplitter splitter(input, prims, params.top_down);
  return splitter.find_split(root_range(input, prims));
}

}  // namespace sahbench
