#include "traversal/bvh2_traversal.h"

#include <string>

#include "core/error.h"

namespace sahbench::detail {

void throw_stack_overflow(uint32_t node, uint32_t child_count) {
  throw Error("traversal stack overflow at node " + std::to_string(node) + " (" +
              std::to_string(child_count) +
              " children): the tree is deeper than kMaxDepth = " + std::to_string(kMaxDepth) +
              ", which the stack of " + std::to_string(kStackCapacity) + " entries is sized for");
}

}  // namespace sahbench::detail
