#include "builders/linked_tree.h"

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <string>
#include <utility>

#include "core/error.h"

namespace sahbench {
namespace {

// Subtrees of fewer nodes than this are refitted by the task that reaches them: large enough that a
// task's work dwarfs spawning it, small enough that a tree of 100K nodes still spreads over the threads.
constexpr uint32_t kSerialRefitNodes = 4096;

class Refitter {
 public:
  explicit Refitter(std::vector<LinkedNode>& nodes) : nodes_(nodes) {}

  // Post-order; returns the subtree's node count so that the caller can decide where to spawn. The
  // recursion depth is the tree's, which the passes keep within kMaxDepth.
  uint32_t refit(uint32_t n) {
    LinkedNode& node = nodes_[n];
    if (node.is_leaf()) return 1;
    uint32_t sizes[2];
    if (parallel_) {
      // Spawn only near the top: whether the children run as tasks does not change the boxes.
      tbb::parallel_invoke([&] { sizes[0] = refit_serial_below(node.child[0]); },
                           [&] { sizes[1] = refit_serial_below(node.child[1]); });
    } else {
      sizes[0] = refit(node.child[0]);
      sizes[1] = refit(node.child[1]);
    }
    node.bounds = merge(nodes_[node.child[0]].bounds, nodes_[node.child[1]].bounds);
    return 1 + sizes[0] + sizes[1];
  }

 private:
  // A task for one child: parallel again while the child's subtree is large, by the count of the
  // previous refit of the same node (sizes do not change as boxes do).
  uint32_t refit_serial_below(uint32_t n) {
    Refitter child(nodes_);
    child.parallel_ = subtree_large(n);
    return child.refit(n);
  }

  // Whether n's subtree has at least kSerialRefitNodes nodes, by a bounded walk.
  bool subtree_large(uint32_t n) const {
    std::vector<uint32_t> stack{n};
    uint32_t seen = 0;
    while (!stack.empty() && seen < kSerialRefitNodes) {
      const LinkedNode& node = nodes_[stack.back()];
      stack.pop_back();
      ++seen;
      if (!node.is_leaf()) stack.insert(stack.end(), {node.child[0], node.child[1]});
    }
    return seen >= kSerialRefitNodes;
  }

  std::vector<LinkedNode>& nodes_;
  bool parallel_ = true;
};

}  // namespace

double area_in_double(const Aabb& box) {
  if (box.is_empty()) return 0.0;
  const double x = static_cast<double>(box.max.x) - box.min.x;
  const double y = static_cast<double>(box.max.y) - box.min.y;
  const double z = static_cast<double>(box.max.z) - box.min.z;
  return x * y + y * z + z * x;
}

LinkedTree::LinkedTree(const Bvh& bvh, std::string_view pass) : refs_(bvh.prim_refs) {
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

void LinkedTree::refit() {
  if (root != kNoNode) Refitter(nodes).refit(root);
}

double LinkedTree::inner_area() const {
  double sum = 0.0;
  for (const LinkedNode& node : nodes)
    if (!node.is_leaf()) sum += area_in_double(node.bounds);
  return sum;
}

void LinkedTree::depths_and_heights(std::vector<uint32_t>& depth, std::vector<uint32_t>& height) const {
  depth.assign(nodes.size(), 0);
  height.assign(nodes.size(), 0);
  if (root == kNoNode) return;
  // Pre-order for the depths; its reverse visits children before parents, for the heights.
  std::vector<uint32_t> order, stack{root};
  order.reserve(nodes.size());
  while (!stack.empty()) {
    const uint32_t n = stack.back();
    stack.pop_back();
    order.push_back(n);
    const LinkedNode& node = nodes[n];
    if (node.is_leaf()) continue;
    for (const uint32_t c : node.child) {
      depth[c] = depth[n] + 1;
      stack.push_back(c);
    }
  }
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    const LinkedNode& node = nodes[*it];
    if (!node.is_leaf()) height[*it] = 1 + std::max(height[node.child[0]], height[node.child[1]]);
  }
}

uint32_t LinkedTree::max_depth() const {
  std::vector<uint32_t> depth, height;
  depths_and_heights(depth, height);
  return root == kNoNode ? 0 : height[root];
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
