#include "builders/child_order.h"

#include <algorithm>

namespace sahbench {

void order_children_by_area(Bvh& bvh) {
  for (const Node& node : bvh.nodes) {
    if (node.is_leaf() || node.child_count < 2) continue;
    // A child's record carries its own children and references, so moving the records moves the
    // subtrees; the parent's range [first, first + child_count) stays the same.
    const auto first = bvh.nodes.begin() + node.first;
    std::stable_sort(first, first + node.child_count,
                     [](const Node& a, const Node& b) { return a.bounds.half_area() > b.bounds.half_area(); });
  }
}

}  // namespace sahbench
