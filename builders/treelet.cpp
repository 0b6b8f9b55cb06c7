#include "builders/treelet.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <bit>
#include <limits>
#include <string>
#include <vector>

#include "builders/linked_tree.h"
#include "core/bvh_stats.h"
#include "core/error.h"

namespace sahbench {
namespace {

// A treelet is replaced only where its new inner area is below the old by this fraction, and an
// iteration counts as a gain only where the tree's is: below it, differences are rounding noise of
// double sums taken in different orders.
constexpr double kMinRelativeGain = 1e-9;

// Parallel tasks per thread at the top of the tree, as in core/refit.cpp: enough that a lopsided tree still
// spreads over the threads. Which subtrees run as tasks does not change the result.
constexpr int kTasksPerThread = 16;

// One task's tables, indexed by subsets (bit masks) of the treelet's leaves.
struct Tables {
  std::vector<Aabb> box;
  std::vector<double> area, cost;
  std::vector<uint32_t> split;  // the subset of the cheapest partition's first part
  explicit Tables(uint32_t leaves)
      : box(std::size_t{1} << leaves), area(box.size()), cost(box.size()), split(box.size()) {}
};

class Restructurer {
 public:
  Restructurer(LinkedTree& tree, const TreeletParams& params)
      : tree_(tree), params_(params), tables_([size = params.treelet_size] { return Tables(size); }) {}

  // One bottom-up pass over the tree: each inner node's treelet after both of its children's, so a
  // treelet is formed from subtrees already final in this pass. Subtrees are disjoint, so their tasks
  // touch different nodes, and the order among them does not change the result.
  void pass() {
    const int tasks = tbb::this_task_arena::max_concurrency() * kTasksPerThread;
    spawn_depth_ = static_cast<uint32_t>(std::bit_width(static_cast<unsigned>(tasks)));
    visit(tree_.root, 0);
  }

 private:
  void visit(uint32_t n, uint32_t depth) {
    const LinkedNode& node = tree_.nodes[n];
    if (node.is_leaf()) return;
    // A treelet's root keeps its index, so the children read here are the ones the visits below keep.
    const uint32_t a = node.child[0], b = node.child[1];
    if (depth < spawn_depth_)
      tbb::parallel_invoke([&] { visit(a, depth + 1); }, [&] { visit(b, depth + 1); });
    else {
      visit(a, depth + 1);
      visit(b, depth + 1);
    }
    restructure(n);
  }

  // Karras and Aila's treelet of `root`: open the leaf of largest area until treelet_size leaves, then
  // give the leaves the topology of least inner area.
  void restructure(uint32_t root) {
    auto& nodes = tree_.nodes;
    uint32_t leaves[kMaxTreeletSize], inner[kMaxTreeletSize];
    uint32_t n = 2, m = 1;
    leaves[0] = nodes[root].child[0];
    leaves[1] = nodes[root].child[1];
    inner[0] = root;
    while (n < params_.treelet_size) {
      int largest = -1;
      double largest_area = -1.0;
      for (uint32_t i = 0; i < n; ++i) {
        if (nodes[leaves[i]].is_leaf()) continue;
        const double a = area_in_double(nodes[leaves[i]].bounds);
        if (a > largest_area) largest = static_cast<int>(i), largest_area = a;
      }
      if (largest < 0) break;
      const uint32_t opened = leaves[largest];
      inner[m++] = opened;
      leaves[largest] = nodes[opened].child[0];
      leaves[n++] = nodes[opened].child[1];
    }
    if (n < 3) return;  // two leaves have one topology

    Tables& t = tables_.local();
    const uint32_t full = (1u << n) - 1;
    for (uint32_t mask = 1; mask <= full; ++mask) {
      const uint32_t low = mask & (~mask + 1);
      if (mask == low) {
        t.box[mask] = nodes[leaves[std::countr_zero(mask)]].bounds;
        t.cost[mask] = 0.0;
        continue;
      }
      t.box[mask] = merge(t.box[low], t.box[mask ^ low]);
      t.area[mask] = area_in_double(t.box[mask]);
    }
    // Subsets in increasing order come after all of their own subsets. Each partition is tried once,
    // with the lowest leaf in its first part.
    for (uint32_t mask = 1; mask <= full; ++mask) {
      const uint32_t low = mask & (~mask + 1);
      if (mask == low) continue;
      const uint32_t rest = mask ^ low;
      double best = std::numeric_limits<double>::infinity();
      uint32_t best_split = low;
      for (uint32_t sub = rest & (rest - 1);; sub = (sub - 1) & rest) {
        const uint32_t part = sub | low;
        const double c = t.cost[part] + t.cost[mask ^ part];
        if (c < best) best = c, best_split = part;
        if (sub == 0) break;
      }
      t.cost[mask] = t.area[mask] + best;
      t.split[mask] = best_split;
    }

    double current = 0.0;
    for (uint32_t i = 0; i < m; ++i) current += area_in_double(nodes[inner[i]].bounds);
    if (!(t.cost[full] < current * (1.0 - kMinRelativeGain))) return;

    // The inner nodes keep their indices (the root's parent still points at it) in new places.
    std::pair<uint32_t, uint32_t> stack[kMaxTreeletSize];  // (subset, inner node index)
    uint32_t top = 0, next = 1;
    stack[top++] = {full, root};
    while (top > 0) {
      const auto [mask, id] = stack[--top];
      nodes[id].bounds = t.box[mask];
      const uint32_t parts[2] = {t.split[mask], mask ^ t.split[mask]};
      for (uint32_t c = 0; c < 2; ++c) {
        uint32_t child;
        if (std::has_single_bit(parts[c])) {
          child = leaves[std::countr_zero(parts[c])];
        } else {
          child = inner[next++];
          stack[top++] = {parts[c], child};
        }
        nodes[id].child[c] = child;
        nodes[child].parent = id;
      }
    }
  }

  LinkedTree& tree_;
  const TreeletParams& params_;
  uint32_t spawn_depth_ = 0;
  tbb::enumerable_thread_specific<Tables> tables_;
};

}  // namespace

Bvh restructure_treelets(const Bvh& source, const TreeletParams& params) {
  if (params.treelet_size < kMinTreeletSize || params.treelet_size > kMaxTreeletSize)
    throw Error("treelet: treelet_size = " + std::to_string(params.treelet_size) + " is outside [" +
                std::to_string(kMinTreeletSize) + ", " + std::to_string(kMaxTreeletSize) + "]");
  LinkedTree tree(source, "treelet");
  if (tree.nodes.size() < 5 || params.iterations == 0) return source;  // fewer than 3 leaves
  Restructurer restructurer(tree, params);
  std::vector<LinkedNode> best = tree.nodes;
  double best_area = tree.refit().inner_area;
  for (uint32_t it = 0; it < params.iterations; ++it) {
    restructurer.pass();
    // The pass leaves every box exact; the refit sums the areas and finds the height.
    const LinkedTree::Summary after = tree.refit();
    if (!(after.inner_area < best_area * (1.0 - kMinRelativeGain)) || after.height > kMaxDepth) {
      tree.nodes = best;
      break;
    }
    best = tree.nodes;
    best_area = after.inner_area;
  }
  Bvh out = tree.to_bvh();
  // As in reinsert(): the statistics' sum, taken in another order, has the last word.
  if (!(sah_cost(out, params.cost) < sah_cost(source, params.cost))) return source;
  return out;
}

}  // namespace sahbench
