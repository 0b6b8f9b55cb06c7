#include "core/validate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/clip_polygon.h"

namespace sahbench {
namespace {

// Enough messages to diagnose a broken builder without flooding the terminal.
constexpr std::size_t kMaxMessages = 32;
// Coverage of a clipped triangle is checked against its leaves' boxes grown by this fraction of the
// triangle's largest coordinate: 2^-30 is far above the double rounding of clipped points (about
// 2^-50 of it) and far below float resolution (2^-24), so a builder whose boxes miss a float-sized
// sliver of a triangle still fails.
constexpr double kCoverageTolerance = 0x1p-30;
// Pieces of a triangle the coverage check keeps at once before it gives up (each box it subtracts may
// cut a piece into six); SBVH trees need a handful.
constexpr std::size_t kMaxCoveragePieces = 4096;

bool has_nan(const Aabb& b) {
  for (std::size_t a = 0; a < 3; ++a)
    if (std::isnan(b.min[a]) || std::isnan(b.max[a])) return true;
  return false;
}

// Nine significant digits read back as the same float: a box one rounding too small must print as
// another number than the box it fails to enclose.
std::string float_text(float v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", static_cast<double>(v));
  return text;
}

std::string box_string(const Aabb& b) {
  return "[(" + float_text(b.min.x) + ", " + float_text(b.min.y) + ", " + float_text(b.min.z) + ") .. (" +
         float_text(b.max.x) + ", " + float_text(b.max.y) + ", " + float_text(b.max.z) + ")]";
}

class Checker {
 public:
  Checker(const Bvh& bvh, std::span<const Aabb> prim_bounds, std::span<const Triangle> triangles)
      : bvh_(bvh), prim_bounds_(prim_bounds), triangles_(triangles) {}

  ValidationReport run() {
    if (bvh_.nodes.empty()) {
      // An empty scene has an empty tree; any primitive makes a root necessary.
      if (!prim_bounds_.empty())
        fail("the tree has no nodes but there are " + std::to_string(prim_bounds_.size()) + " primitives");
      return std::move(report_);
    }
    if (bvh_.arity != 2 && bvh_.arity != 4 && bvh_.arity != 8)
      fail("arity is " + std::to_string(bvh_.arity) + ", expected 2, 4 or 8");
    count_references();
    walk();
    check_coverage();
    // The coverage walk assumes a tree; a broken one has been reported already.
    if (!triangles_.empty() && report_.ok()) check_clipped_coverage();
    return std::move(report_);
  }

 private:
  void fail(std::string message) {
    if (report_.errors.size() < kMaxMessages) report_.errors.push_back(std::move(message));
  }

  // Visits every node reachable from the root once. A node reached twice means a cycle or a shared
  // child; the walk does not descend into it again, so it terminates on any input.
  void walk() {
    const std::size_t n = bvh_.nodes.size();
    std::vector<uint8_t> seen(n, 0);
    std::vector<uint32_t> stack{0};
    seen[0] = 1;
    referenced_.assign(prim_bounds_.size(), 0);
    std::size_t reached = 1;
    while (!stack.empty()) {
      const uint32_t index = stack.back();
      stack.pop_back();
      const Node& node = bvh_.nodes[index];
      const std::string where = "node " + std::to_string(index);
      if (has_nan(node.bounds)) fail(where + " has NaN in its bounds");
      if ((node.child_count == 0) == (node.prim_count == 0)) {
        fail(where + " has child_count " + std::to_string(node.child_count) + " and prim_count " +
             std::to_string(node.prim_count) + "; exactly one must be non-zero");
        continue;
      }
      if (node.is_leaf()) {
        check_leaf(index, node);
        continue;
      }
      if (node.child_count < 2 || node.child_count > bvh_.arity)
        fail(where + " has " + std::to_string(node.child_count) + " children, arity is " +
             std::to_string(bvh_.arity));
      if (static_cast<uint64_t>(node.first) + node.child_count > n) {
        fail(where + " has children [" + std::to_string(node.first) + ", +" +
             std::to_string(node.child_count) + ") outside the " + std::to_string(n) + " nodes");
        continue;
      }
      for (uint32_t c = node.first; c < node.first + node.child_count; ++c) {
        if (seen[c]) {
          fail("node " + std::to_string(c) + " is reached twice (cycle or shared child), again from " +
               where);
          continue;
        }
        seen[c] = 1;
        ++reached;
        if (!node.bounds.contains(bvh_.nodes[c].bounds))
          fail("child node " + std::to_string(c) + " " + box_string(bvh_.nodes[c].bounds) +
               " is not inside its parent " + where + " " + box_string(node.bounds));
        stack.push_back(c);
      }
    }
    if (reached != n) fail(std::to_string(n - reached) + " nodes are not reachable from the root");
  }

  void check_leaf(uint32_t index, const Node& node) {
    const std::string where = "leaf " + std::to_string(index);
    if (static_cast<uint64_t>(node.first) + node.prim_count > bvh_.prim_refs.size()) {
      fail(where + " references [" + std::to_string(node.first) + ", +" + std::to_string(node.prim_count) +
           ") outside the " + std::to_string(bvh_.prim_refs.size()) + " references");
      return;
    }
    for (uint32_t r = node.first; r < node.first + node.prim_count; ++r) {
      const uint32_t prim = bvh_.prim_refs[r];
      if (prim >= prim_bounds_.size()) {
        fail(where + " references primitive " + std::to_string(prim) + ", but there are only " +
             std::to_string(prim_bounds_.size()));
        continue;
      }
      referenced_[prim] = 1;
      // Spatial splits may clip a reference to a part of the primitive, so only the intersection of
      // the two boxes must be non-empty for those; without repeats the whole box must be inside.
      const Aabb& pb = prim_bounds_[prim];
      const bool inside = node.bounds.contains(pb);
      const bool overlaps = !merge_intersection(node.bounds, pb).is_empty();
      if (!inside && !(may_be_clipped(prim) && overlaps))
        fail(where + " does not contain primitive " + std::to_string(prim) + " " + box_string(pb) +
             "; leaf box " + box_string(node.bounds));
      if (!triangles_.empty() && inside) fully_contained_[prim] = 1;
    }
  }

  static Aabb merge_intersection(const Aabb& a, const Aabb& b) {
    return {max(a.min, b.min), min(a.max, b.max)};
  }

  // A leaf may hold a clipped part of a primitive only when that primitive is split, i.e. referenced
  // more than once. With bounds alone, the validator cannot tell which primitives are split and allows
  // clipped parts of all of them as soon as references repeat.
  bool may_be_clipped(uint32_t prim) const {
    if (!triangles_.empty()) return reference_count_[prim] > 1;
    return bvh_.prim_refs.size() > prim_bounds_.size();
  }

  // References per primitive (out-of-range ones are reported by check_leaf).
  void count_references() {
    if (triangles_.empty()) return;
    reference_count_.assign(prim_bounds_.size(), 0);
    fully_contained_.assign(prim_bounds_.size(), 0);
    for (uint32_t prim : bvh_.prim_refs)
      if (prim < reference_count_.size()) ++reference_count_[prim];
  }

  // Every point of a split triangle must lie in the box of some leaf that references it, or a ray may
  // pass through the triangle without testing it. Leaves holding the whole box settle it at once;
  // otherwise the check subtracts the leaves' boxes from the triangle, clipped exactly (ClipPolygon).
  void check_clipped_coverage() {
    std::vector<std::vector<Aabb>> boxes(prim_bounds_.size());
    std::vector<uint32_t> stack{0};
    while (!stack.empty()) {
      const Node& node = bvh_.nodes[stack.back()];
      stack.pop_back();
      if (!node.is_leaf()) {
        for (uint32_t c = 0; c < node.child_count; ++c) stack.push_back(node.first + c);
        continue;
      }
      for (uint32_t r = node.first; r < node.first + node.prim_count; ++r) {
        const uint32_t prim = bvh_.prim_refs[r];
        if (prim < boxes.size() && !fully_contained_[prim] && reference_count_[prim] > 1)
          boxes[prim].push_back(node.bounds);
      }
    }
    for (uint32_t prim = 0; prim < boxes.size(); ++prim) {
      if (boxes[prim].empty()) continue;
      const std::string uncovered = uncovered_part(triangles_[prim], boxes[prim]);
      if (!uncovered.empty())
        fail("primitive " + std::to_string(prim) + " is split over " + std::to_string(boxes[prim].size()) +
             " leaves whose boxes do not cover it: " + uncovered);
    }
  }

  // Empty when the boxes (grown by the tolerance) cover the triangle; otherwise a point left over.
  static std::string uncovered_part(const Triangle& tri, const std::vector<Aabb>& boxes) {
    const double tol = kCoverageTolerance * coordinate_scale(tri);
    std::vector<ClipPolygon> pieces{ClipPolygon::of(tri)}, next;
    for (const Aabb& box : boxes) {
      next.clear();
      for (ClipPolygon piece : pieces) {
        // Cut off the parts beyond each face in turn; what is left at the end lies in the box.
        for (int axis = 0; axis < 3 && !piece.empty(); ++axis) {
          const double lo = double(box.min[axis]) - tol, hi = double(box.max[axis]) + tol;
          for (const bool below : {true, false}) {
            const double face = below ? lo : hi;
            ClipPolygon beyond = piece;
            beyond.clip(axis, face, below);
            if (beyond.reaches(axis, face, below)) next.push_back(beyond);
            piece.clip(axis, face, !below);
          }
        }
      }
      if (next.size() > kMaxCoveragePieces)
        return "too many pieces to check (over " + std::to_string(kMaxCoveragePieces) + ")";
      std::swap(pieces, next);
      if (pieces.empty()) return {};
    }
    const auto& p = pieces.front().v[0];
    return "e.g. near (" + std::to_string(p[0]) + ", " + std::to_string(p[1]) + ", " + std::to_string(p[2]) +
           ")";
  }

  void check_coverage() {
    std::size_t missing = 0;
    uint32_t first_missing = 0;
    for (std::size_t p = 0; p < referenced_.size(); ++p) {
      if (!referenced_[p] && missing++ == 0) first_missing = static_cast<uint32_t>(p);
    }
    if (missing)
      fail(std::to_string(missing) +
           " primitives are not referenced by any leaf (first: " + std::to_string(first_missing) + ")");
  }

  const Bvh& bvh_;
  std::span<const Aabb> prim_bounds_;
  std::span<const Triangle> triangles_;  // empty: bounds only
  std::vector<uint8_t> referenced_;
  std::vector<uint32_t> reference_count_;  // with triangles: references per primitive
  std::vector<uint8_t> fully_contained_;   // with triangles: some leaf box holds the whole primitive box
  ValidationReport report_;
};

}  // namespace

std::string ValidationReport::summary() const {
  std::string out;
  for (const auto& e : errors) out += e + "\n";
  return out;
}

ValidationReport validate(const Bvh& bvh, std::span<const Aabb> prim_bounds) {
  return Checker(bvh, prim_bounds, {}).run();
}

ValidationReport validate(const Bvh& bvh, std::span<const Triangle> triangles) {
  std::vector<Aabb> bounds(triangles.size());
  for (std::size_t i = 0; i < triangles.size(); ++i) bounds[i] = triangles[i].bounds();
  return Checker(bvh, bounds, triangles).run();
}

}  // namespace sahbench
