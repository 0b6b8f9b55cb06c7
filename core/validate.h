#pragma once
// Checks the invariants of the common format. Runs in tests after every build and in the CLI.

#include <span>
#include <string>
#include <vector>

#include "core/bvh.h"
#include "core/triangle.h"

namespace sahbench {

struct ValidationReport {
  std::vector<std::string> errors;  ///< empty when the tree is valid; capped at a few dozen messages
  bool ok() const { return errors.empty(); }
  std::string summary() const;      ///< the errors joined by newlines
};

/// Checks: nodes[0] exists; every child index in range and every node reached exactly once from the
/// root (no cycles, no sharing, no orphans); child_count within 2..arity for inner nodes; exactly one
/// of the two counts non-zero; leaf ranges inside prim_refs and every reference a valid primitive;
/// no NaN in any box; every child box inside its parent; every leaf box contains its primitives'
/// bounds (when `prim_bounds` is given); every primitive referenced at least once.
ValidationReport validate(const Bvh& bvh, std::span<const Aabb> prim_bounds);

/// Same, with primitive bounds computed from the triangles.
ValidationReport validate(const Bvh& bvh, std::span<const Triangle> triangles);

}  // namespace sahbench
