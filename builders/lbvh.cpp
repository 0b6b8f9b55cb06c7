#include "builders/lbvh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "builders/leaf_collapse.h"
#include "builders/morton.h"
#include "core/error.h"

namespace sahbench {
namespace {

constexpr const char* kName = "lbvh";
// Nodes or primitives per task in the parallel loops (the results do not depend on it).
constexpr std::size_t kGrain = 1u << 12;

// The binary radix tree over sorted Morton codes, Karras 2012, section 4 and Figure 4: inner node i
// covers a range of positions with one end at i, and splits it where the common prefix of its keys
// grows. A key is the code followed by the position, so equal codes compare by position.
template <class Code>
class RadixTree {
 public:
  RadixTree(const HugePageArray<Code>& codes)
      : codes_(codes.data()), n_(static_cast<int64_t>(codes.size())) {}

  // Length of the common prefix of the keys at positions i and j, or -1 when j is outside the array.
  // Written as a select: whether codes are equal is as unpredictable as the searches' branches.
  int delta(int64_t i, int64_t j) const {
    if (j < 0 || j >= n_) return -1;
    const Code x = codes_[i] ^ codes_[j];
    const int by_code = std::countl_zero(x);
    const int by_position = int(8 * sizeof(Code)) + std::countl_zero(static_cast<uint32_t>(i ^ j));
    return x != 0 ? by_code : by_position;
  }

  // The children of inner node i, as tags (leaf positions or inner nodes).
  void children(int64_t i, uint32_t child[2]) const {
    // The range's direction: towards the neighbour with the longer common prefix; the other neighbour's
    // prefix is the one the range's keys all exceed.
    const int next = delta(i, i + 1), previous = delta(i, i - 1);
    const int64_t d = next > previous ? 1 : -1;
    const int delta_min = std::min(next, previous);
    // Its other end: an upper bound by doubling, then a binary search.
    int64_t l_max = 2;
    while (delta(i, i + l_max * d) > delta_min) l_max *= 2;
    int64_t l = 0;
    for (int64_t t = l_max / 2; t >= 1; t /= 2) l += delta(i, i + (l + t) * d) > delta_min ? t : 0;
    const int64_t j = i + l * d;
    // The split: the last position whose key shares more than the range's common prefix with i's.
    const int delta_node = delta(i, j);
    int64_t s = 0;
    for (int64_t t = l; t > 1;) {
      t = (t + 1) / 2;
      s += delta(i, i + (s + t) * d) > delta_node ? t : 0;
    }
    const int64_t gamma = i + s * d + std::min<int64_t>(d, 0);
    const auto g = static_cast<uint32_t>(gamma);
    child[0] = std::min(i, j) == gamma ? leaf_tag(g) : g;
    child[1] = std::max(i, j) == gamma + 1 ? leaf_tag(g + 1) : g + 1;
  }

  // The positions [first, last] under the node that splits between positions k and k + 1 (Apetrei's
  // numbering): those whose keys share with key k at least the prefix that keys k and k + 1 share, found
  // each way by doubling and then halving the step, as children() finds a range's other end.
  std::pair<int64_t, int64_t> range_of(int64_t k) const {
    const int prefix = delta(k, k + 1);
    auto furthest = [&](int64_t from, int64_t direction) {
      int64_t step = 1;
      while (delta(k, from + step * direction) >= prefix) step *= 2;
      int64_t l = 0;
      for (int64_t t = step / 2; t >= 1; t /= 2) l += delta(k, from + (l + t) * direction) >= prefix ? t : 0;
      return from + l * direction;
    };
    return {furthest(k, -1), furthest(k + 1, 1)};
  }

 private:
  const Code* codes_;
  int64_t n_;
};

// Karras's way: the children of every inner node found in parallel, one task per node (section 4), then
// boxes and costs bottom-up: from every leaf towards the root, where the first of a node's two children
// to arrive stops and the second goes on, so each node is computed once, after both its children. The
// counter's acquire-release orders the first child's writes before the second's reads, and a node's
// values depend only on its children's: the same for any thread count. Returns the root's tag.
template <class Code>
uint32_t karras_pass(const ClusterTree& tree, const RadixTree<Code>& radix, const LeafCollapse& rule) {
  const auto n = static_cast<uint32_t>(tree.order.size());
  HugePageArray<uint32_t> parent(n - 1), leaf_parent(n);
  HugePageArray<uint8_t> arrivals(n - 1);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n - 1, kGrain), [&](const auto& r) {
    for (uint32_t i = r.begin(); i != r.end(); ++i) {
      uint32_t* child = tree.nodes[i].child;
      radix.children(i, child);
      for (int c = 0; c < 2; ++c)
        (is_leaf_tag(child[c]) ? leaf_parent[tag_index(child[c])] : parent[child[c]]) = i;
      arrivals[i] = 0;
    }
  });
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, kGrain), [&](const auto& r) {
    for (uint32_t leaf = r.begin(); leaf != r.end(); ++leaf) {
      uint32_t p = leaf_parent[leaf];
      while (std::atomic_ref<uint8_t>(arrivals[p]).fetch_add(1, std::memory_order_acq_rel) != 0) {
        ClusterNode& node = tree.nodes[p];
        node.bounds = merge(tag_bounds(tree, node.child[0]), tag_bounds(tree, node.child[1]));
        tree.costs[p] = rule.combine(node.bounds, rule.of(tree, node.child[0]), rule.of(tree, node.child[1]));
        if (p == 0) break;
        p = parent[p];
      }
    }
  });
  return 0;  // Karras's root is inner node 0
}

// Apetrei's way ("Fast and Simple Agglomerative LBVH Construction", 2014): the same radix tree, found
// bottom-up in one pass with its boxes and costs. Inner node k splits between positions k and k + 1; a
// node over positions [a, b] is the left child of split b where delta(b, b + 1) exceeds
// delta(a - 1, a), and the right child of split a - 1 otherwise (the parent is the neighbouring split
// whose keys share more). From every leaf towards the root, the first of a node's two children to arrive
// leaves its end of the range in the node's slot and stops; the second takes it and goes on with the
// whole range. No searches and no parent links; the tree and the order of children are Karras's, so the
// output is the same, node for node. Returns the root's tag.
//
// The leaves are walked in fixed chunks, each by one task, left to right. A node whose positions all lie
// in one chunk is then reached by its left child first and by its right child last, both from the same
// task, so its slot needs no atomic exchange: the left child writes, the right one reads. Only the nodes
// over a chunk boundary (the boundary's split node and its ancestors, marked first) can be reached from
// two tasks in either order, and take the exchange. A locked exchange waits for every store before it,
// and on a 110k-triangle scene it was a third of the pass.
template <class Code>
uint32_t apetrei_pass(const ClusterTree& tree, const RadixTree<Code>& radix, const LeafCollapse& rule) {
  const auto n = static_cast<uint32_t>(tree.order.size());
  // Slots of the nodes over a boundary hold kShared until the first child arrives, and its end with
  // kShared's top bit after (positions are below 2^31); the others are 0 until their left child writes.
  constexpr uint32_t kShared = ~0u, kSharedBit = 1u << 31;
  constexpr uint32_t kChunk = 1u << 12;
  const uint32_t chunks = (n + kChunk - 1) / kChunk;
  HugePageArray<uint32_t> other_end(n - 1);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n - 1, kGrain), [&](const auto& r) {
    for (uint32_t k = r.begin(); k != r.end(); ++k) other_end[k] = 0;
  });
  // delta between positions k and k + 1; -1 beyond either end.
  auto split_delta = [&](int64_t k) { return k < 0 || k + 1 >= n ? -1 : radix.delta(k, k + 1); };
  // The parent of the node over [a, b], as above.
  auto parent_of = [&](int64_t a, int64_t b) { return split_delta(b) > split_delta(a - 1) ? b : a - 1; };
  for (uint32_t c = 1; c < chunks; ++c) {
    for (int64_t k = int64_t{c} * kChunk - 1; other_end[k] != kShared;) {
      other_end[k] = kShared;
      const auto [a, b] = radix.range_of(k);
      if (a == 0 && b == n - 1) break;
      k = parent_of(a, b);
    }
  }
  std::atomic<uint32_t> root{0};
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, chunks, 1), [&](const auto& r) {
    for (uint32_t chunk = r.begin(); chunk != r.end(); ++chunk) {
      const uint32_t last = std::min(n, (chunk + 1) * kChunk);
      for (uint32_t leaf = chunk * kChunk; leaf != last; ++leaf) {
        uint32_t tag = leaf_tag(leaf), a = leaf, b = leaf;
        // The prefix lengths at the range's two ends; a step moves one end, so one is kept.
        int before_a = split_delta(int64_t{a} - 1), after_b = split_delta(b);
        for (;;) {
          const bool left = after_b > before_a;
          const uint32_t p = left ? b : a - 1;
          tree.nodes[p].child[left ? 0 : 1] = tag;
          std::atomic_ref<uint32_t> slot(other_end[p]);
          uint32_t end;
          if (slot.load(std::memory_order_relaxed) & kSharedBit) {
            end = slot.exchange((left ? a : b) | kSharedBit, std::memory_order_acq_rel);
            if (end == kShared) break;
            end &= ~kSharedBit;
          } else if (left) {
            slot.store(a, std::memory_order_relaxed);
            break;
          } else {
            end = slot.load(std::memory_order_relaxed);
          }
          if (left) {
            b = end;
            after_b = split_delta(b);
          } else {
            a = end;
            before_a = split_delta(int64_t{a} - 1);
          }
          ClusterNode& node = tree.nodes[p];
          node.bounds = merge(tag_bounds(tree, node.child[0]), tag_bounds(tree, node.child[1]));
          tree.costs[p] =
              rule.combine(node.bounds, rule.of(tree, node.child[0]), rule.of(tree, node.child[1]));
          tag = p;
          if (a == 0 && b == n - 1) {
            root.store(p, std::memory_order_relaxed);
            break;
          }
        }
      }
    }
  });
  return root.load();
}

template <class Code>
Bvh build(const BuildInput& input, const LbvhParams& params) {
  const auto n = static_cast<uint32_t>(input.size());
  const MortonOrder<Code> sorted = sort_by_morton<Code>(input.bounds.span());
  const LeafCollapse rule(params.top_down);
  HugePageArray<ClusterNode> nodes(n - 1);
  HugePageArray<SubtreeCost> costs(n - 1);
  const HugePageArray<Aabb> leaf_bounds = bounds_in_order(input.bounds.span(), sorted.ids.span());
  ClusterTree tree{nodes.span(), costs.span(), sorted.ids.span(), leaf_bounds.span(), leaf_tag(0), true};
  if (n > 1) {
    const RadixTree<Code> radix(sorted.codes);
    tree.root = params.hierarchy == LbvhHierarchy::kApetrei ? apetrei_pass(tree, radix, rule)
                                                            : karras_pass(tree, radix, rule);
  }
  return finish_cluster_tree(tree, rule);
}

}  // namespace

void check_lbvh_params(const LbvhParams& params) {
  if (params.bits != 30 && params.bits != 63)
    throw Error(std::string(kName) + ": bits = " + std::to_string(params.bits) + " must be 30 or 63");
  if (params.top_down.arity != 2)
    throw Error(std::string(kName) + ": arity = " + std::to_string(params.top_down.arity) +
                " (the builder writes binary trees)");
  check_config(params.top_down, kName);
}

Bvh build_lbvh(const BuildInput& input, const LbvhParams& params) {
  check_lbvh_params(params);
  check_prim_count(input.size(), kName);
  if (input.size() == 0) return Bvh{};
  return params.bits == 30 ? build<uint32_t>(input, params) : build<uint64_t>(input, params);
}

}  // namespace sahbench
