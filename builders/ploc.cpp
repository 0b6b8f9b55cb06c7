#include "builders/ploc.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "builders/leaf_collapse.h"
#include "builders/morton.h"
#include "core/error.h"

namespace sahbench {
namespace {

constexpr const char* kName = "ploc";
// Clusters per task in each round's parallel loops. Fixed, so the chunks do not depend on the thread
// count (the results never depend on the chunks: neighbours are exact minima, positions exact sums).
// Small, because the rounds shrink geometrically: with 8192 most rounds of a 100k-primitive build were
// one or two tasks, and 2 threads built it in 16.3-17.0 ms against 12.3-12.4 with 2048 (1 thread alike).
constexpr uint32_t kChunk = 1u << 11;
constexpr float kInf = std::numeric_limits<float>::infinity();

// The clusters of a round, coordinate by coordinate (structure of arrays), so that the neighbour search's
// distances from one cluster to the next `radius` are a loop over consecutive floats, which the compiler
// vectorizes (with the boxes side by side it did not).
struct Clusters {
  explicit Clusters(uint32_t n) {
    for (auto& a : min) a = HugePageArray<float>(n);
    for (auto& a : max) a = HugePageArray<float>(n);
    tag = HugePageArray<uint32_t>(n);
  }
  Aabb box(uint32_t i) const {
    return {{min[0][i], min[1][i], min[2][i]}, {max[0][i], max[1][i], max[2][i]}};
  }
  void set(uint32_t i, const Aabb& box, uint32_t t) {
    for (int a = 0; a < 3; ++a) {
      min[a][i] = box.min[a];
      max[a][i] = box.max[a];
    }
    tag[i] = t;
  }

  HugePageArray<float> min[3], max[3];
  HugePageArray<uint32_t> tag;  // an inner node or a leaf (leaf_collapse.h)
};

// The distance of two clusters: the half area of their merged box. NaN, from an infinite
// extent times a zero one, counts as the largest distance.
inline float distance(const Aabb& a, const Aabb& b) {
  const float x = std::max(a.max.x, b.max.x) - std::min(a.min.x, b.min.x);
  const float y = std::max(a.max.y, b.max.y) - std::min(a.min.y, b.min.y);
  const float z = std::max(a.max.z, b.max.z) - std::min(a.min.z, b.min.z);
  const float area = x * y + y * z + z * x;
  return area == area ? area : kInf;
}

// A candidate neighbour of cluster i as one integer, so that the nearest is a minimum without branches:
// the distance's bits (non-negative floats order as their bit patterns), then for equal distances the
// pair's indices: the closer pair in the order first, then the pair whose lower index is even, then the
// lower pair, i.e. the neighbour before i before the one after it. One total order on pairs, the same
// seen from both ends, keeps nearest neighbours free of cycles; and where all distances are equal, the
// even-odd rule pairs clusters 0-1, 2-3, ..., halving their number each round, where a rule by the lower
// index alone would merge one pair per round into a chain.
inline uint64_t candidate(float distance, uint32_t gap, uint32_t lower, bool after) {
  return uint64_t{std::bit_cast<uint32_t>(distance)} << 32 | gap << 2 | (lower & 1u) << 1 | uint32_t{after};
}

// The neighbour of cluster i that `key` (a candidate's) stands for.
inline uint32_t neighbour_of(uint32_t i, uint64_t key) {
  const auto gap = static_cast<uint32_t>(key >> 2) & 0x3FFFFFFFu;
  return (key & 1u) ? i + gap : i - gap;
}

class Clustering {
 public:
  Clustering(const ClusterTree& tree, const LeafCollapse& rule, uint32_t radius)
      : tree_(tree), rule_(rule), radius_(radius) {}

  // Merges the n leaves of `tree` into one tree; returns the root's tag.
  uint32_t run() {
    const auto n = static_cast<uint32_t>(tree_.order.size());
    Clusters current(n), next(n);
    neighbour_ = HugePageArray<uint32_t>(n);
    tbb::parallel_for(0u, chunks(n), [&](uint32_t c) {
      for (uint32_t i = c * kChunk; i < std::min(n, (c + 1) * kChunk); ++i)
        current.set(i, tag_bounds(tree_, leaf_tag(i)), leaf_tag(i));
    });
    uint32_t count = n, next_node = 0;
    while (count > 1) {
      find_neighbours(current, count);
      const uint32_t merges = merge_mutual(current, next, count, next_node);
      std::swap(current, next);
      count -= merges;
      next_node += merges;
    }
    return current.tag[0];
  }

 private:
  static uint32_t chunks(uint32_t count) { return (count + kChunk - 1) / kChunk; }

  // The distances from cluster i to clusters i + 1 .. i + span, into d[0, span): distance() lane by lane
  // (i's box first, as there), with the same operations in the same order.
  static void distances_after(const Clusters& c, uint32_t i, uint32_t span, float* d) {
    const float lo_x = c.min[0][i], lo_y = c.min[1][i], lo_z = c.min[2][i];
    const float hi_x = c.max[0][i], hi_y = c.max[1][i], hi_z = c.max[2][i];
    const float *min_x = c.min[0].data() + i + 1, *min_y = c.min[1].data() + i + 1,
                *min_z = c.min[2].data() + i + 1;
    const float *max_x = c.max[0].data() + i + 1, *max_y = c.max[1].data() + i + 1,
                *max_z = c.max[2].data() + i + 1;
    for (uint32_t k = 0; k < span; ++k) {
      const float x = std::max(hi_x, max_x[k]) - std::min(lo_x, min_x[k]);
      const float y = std::max(hi_y, max_y[k]) - std::min(lo_y, min_y[k]);
      const float z = std::max(hi_z, max_z[k]) - std::min(lo_z, min_z[k]);
      const float area = x * y + y * z + z * x;
      d[k] = area == area ? area : kInf;
    }
  }

  // Each cluster's nearest neighbour among those within `radius` positions. Each task
  // takes a chunk and computes every distance in it once, offering it to both ends (the pairs reaching
  // back into the previous chunk are computed first); the neighbour is a minimum in a total order, so it
  // does not depend on how the chunks are cut.
  void find_neighbours(const Clusters& clusters, uint32_t count) {
    tbb::parallel_for(0u, chunks(count), [&](uint32_t c) {
      const uint32_t begin = c * kChunk, end = std::min(count, begin + kChunk);
      std::vector<uint64_t> nearest(end - begin, ~uint64_t{0});
      for (uint32_t i = begin; i < std::min(end, begin + radius_); ++i)
        for (uint32_t j = i > radius_ ? i - radius_ : 0; j < begin; ++j) {
          const uint64_t key = candidate(distance(clusters.box(i), clusters.box(j)), i - j, j, false);
          nearest[i - begin] = std::min(nearest[i - begin], key);
        }
      alignas(64) float d[kPlocMaxRadius];
      for (uint32_t i = begin; i < end; ++i) {
        const uint32_t span = std::min(count - 1, i + radius_) - i;  // neighbours after i
        const uint32_t inside = std::min(end - 1 - i, span);         // of them in this chunk
        distances_after(clusters, i, span, d);
        // Over consecutive distances and keys: loops the compiler vectorizes.
        uint64_t mine = nearest[i - begin];
        for (uint32_t k = 0; k < span; ++k) mine = std::min(mine, candidate(d[k], k + 1, i, true));
        uint64_t* const theirs = nearest.data() + (i + 1 - begin);
        for (uint32_t k = 0; k < inside; ++k)
          theirs[k] = std::min(theirs[k], candidate(d[k], k + 1, i, false));
        neighbour_[i] = neighbour_of(i, mine);
      }
    });
  }

  bool mutual(uint32_t i) const { return neighbour_[neighbour_[i]] == i; }

  // Mutual nearest neighbours i < j merge into a new node at i's place, j's place
  // is dropped, and the rest move down over the dropped places. New nodes are numbered from `first_node`
  // in the order of their places. Returns the number of merges.
  uint32_t merge_mutual(const Clusters& in, Clusters& out, uint32_t count, uint32_t first_node) {
    const uint32_t chunk_count = chunks(count);
    std::vector<uint32_t> merges(chunk_count + 1, 0), dropped(chunk_count + 1, 0);
    tbb::parallel_for(0u, chunk_count, [&](uint32_t c) {
      for (uint32_t i = c * kChunk; i < std::min(count, (c + 1) * kChunk); ++i) {
        if (!mutual(i)) continue;
        ++(i < neighbour_[i] ? merges : dropped)[c + 1];
      }
    });
    for (uint32_t c = 0; c < chunk_count; ++c) {
      merges[c + 1] += merges[c];
      dropped[c + 1] += dropped[c];
    }
    tbb::parallel_for(0u, chunk_count, [&](uint32_t c) {
      uint32_t node = first_node + merges[c], gone = dropped[c];
      for (uint32_t i = c * kChunk; i < std::min(count, (c + 1) * kChunk); ++i) {
        const uint32_t j = neighbour_[i];
        if (!mutual(i)) {
          out.set(i - gone, in.box(i), in.tag[i]);
        } else if (i < j) {
          ClusterNode& created = tree_.nodes[node];
          created.child[0] = in.tag[i];
          created.child[1] = in.tag[j];
          created.bounds = merge(in.box(i), in.box(j));
          tree_.costs[node] =
              rule_.combine(created.bounds, rule_.of(tree_, in.tag[i]), rule_.of(tree_, in.tag[j]));
          out.set(i - gone, created.bounds, node);
          ++node;
        } else {
          ++gone;
        }
      }
    });
    return merges[chunk_count];
  }

  const ClusterTree& tree_;
  const LeafCollapse& rule_;
  uint32_t radius_;
  HugePageArray<uint32_t> neighbour_;
};

}  // namespace

void check_ploc_params(const PlocParams& params) {
  const std::string name(kName);
  if (params.radius < 1 || params.radius > kPlocMaxRadius)
    throw Error(name + ": radius = " + std::to_string(params.radius) + " is outside [1, " +
                std::to_string(kPlocMaxRadius) + "]");
  if (params.bits != 30 && params.bits != 63)
    throw Error(name + ": bits = " + std::to_string(params.bits) + " must be 30 or 63");
  if (params.top_down.arity != 2)
    throw Error(name + ": arity = " + std::to_string(params.top_down.arity) +
                " (the builder writes binary trees)");
  check_config(params.top_down, kName);
}

Bvh build_ploc(const BuildInput& input, const PlocParams& params) {
  check_ploc_params(params);
  check_prim_count(input.size(), kName);
  const auto n = static_cast<uint32_t>(input.size());
  if (n == 0) return Bvh{};
  const HugePageArray<uint32_t> order = params.bits == 30 ? sort_by_morton<uint32_t>(input.bounds.span()).ids
                                                          : sort_by_morton<uint64_t>(input.bounds.span()).ids;
  HugePageArray<ClusterNode> nodes(n - 1);
  HugePageArray<SubtreeCost> costs(n - 1);
  const HugePageArray<Aabb> leaf_bounds = bounds_in_order(input.bounds.span(), order.span());
  ClusterTree tree{nodes.span(), costs.span(), order.span(), leaf_bounds.span(), leaf_tag(0)};
  const LeafCollapse rule(params.top_down);
  if (n > 1) tree.root = Clustering(tree, rule, params.radius).run();
  return finish_cluster_tree(tree, rule);
}

}  // namespace sahbench
