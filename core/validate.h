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
  std::string summary() const;  ///< the errors joined by newlines
};

/// Checks: nodes[0] exists; every child index in range and every node reached exactly once from the
/// root (no cycles, no sharing, no orphans); child_count within 2..arity for inner nodes; exactly one
/// of the two counts non-zero; leaf ranges inside prim_refs and every reference a valid primitive;
/// no NaN in any box; every child box inside its parent; every leaf box contains its primitives'
/// bounds; every primitive referenced at least once.
///
/// Spatial splits (references repeat) leave clipped parts of primitives in leaves whose boxes are
/// smaller than the primitive's. From bounds alone the validator cannot check those parts: once
/// references repeat, it only asks each leaf box to overlap its primitives' boxes.
ValidationReport validate(const Bvh& bvh, std::span<const Aabb> prim_bounds);

/// Same, with primitive bounds computed from the triangles, and an exact check of clipped parts: a
/// primitive referenced once must lie in its leaf's box, and the boxes of the leaves that hold a
/// primitive referenced several times must together cover the whole triangle (the triangle is clipped
/// by those boxes in double precision, each grown by 2^-30 of the triangle's largest coordinate), so
/// that no ray can pass through a part of a triangle that no leaf on its path holds.
ValidationReport validate(const Bvh& bvh, std::span<const Triangle> triangles);

}  // namespace sahbench
