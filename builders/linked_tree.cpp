#include "builders/linked_tree.h"

#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <bit>
#include <string>
#include <utility>

#include "core/error.h"

namespace sahbench {
namespace {

// Parallel tasks per thread at the top of the tree, as in core/refit.cpp: enough spare tasks that a lopsided
// tree still balances across threads. Which subtrees run as tasks changes neither boxes nor sums.
constexpr int kTasksPerThread = 16;

using Summary = LinkedTree::Summary;

class Refitter {
 public:
  Refitter(std::vector<LinkedNode>& nodes, LinkedTree::Levels* levels, uint32_t spawn_depth)
      : nodes_(nodes), levels_(levels), spawn_depth_(spawn_depth) {}

  // Post-order below a node at `depth`. The recursion depth is the tree's, which the passes keep within
  // kMaxDepth.
  Summary refit(uint32_t n, uint32_t depth) {
    LinkedNode& node = nodes_[n];
    Summary out;
    if (!node.is_leaf()) {
      Summary children[2];
      if (depth < spawn_depth_) {
        tbb::parallel_invoke([&] { children[0] = refit(node.child[0], depth + 1); },
                             [&] { children[1] = refit(node.child[1], depth + 1); });
      } else {
        children[0] = refit(node.child[0], depth + 1);
        children[1] = refit(node.child[1], depth + 1);
      }
      node.bounds = merge(nodes_[node.child[0]].bounds, nodes_[node.child[1]].bounds);
      out.height = 1 + std::max(children[0].height, children[1].height);
      out.inner_area = area_in_double(node.bounds) + children[0].inner_area + children[1].inner_area;
    }
    if (levels_) {
      levels_->depth[n] = depth;
      levels_->height[n] = out.height;
    }
    return out;
  }

 private:
  std::vector<LinkedNode>& nodes_;
  LinkedTree::Levels* levels_;
  uint32_t spawn_depth_;
};

}  // namespace

LinkedTree::LinkedTree(const Bvh& bvh, std::string_view pass)
    : refs_(bvh.prim_refs.begin(), bvh.prim_refs.end()) {
  if (bvh.arity != 2)
    throw Error(std::string(pass) + ": the source tree has arity " + std::to_string(bvh.arity) +
                "; this pass rewrites binary trees (a source of arity 2)");
  nodes.resize(bvh.nodes.size());
  if (bvh.nodes.empty()) return;
  root = 0;
  for (uint32_t n = 0; n < bvh.nodes.size(); ++n) {
    const Node& in = bvh.nodes[n];
    LinkedNode& out = nodes[n];
    out.bounds = in.bounds;
    if (in.is_leaf()) {
      out.first = in.first;
      out.count = in.prim_count;
      continue;
    }
    if (in.child_count != 2)
      throw Error(std::string(pass) + ": node " + std::to_string(n) + " of the source tree has " +
                  std::to_string(in.child_count) + " children; this pass rewrites binary trees");
    for (uint32_t c = 0; c < 2; ++c) {
      out.child[c] = in.first + c;
      nodes[in.first + c].parent = n;
    }
  }
}

uint32_t LinkedTree::sibling(uint32_t n) const {
  const LinkedNode& parent = nodes[nodes[n].parent];
  return parent.child[0] == n ? parent.child[1] : parent.child[0];
}

void LinkedTree::replace_child(uint32_t parent, uint32_t old, uint32_t now) {
  LinkedNode& p = nodes[parent];
  p.child[p.child[0] == old ? 0 : 1] = now;
}

bool LinkedTree::in_subtree(uint32_t n, uint32_t ancestor) const {
  for (; n != kNoNode; n = nodes[n].parent)
    if (n == ancestor) return true;
  return false;
}

LinkedTree::Summary LinkedTree::refit(Levels* levels) {
  if (levels) {
    levels->depth.resize(nodes.size());
    levels->height.resize(nodes.size());
  }
  if (root == kNoNode) return {};
  const int tasks = tbb::this_task_arena::max_concurrency() * kTasksPerThread;
  return Refitter(nodes, levels, static_cast<uint32_t>(std::bit_width(static_cast<unsigned>(tasks))))
      .refit(root, 0);
}

Bvh LinkedTree::to_bvh() const {
  Bvh out;
  if (root == kNoNode) return out;
  out.nodes.reserve(nodes.size());
  out.prim_refs.reserve(refs_.size());
  out.nodes.push_back({nodes[root].bounds, 0, 0, 0});
  // (linked node, output index) still to fill; the second child pushed first, so that the first child's
  // subtree follows the pair.
  std::vector<std::pair<uint32_t, uint32_t>> stack{{root, 0u}};
  while (!stack.empty()) {
    const auto [n, index] = stack.back();
    stack.pop_back();
    const LinkedNode& node = nodes[n];
    Node& written = out.nodes[index];
    if (node.is_leaf()) {
      written.first = static_cast<uint32_t>(out.prim_refs.size());
      written.prim_count = static_cast<uint16_t>(node.count);
      out.prim_refs.insert(out.prim_refs.end(), refs_.begin() + node.first,
                           refs_.begin() + node.first + node.count);
      continue;
    }
    const uint32_t first = static_cast<uint32_t>(out.nodes.size());
    written.first = first;
    written.child_count = 2;
    for (const uint32_t c : node.child) out.nodes.push_back({nodes[c].bounds, 0, 0, 0});
    stack.emplace_back(node.child[1], first + 1);
    stack.emplace_back(node.child[0], first);
  }
  return out;
}

}  // namespace sahbench
