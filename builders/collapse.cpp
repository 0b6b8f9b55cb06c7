#include "builders/collapse.h"

#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "builders/top_down.h"
#include "core/error.h"
#include "core/huge_pages.h"

namespace sahbench {
namespace {

// Parallel tasks per thread in collapse_sah's bottom-up pass, as in core/refit.cpp.
constexpr int kTasksPerThread = 16;

void check_arity(const Bvh& bvh, uint32_t arity, const char* pass) {
  if (arity != 2 && arity != 4 && arity != 8)
    throw Error(std::string(pass) + ": arity " + std::to_string(arity) + " must be 2, 4 or 8");
  if (bvh.arity > arity)
    throw Error(std::string(pass) + ": the input tree has arity " + std::to_string(bvh.arity) +
                ", wider than the requested " + std::to_string(arity));
}

// Writes output nodes depth first. A wide node's slots are input nodes; each slot becomes either a
// leaf holding every reference under it, or an inner node whose own slots `slots_of` chooses.
class WideWriter {
 public:
  // `distinct`: a leaf that merges input leaves keeps each reference once (a spatial-split source
  // repeats a triangle in the leaves of neighbouring nodes).
  explicit WideWriter(const Bvh& in, uint32_t arity, bool distinct = false) : in_(in), distinct_(distinct) {
    out_.arity = arity;
    out_.nodes.reserve(in.nodes.size());
    out_.prim_refs.reserve(in.prim_refs.size());
  }

  // `slots_of(n, slots)` fills the slots of input node n as an inner node; `is_leaf(n)` says whether
  // input node n becomes a leaf.
  template <class SlotsOf, class IsLeaf>
  Bvh write(SlotsOf slots_of, IsLeaf is_leaf) {
    if (in_.nodes.empty()) return std::move(out_);
    out_.nodes.push_back({in_.nodes[0].bounds, 0, 0, 0});
    // (input node, output index) pairs still to fill; right-most pushed first, so the first child's
    // subtree is laid out right after its siblings.
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};
    std::vector<uint32_t> slots;
    while (!stack.empty()) {
      const auto [n, index] = stack.back();
      stack.pop_back();
      if (is_leaf(n)) {
        const uint32_t first = static_cast<uint32_t>(out_.prim_refs.size());
        append_refs(n);
        if (distinct_ && !in_.nodes[n].is_leaf()) keep_first_of_each(first);
        const uint32_t count = static_cast<uint32_t>(out_.prim_refs.size()) - first;
        if (count > kMaxLeafPrims)
          throw Error("collapse: a merged leaf of " + std::to_string(count) + " references exceeds " +
                      std::to_string(kMaxLeafPrims));
        out_.nodes[index].first = first;
        out_.nodes[index].prim_count = static_cast<uint16_t>(count);
        continue;
      }
      slots.clear();
      slots_of(n, slots);
      const uint32_t first_child = static_cast<uint32_t>(out_.nodes.size());
      out_.nodes[index].first = first_child;
      out_.nodes[index].child_count = static_cast<uint16_t>(slots.size());
      for (uint32_t s : slots) out_.nodes.push_back({in_.nodes[s].bounds, 0, 0, 0});
      for (uint32_t c = static_cast<uint32_t>(slots.size()); c-- > 0;)
        stack.emplace_back(slots[c], first_child + c);
    }
    return std::move(out_);
  }

 private:
  // Every reference under input node n, leaves in depth-first order. The depth is at most kMaxDepth,
  // which every builder guarantees.
  void append_refs(uint32_t n) {
    const Node& node = in_.nodes[n];
    if (node.is_leaf()) {
      out_.prim_refs.insert(out_.prim_refs.end(), in_.prim_refs.begin() + node.first,
                            in_.prim_refs.begin() + node.first + node.prim_count);
      return;
    }
    for (uint32_t c = 0; c < node.child_count; ++c) append_refs(node.first + c);
  }

  // Drops the references from `first` on that repeat an earlier one of them. A merged leaf holds at
  // most max_leaf references, usually a few: those keep their depth-first order by a quadratic scan;
  // a large one is sorted instead.
  void keep_first_of_each(uint32_t first) {
    constexpr std::size_t kScanned = 32;
    auto begin = out_.prim_refs.begin() + first;
    auto kept = begin;
    if (out_.prim_refs.size() - first > kScanned) {
      std::sort(begin, out_.prim_refs.end());
      kept = std::unique(begin, out_.prim_refs.end());
    } else {
      for (auto it = begin; it != out_.prim_refs.end(); ++it)
        if (std::find(begin, kept, *it) == kept) *kept++ = *it;
    }
    out_.prim_refs.erase(kept, out_.prim_refs.end());
  }

  const Bvh& in_;
  bool distinct_;
  Bvh out_;
};

// Whether some scene index appears more than once among the tree's references (spatial splits,
// presplitting): then a leaf merged from several input leaves may hold a triangle twice.
bool repeats_references(const Bvh& bvh) {
  if (bvh.prim_refs.empty()) return false;
  const uint32_t top = *std::max_element(bvh.prim_refs.begin(), bvh.prim_refs.end());
  // More references than indices up to the largest: some index repeats, without a scan.
  if (bvh.prim_refs.size() > std::size_t{top} + 1) return true;
  std::vector<uint8_t> seen(std::size_t{top} + 1);
  for (uint32_t r : bvh.prim_refs) {
    if (seen[r]) return true;
    seen[r] = 1;
  }
  return false;
}

// The SAH-optimal collapse for a fixed arity (a template parameter, so that the loops over subtree
// counts unroll). kDistinct: the input repeats a reference, so merged leaves count and keep each once;
// without repeats the subtrees carry no sets (a parameter, so that the common case copies no more than
// its costs up the recursion). C(n, i), the least cost of binary subtree n as at most i subtrees (Ylitie et
// al.), is computed bottom-up in area-weighted units (divided by the root's area only in the statistics), in
// double, since a million-node sum in float would round differently along different paths.
//
// Each node's costs are returned to its parent rather than stored: a node's C(., i) is read only by its
// parent, and the recursion holds at most two per level. Only the choices that reach them are kept,
// one byte per node and subtree count, for the reconstruction. (A table of every node's costs had been
// 25-33 MB on the 1M-triangle terrain, written once and read once, and its first touch alone cost
// more than the arithmetic.)
template <uint32_t kArity, bool kDistinct>
class SahCollapse {
 public:
  SahCollapse(const Bvh& bvh, const SahCost& cost, uint32_t max_leaf)
      : bvh_(bvh), cost_(cost), max_leaf_(max_leaf), choice_(bvh.nodes.size() * kArity) {
    // The top levels in parallel, each node's two subtrees as two tasks, down to the depth where a
    // balanced tree has kTasksPerThread subtrees per thread (as refit() spawns); none with one thread.
    // Every node's values depend on its subtree alone, so the result is the serial one. Serial, this
    // pass held wide_collapse's 1M-terrain build at 2 threads at 1.08-1.27x Embree medium's time (1.05x
    // in parallel).
    const int threads = tbb::this_task_arena::max_concurrency();
    spawn_depth_ =
        threads > 1 ? static_cast<uint32_t>(std::ceil(std::log2(double(threads) * kTasksPerThread))) : 0;
  }

  Bvh run() {
    solve(0, 0);
    auto slots_of = [&](uint32_t n, std::vector<uint32_t>& slots) {
      // As an inner node, n's children are split into kArity slots at the k recorded for it.
      const uint32_t k = choice(n, 1);
      const Node& node = bvh_.nodes[n];
      take(node.first, k, slots);
      take(node.first + 1, kArity - k, slots);
    };
    auto is_leaf = [&](uint32_t n) { return bvh_.nodes[n].is_leaf() || choice(n, 1) == kAsLeaf; };
    return WideWriter(bvh_, kArity, kDistinct).write(slots_of, is_leaf);
  }

 private:
  // choice(n, 1): kAsLeaf, or the k of the best split of n's children into kArity subtrees as an inner
  // node (k subtrees from the left child, kArity - k from the right). choice(n, i) for i >= 2: kFewer
  // when i - 1 subtrees are as cheap, else the k of the best split into i. An input leaf has kAsLeaf
  // (= kFewer) everywhere.
  static constexpr uint8_t kAsLeaf = 0, kFewer = 0;
  static constexpr double kInf = std::numeric_limits<double>::infinity();

  // Most distinct references a subtree's set carries; beyond it a merged leaf is costed by its
  // references with repeats (an upper bound), which only max_leaf above it can reach.
  static constexpr uint32_t kSetCap = 16;

  struct Subtree {
    std::array<double, kArity> cost;  // cost[i - 1] = C(n, i)
    uint32_t refs;                    // references a leaf merging n would hold
    // kDistinct: n's distinct references, sorted, while there are at most kSetCap of them
    // (set_size > kSetCap once there are more); for an inner node refs is then set_size.
    uint32_t set_size = kSetCap + 1;
    std::array<uint32_t, kDistinct ? kSetCap : 0> set;
  };

  uint8_t& choice(uint32_t n, uint32_t i) { return choice_[std::size_t{n} * kArity + i - 1]; }

  // Post-order: the depth is at most kMaxDepth, which every builder guarantees.
  Subtree solve(uint32_t n, uint32_t depth) {
    const Node node = bvh_.nodes[n];
    if (node.is_leaf()) {
      // An input leaf stays one leaf, whatever its size.
      std::fill_n(&choice(n, 1), kArity, kAsLeaf);
      Subtree s;
      s.cost.fill(cost_.leaf_cost(node.prim_count) * double(node.bounds.half_area()));
      s.refs = node.prim_count;
      if constexpr (kDistinct) {
        if (node.prim_count > kSetCap) return s;
        const auto refs = bvh_.prim_refs.begin() + node.first;
        std::copy(refs, refs + node.prim_count, s.set.begin());
        std::sort(s.set.begin(), s.set.begin() + node.prim_count);
        s.set_size = static_cast<uint32_t>(std::unique(s.set.begin(), s.set.begin() + node.prim_count) -
                                           s.set.begin());
      }
      return s;
    }
    Subtree l, r;
    if (depth < spawn_depth_) {
      tbb::parallel_invoke([&] { l = solve(node.first, depth + 1); },
                           [&] { r = solve(node.first + 1, depth + 1); });
    } else {
      l = solve(node.first, depth + 1);
      r = solve(node.first + 1, depth + 1);
    }
    return combine(n, node, l, r);
  }

  Subtree combine(uint32_t n, const Node& node, const Subtree& l, const Subtree& r) {
    // distribute[j]: the least cost of the two children as at most j subtrees together, at the first
    // least k. Selects, not branches: which k wins is unpredictable.
    std::array<double, kArity + 1> distribute;
    std::array<uint8_t, kArity + 1> split_at;
    for (uint32_t j = 2; j <= kArity; ++j) {
      double least = kInf;
      uint8_t at = 0;
      for (uint32_t k = 1; k < j; ++k) {
        const double v = l.cost[k - 1] + r.cost[j - k - 1];
        const bool lower = v < least;
        least = lower ? v : least;
        at = lower ? static_cast<uint8_t>(k) : at;
      }
      distribute[j] = least;
      split_at[j] = at;
    }
    const double area = node.bounds.half_area();
    Subtree s;
    s.refs = l.refs + r.refs;
    if constexpr (kDistinct) merge_sets(l, r, s);
    const double as_leaf = s.refs <= max_leaf_ ? cost_.leaf_cost(s.refs) * area : kInf;
    const double as_node = cost_.c_trav * area + distribute[kArity];
    s.cost[0] = as_leaf <= as_node ? as_leaf : as_node;
    // A split k of 0 means no candidate was finite (costs that overflowed to inf or NaN); k = 1 then, as
    // the reconstruction took before, so that the node stays an inner node and never reads as kAsLeaf.
    choice(n, 1) = as_leaf <= as_node ? kAsLeaf : std::max<uint8_t>(split_at[kArity], 1);
    for (uint32_t i = 2; i <= kArity; ++i) {
      // Ties prefer fewer subtrees: fewer, larger nodes cost the same and keep the tree shallow.
      const bool fewer = s.cost[i - 2] <= distribute[i];
      s.cost[i - 1] = fewer ? s.cost[i - 2] : distribute[i];
      choice(n, i) = fewer ? kFewer : split_at[i];
    }
    return s;
  }

  // s's set as the union of l's and r's, and s.refs as its size where it is known.
  static void merge_sets(const Subtree& l, const Subtree& r, Subtree& s) {
    if (l.set_size > kSetCap || r.set_size > kSetCap) return;
    uint32_t a = 0, b = 0, n = 0;
    while (a < l.set_size || b < r.set_size) {
      const bool take_l = b == r.set_size || (a < l.set_size && l.set[a] <= r.set[b]);
      const uint32_t id = take_l ? l.set[a] : r.set[b];
      if (take_l) {
        b += b < r.set_size && r.set[b] == id;
        ++a;
      } else {
        ++b;
      }
      if (n == kSetCap) return;  // more than kSetCap distinct: unknown, s.refs stays the sum
      s.set[n++] = id;
    }
    s.set_size = n;
    s.refs = n;
  }

  // Reconstruction: appends the slots of subtree n represented as at most i subtrees.
  void take(uint32_t n, uint32_t i, std::vector<uint32_t>& slots) {
    const Node& node = bvh_.nodes[n];
    while (i > 1 && !node.is_leaf() && choice(n, i) == kFewer) --i;
    if (i == 1 || node.is_leaf()) {
      slots.push_back(n);
      return;
    }
    const uint32_t k = choice(n, i);
    take(node.first, k, slots);
    take(node.first + 1, i - k, slots);
  }

  const Bvh& bvh_;
  const SahCost& cost_;
  uint32_t max_leaf_;
  uint32_t spawn_depth_;
  // Every entry is written by the bottom-up pass before it is read, so it starts uninitialised.
  HugePageArray<uint8_t> choice_;
};

}  // namespace

Bvh collapse_greedy(const Bvh& bvh, uint32_t arity) {
  check_arity(bvh, arity, "collapse_greedy");
  auto slots_of = [&](uint32_t n, std::vector<uint32_t>& slots) {
    const Node& node = bvh.nodes[n];
    for (uint32_t c = 0; c < node.child_count; ++c) slots.push_back(node.first + c);
    while (true) {
      // The inner slot of largest area whose children still fit.
      std::size_t best = slots.size();
      float best_area = -1.0f;
      for (std::size_t s = 0; s < slots.size(); ++s) {
        const Node& child = bvh.nodes[slots[s]];
        if (child.is_leaf() || slots.size() - 1 + child.child_count > arity) continue;
        const float area = child.bounds.half_area();
        if (area > best_area) best = s, best_area = area;
      }
      if (best == slots.size()) break;
      // Its children take its place, keeping the slots in the input's order.
      const Node& opened = bvh.nodes[slots[best]];
      slots.erase(slots.begin() + static_cast<std::ptrdiff_t>(best));
      for (uint32_t c = 0; c < opened.child_count; ++c)
        slots.insert(slots.begin() + static_cast<std::ptrdiff_t>(best + c), opened.first + c);
    }
  };
  auto is_leaf = [&](uint32_t n) { return bvh.nodes[n].is_leaf(); };
  return WideWriter(bvh, arity).write(slots_of, is_leaf);
}

Bvh collapse_sah(const Bvh& bvh, uint32_t arity, const SahCost& cost, uint32_t max_leaf) {
  check_arity(bvh, arity, "collapse_sah");
  if (bvh.arity != 2)
    throw Error("collapse_sah: needs a binary tree, got arity " + std::to_string(bvh.arity));
  if (bvh.nodes.empty()) return Bvh{{}, {}, arity};
  auto run = [&]<uint32_t kArity>() {
    return repeats_references(bvh) ? SahCollapse<kArity, true>(bvh, cost, max_leaf).run()
                                   : SahCollapse<kArity, false>(bvh, cost, max_leaf).run();
  };
  switch (arity) {
    case 2:
      return run.template operator()<2>();
    case 4:
      return run.template operator()<4>();
    default:
      return run.template operator()<8>();
  }
}

}  // namespace sahbench
