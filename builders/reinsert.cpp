#include "builders/reinsert.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <queue>
#include <string>
#include <utility>
#include <vector>

#include "builders/linked_tree.h"
#include "core/bvh_stats.h"
#include "core/error.h"

namespace sahbench {
namespace {

// A move must lower the inner area by this fraction of the tree's, and an iteration the tree's by as
// much: below it, gains are rounding noise of the double sums rather than better trees.
constexpr double kMinRelativeGain = 1e-9;

// Moving `node` to be the sibling of `target`, lowering the tree's inner area by `gain`.
struct Move {
  double gain = 0.0;
  uint32_t node = kNoNode;
  uint32_t target = kNoNode;
};

// A place still to search: the tree node, its depth once `node` is taken out, and the area its
// ancestors would grow by if `node` were inserted below them (the lower bound of Bittner et al.'s
// branch and bound).
struct Candidate {
  double induced = 0.0;
  uint32_t node = 0;
  uint32_t depth = 0;
  // Smallest induced cost first; ties by node index, so that the search is the same on every run.
  bool operator<(const Candidate& o) const {
    return induced != o.induced ? induced > o.induced : node > o.node;
  }
};

struct Scratch {
  std::vector<std::pair<uint32_t, Aabb>> path;  // ancestors of the removed parent, with their new boxes
  std::vector<Candidate> heap;
};

class Reinserter {
 public:
  Reinserter(LinkedTree& tree, const ReinsertParams& params) : tree_(tree), params_(params) {}

  void run() {
    std::vector<LinkedNode> best = tree_.nodes;
    uint32_t best_root = tree_.root;
    double best_area = tree_.refit(&levels_).inner_area;
    for (uint32_t it = 0; it < params_.iterations; ++it) {
      const std::vector<Move> moves = find_moves(best_area);
      if (moves.empty()) return;
      // Moves found against the same tree interact through the boxes of shared ancestors, so together
      // they may raise the cost; fewer, the best first, interact less, and one alone lowers it by its gain.
      bool improved = false;
      // Convergence is judged on what the search found, each move's gain against the tree as it stood,
      // not on what the round kept: a round cut short by the halving below gains little by construction.
      double found = 0.0;
      for (const Move& m : moves) found += m.gain;
      const bool last = found < best_area * params_.min_gain;
      for (std::size_t count = moves.size(); count > 0 && !improved; count /= 2) {
        apply(moves, count);
        const LinkedTree::Summary after = tree_.refit(&levels_);
        improved = after.inner_area < best_area * (1.0 - kMinRelativeGain) && after.height <= kMaxDepth;
        if (improved) {
          best = tree_.nodes;
          best_root = tree_.root;
          best_area = after.inner_area;
        } else {
          tree_.nodes = best;
          tree_.root = best_root;
          tree_.refit(&levels_);  // the levels of the tree restored
        }
      }
      if (!improved || last) return;
    }
  }

 private:
  // The best move of each of the batch's nodes, those that gain, in the order to apply them.
  std::vector<Move> find_moves(double total_area) {
    std::vector<uint32_t> order;
    order.reserve(tree_.nodes.size());
    for (uint32_t n = 0; n < tree_.nodes.size(); ++n)
      if (n != tree_.root) order.push_back(n);
    if (order.empty()) return {};
    std::vector<double> area(tree_.nodes.size());
    tbb::parallel_for(std::size_t{0}, area.size(),
                      [&](std::size_t n) { area[n] = area_in_double(tree_.nodes[n].bounds); });
    const std::size_t batch = std::clamp<std::size_t>(
        static_cast<std::size_t>(std::ceil(params_.batch * double(order.size()))), 1, order.size());
    // The largest first; ties by index, so that the batch is the same on every run.
    const auto larger = [&](uint32_t a, uint32_t b) {
      return area[a] != area[b] ? area[a] > area[b] : a < b;
    };
    std::nth_element(order.begin(), order.begin() + std::ptrdiff_t(batch - 1), order.end(), larger);
    order.resize(batch);  // the set is unique; the moves are ordered by gain below

    std::vector<Move> found(batch);
    tbb::enumerable_thread_specific<Scratch> scratch;
    tbb::parallel_for(std::size_t{0}, batch,
                      [&](std::size_t i) { found[i] = best_move(order[i], area, scratch.local()); });
    std::vector<Move> moves;
    for (const Move& m : found)
      if (m.gain > kMinRelativeGain * total_area) moves.push_back(m);
    // Largest gain first; ties by node index (unique per move).
    tbb::parallel_sort(moves.begin(), moves.end(), [](const Move& a, const Move& b) {
      return a.gain != b.gain ? a.gain > b.gain : a.node < b.node;
    });
    return moves;
  }

  // The place where `n` lowers the tree's inner area most, searched in the tree without n (its parent
  // removed and its sibling in the parent's place), by best-first branch and bound from the root.
  Move best_move(uint32_t n, const std::vector<double>& area, Scratch& s) const {
    const std::vector<LinkedNode>& nodes = tree_.nodes;
    const uint32_t parent = nodes[n].parent, sibling = tree_.sibling(n);
    const Aabb& box = nodes[n].bounds;
    const double box_area = area[n];

    // Taking n out removes its parent and shrinks the parent's ancestors to their boxes without n.
    double removed = area[parent];
    s.path.clear();
    Aabb below = nodes[sibling].bounds;
    for (uint32_t child = parent, a = nodes[parent].parent; a != kNoNode; child = a, a = nodes[a].parent) {
      const uint32_t other = nodes[a].child[0] == child ? nodes[a].child[1] : nodes[a].child[0];
      below = merge(below, nodes[other].bounds);
      removed += area[a] - area_in_double(below);
      s.path.emplace_back(a, below);
    }
    // path[i] is the ancestor at depth depth[parent] - 1 - i.
    const std::vector<uint32_t>& depth = levels_.depth;
    const uint32_t parent_depth = depth[parent];
    auto box_of = [&](uint32_t x) -> const Aabb& {
      if (depth[x] < parent_depth) {
        const auto& [on_path, shrunk] = s.path[parent_depth - 1 - depth[x]];
        if (on_path == x) return shrunk;
      }
      return nodes[x].bounds;
    };

    // Inserting n beside x costs the new parent's area plus its ancestors' growth; it gains where that
    // is below what removing n saved.
    Move best{0.0, n, kNoNode};
    double best_cost = removed;
    s.heap.clear();
    s.heap.push_back({0.0, parent == tree_.root ? sibling : tree_.root, 0});
    while (!s.heap.empty()) {
      std::pop_heap(s.heap.begin(), s.heap.end());
      const Candidate c = s.heap.back();
      s.heap.pop_back();
      if (c.induced + box_area >= best_cost) break;  // every place left costs at least this
      const Aabb& x_box = box_of(c.node);
      const double merged = area_in_double(merge(x_box, box));
      if (c.induced + merged < best_cost && c.depth + 1 + levels_.height[n] <= kMaxDepth) {
        best_cost = c.induced + merged;
        best.target = c.node;
      }
      const LinkedNode& x = nodes[c.node];
      if (x.is_leaf()) continue;
      const double induced = c.induced + merged - area_in_double(x_box);
      if (induced + box_area >= best_cost) continue;
      for (uint32_t child : x.child) {
        if (child == parent) child = sibling;  // the tree without n
        s.heap.push_back({induced, child, c.depth + 1});
        std::push_heap(s.heap.begin(), s.heap.end());
      }
    }
    if (best.target != kNoNode) best.gain = removed - best_cost;
    return best;
  }

  // Applies the first `count` moves, except those touching a node that an earlier one changed.
  void apply(const std::vector<Move>& moves, std::size_t count) {
    std::vector<char> locked(tree_.nodes.size(), 0);
    for (std::size_t i = 0; i < count; ++i) {
      const Move& m = moves[i];
      if (locked[m.node]) continue;  // an earlier move may have made it the root
      const uint32_t parent = tree_.nodes[m.node].parent, sibling = tree_.sibling(m.node);
      const uint32_t grandparent = tree_.nodes[parent].parent, above_target = tree_.nodes[m.target].parent;
      const uint32_t touched[] = {m.node, parent, sibling, grandparent, m.target, above_target};
      if (std::any_of(std::begin(touched), std::end(touched),
                      [&](uint32_t t) { return t != kNoNode && locked[t]; }))
        continue;
      // An earlier move may have carried the target into n's subtree.
      if (tree_.in_subtree(m.target, m.node)) continue;
      for (const uint32_t t : touched)
        if (t != kNoNode) locked[t] = 1;
      move(m.node, m.target);
    }
  }

  // Takes n's parent out (n's sibling takes its place) and puts it back between `target` and target's
  // parent, with n and target as its children. Boxes are left for refit().
  void move(uint32_t n, uint32_t target) {
    auto& nodes = tree_.nodes;
    const uint32_t parent = nodes[n].parent, sibling = tree_.sibling(n);
    const uint32_t grandparent = nodes[parent].parent;
    nodes[sibling].parent = grandparent;
    if (grandparent == kNoNode)
      tree_.root = sibling;
    else
      tree_.replace_child(grandparent, parent, sibling);
    const uint32_t above = nodes[target].parent;
    nodes[parent].parent = above;
    if (above == kNoNode)
      tree_.root = parent;
    else
      tree_.replace_child(above, target, parent);
    nodes[parent].child[0] = target;
    nodes[parent].child[1] = n;
    nodes[target].parent = parent;
    nodes[n].parent = parent;
  }

  LinkedTree& tree_;
  const ReinsertParams& params_;
  LinkedTree::Levels levels_;  // of the tree as it stands between iterations
};

}  // namespace

Bvh reinsert(const Bvh& source, const ReinsertParams& params) {
  if (!(params.batch > 0.0 && params.batch <= 1.0))
    throw Error("reinsert: batch = " + std::to_string(params.batch) + " is outside (0, 1]");
  if (!(params.min_gain >= 0.0 && params.min_gain <= kMaxMinGain))
    throw Error("reinsert: min_gain = " + std::to_string(params.min_gain) + " is outside [0, " +
                std::to_string(kMaxMinGain) + "]");
  LinkedTree tree(source, "reinsert");
  if (tree.nodes.size() < 3 || params.iterations == 0) return source;
  Reinserter(tree, params).run();
  Bvh out = tree.to_bvh();
  // The iterations compare the inner areas summed in one order; the statistics sum the whole tree in
  // another. Where the two disagree on a change too small to matter, keep the source.
  if (!(sah_cost(out, params.cost) < sah_cost(source, params.cost))) return source;
  return out;
}

}  // namespace sahbench
