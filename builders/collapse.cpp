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

namespace sahbench {
namespace {

// Parallel tasks per thread in collapse_sah's bottom-up pass, as in builders/refit.cpp.
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
  explicit WideWriter(const Bvh& in, uint32_t arity) : in_(in) {
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
      for (uint32_t c = static_cast<uint32_t>(slots.size()); c-- > 0;) stack.emplace_back(slots[c], first_child + c);
    }
    return std::move(out_);
  }

 private:
  // Every reference under input node n, leaves in depth-first order.
  void append_refs(uint32_t n) {
    std::vector<uint32_t> stack{n};
    while (!stack.empty()) {
      const Node& node = in_.nodes[stack.back()];
      stack.pop_back();
      if (node.is_leaf()) {
        out_.prim_refs.insert(out_.prim_refs.end(), in_.prim_refs.begin() + node.first,
                              in_.prim_refs.begin() + node.first + node.prim_count);
        continue;
      }
      for (uint32_t c = node.child_count; c-- > 0;) stack.push_back(node.first + c);
    }
  }

  const Bvh& in_;
  Bvh out_;
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
  if (bvh.arity != 2) throw Error("collapse_sah: needs a binary tree, got arity " + std::to_string(bvh.arity));
  const std::size_t n_nodes = bvh.nodes.size();
  if (n_nodes == 0) return Bvh{{}, {}, arity};

  // cost_[n * arity + i - 1]: the least cost of subtree n as at most i subtrees ("C(n, i)" in Ylitie et
  // al.), in area-weighted units (divided by the root's area only in the statistics). Double, since a
  // million-node sum in float would round differently along different paths.
  std::vector<double> best(n_nodes * arity);
  // choice_[n * arity + i - 1]: for i = 1, kAsLeaf or kAsNode; for i >= 2, 0 when i - 1 subtrees are
  // as cheap (kFewer), else the k of the best split (k subtrees from the left child, i - k from the right).
  constexpr uint8_t kAsLeaf = 0, kAsNode = 1, kFewer = 0;
  std::vector<uint8_t> choice(n_nodes * arity);
  std::vector<uint32_t> refs(n_nodes);

  constexpr double kInf = std::numeric_limits<double>::infinity();
  // C(n, i) and the choices for node n, from its children's.
  auto solve_node = [&](uint32_t n) {
    const Node& node = bvh.nodes[n];
    const double area = node.bounds.half_area();
    double* c = &best[std::size_t{n} * arity];
    uint8_t* ch = &choice[std::size_t{n} * arity];
    if (node.is_leaf()) {
      // An input leaf stays one leaf, whatever its size.
      refs[n] = node.prim_count;
      std::fill(c, c + arity, cost.leaf_cost(node.prim_count) * area);
      std::fill(ch, ch + arity, kAsLeaf);
      return;
    }
    const uint32_t l = node.first, r = node.first + 1;
    refs[n] = refs[l] + refs[r];
    const double* cl = &best[std::size_t{l} * arity];
    const double* cr = &best[std::size_t{r} * arity];
    // distribute[j]: the least cost of the two children as at most j subtrees together.
    std::array<double, 9> distribute;
    std::array<uint8_t, 9> split_at{};
    for (uint32_t j = 2; j <= arity; ++j) {
      distribute[j] = kInf;
      for (uint32_t k = 1; k < j; ++k) {
        const double v = cl[k - 1] + cr[j - k - 1];
        if (v < distribute[j]) distribute[j] = v, split_at[j] = static_cast<uint8_t>(k);
      }
    }
    const double as_leaf = refs[n] <= max_leaf ? cost.leaf_cost(refs[n]) * area : kInf;
    const double as_node = cost.c_trav * area + distribute[arity];
    c[0] = as_leaf <= as_node ? as_leaf : as_node;
    ch[0] = as_leaf <= as_node ? kAsLeaf : kAsNode;
    for (uint32_t i = 2; i <= arity; ++i) {
      // Ties prefer fewer subtrees: fewer, larger nodes cost the same and keep the tree shallow.
      if (c[i - 2] <= distribute[i]) {
        c[i - 1] = c[i - 2];
        ch[i - 1] = kFewer;
      } else {
        c[i - 1] = distribute[i];
        ch[i - 1] = split_at[i];
      }
    }
  };
  // Subtree `root` children first, on this thread: its nodes in depth-first preorder, walked backwards.
  auto solve_serial = [&](uint32_t root) {
    std::vector<uint32_t> order;
    for (std::vector<uint32_t> stack{root}; !stack.empty();) {
      const uint32_t n = stack.back();
      stack.pop_back();
      order.push_back(n);
      const Node& node = bvh.nodes[n];
      for (uint32_t c = 0; c < node.child_count; ++c) stack.push_back(node.first + c);
    }
    for (auto it = order.rbegin(); it != order.rend(); ++it) solve_node(*it);
  };
  // The top levels in parallel, each node's two subtrees as two tasks, down to the depth where a
  // balanced tree has kTasksPerThread subtrees per thread (as refit() spawns); none with one thread. Every
  // node's values depend on its subtree alone, so the result is the serial one. Serial, this pass held
  // wide_collapse's 1M-terrain build at 2 threads at 1.08-1.27x Embree medium's time (1.05x in parallel).
  const int threads = tbb::this_task_arena::max_concurrency();
  const uint32_t spawn_depth =
      threads > 1 ? static_cast<uint32_t>(std::ceil(std::log2(double(threads) * kTasksPerThread))) : 0;
  auto solve = [&](auto&& self, uint32_t n, uint32_t depth) -> void {
    const Node& node = bvh.nodes[n];
    if (depth >= spawn_depth || node.is_leaf()) return solve_serial(n);
    tbb::parallel_invoke([&] { self(self, node.first, depth + 1); },
                         [&] { self(self, node.first + 1, depth + 1); });
    solve_node(n);
  };
  solve(solve, 0, 0);

  // Reconstruction: the slots of an inner node n are its two children's best split into `arity`.
  auto take = [&](auto&& self, uint32_t n, uint32_t i, std::vector<uint32_t>& slots) -> void {
    const Node& node = bvh.nodes[n];
    while (i > 1 && !node.is_leaf() && choice[std::size_t{n} * arity + i - 1] == kFewer) --i;
    if (i == 1 || node.is_leaf()) {
      slots.push_back(n);
      return;
    }
    const uint32_t k = choice[std::size_t{n} * arity + i - 1];
    self(self, node.first, k, slots);
    self(self, node.first + 1, i - k, slots);
  };
  auto slots_of = [&](uint32_t n, std::vector<uint32_t>& slots) {
    const Node& node = bvh.nodes[n];
    // As an inner node, n's children are split into `arity` slots by the best k recorded for it.
    double best_v = kInf;
    uint32_t best_k = 1;
    const double* cl = &best[std::size_t{node.first} * arity];
    const double* cr = &best[std::size_t{node.first + 1} * arity];
    for (uint32_t k = 1; k < arity; ++k) {
      const double v = cl[k - 1] + cr[arity - k - 1];
      if (v < best_v) best_v = v, best_k = k;
    }
    take(take, node.first, best_k, slots);
    take(take, node.first + 1, arity - best_k, slots);
  };
  auto is_leaf = [&](uint32_t n) { return bvh.nodes[n].is_leaf() || choice[std::size_t{n} * arity] == kAsLeaf; };
  return WideWriter(bvh, arity).write(slots_of, is_leaf);
}

}  // namespace sahbench
