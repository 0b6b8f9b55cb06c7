#pragma once
// The one place where triangles enter a Scene: every loader and generator pushes its triangles through
// a TriangleFilter, which keeps the valid ones and counts the others by reason (DESIGN.md, numerical
// policy). Nothing else appends to Scene::triangles.

#include <algorithm>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "core/triangle.h"
#include "scenes/scene.h"

namespace sahbench {

/// A double coordinate as float. Values beyond the float range become +-infinity (so the filter counts
/// them as non-finite) instead of the undefined behaviour of a plain out-of-range conversion.
inline float to_float(double v) {
  constexpr double kMax = std::numeric_limits<float>::max();
  if (v > kMax) return std::numeric_limits<float>::infinity();
  if (v < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);  // NaN stays NaN
}

class TriangleFilter {
 public:
  /// Appends to `scene.triangles` and counts into `scene.removed`; the scene must outlive the filter.
  explicit TriangleFilter(Scene& scene) : scene_(scene) {}

  /// Makes room for `count` more triangles. Grows geometrically, so that loaders may call it once per
  /// mesh instance (hundreds of times) without quadratic copying.
  void reserve(std::size_t count) {
    auto& tris = scene_.triangles;
    const std::size_t needed = tris.size() + count;
    if (needed > tris.capacity()) tris.reserve(std::max(needed, 2 * tris.capacity()));
  }

  /// Keeps `t` if it is finite and has non-zero area; otherwise counts it.
  void add(const Triangle& t) {
    if (accept(t)) scene_.triangles.push_back(t);
  }

  /// The triangle (vertices[a], vertices[b], vertices[c]). Indices are signed and 64-bit so that any
  /// index a file can hold (negative, or past the end) is representable and counted as bad_index.
  void add_indexed(std::span<const Vec3> vertices, int64_t a, int64_t b, int64_t c) {
    const auto n = static_cast<int64_t>(vertices.size());
    if (a < 0 || b < 0 || c < 0 || a >= n || b >= n || c >= n) {
      ++scene_.removed.bad_index;
      return;
    }
    add({vertices[static_cast<std::size_t>(a)], vertices[static_cast<std::size_t>(b)],
         vertices[static_cast<std::size_t>(c)]});
  }

  /// Counts a triangle the caller could not even form because one of its indices is invalid.
  void add_bad_index(std::size_t count = 1) { scene_.removed.bad_index += count; }
  /// Counts a polygon with fewer than three vertices: it has zero area by definition.
  void add_degenerate(std::size_t count = 1) { scene_.removed.zero_area += count; }

  /// Same as add() for each triangle, in order; moves the storage into an empty scene instead of copying
  /// (generators produce millions of triangles).
  void add_all(std::vector<Triangle>&& triangles) {
    if (!scene_.triangles.empty()) {
      reserve(triangles.size());
      for (const Triangle& t : triangles) add(t);
      return;
    }
    // Compact in place, counting the removed ones with the same classification as add().
    std::size_t kept = 0;
    for (const Triangle& t : triangles)
      if (accept(t)) triangles[kept++] = t;
    triangles.resize(kept);
    scene_.triangles = std::move(triangles);
  }

 private:
  enum class Verdict { kValid, kNonFinite, kZeroArea };

  static Verdict classify(const Triangle& t) {
    if (!is_finite(t.v0) || !is_finite(t.v1) || !is_finite(t.v2)) return Verdict::kNonFinite;
    // Exactly zero in float, as core computes it: repeated vertices, exactly collinear ones, or edges so
    // short that the cross product underflows. Any other sliver is kept; builders must cope with it.
    if (t.normal() == Vec3{0.0f}) return Verdict::kZeroArea;
    return Verdict::kValid;
  }

  // True for a valid triangle; an invalid one is counted under its reason.
  bool accept(const Triangle& t) {
    switch (classify(t)) {
      case Verdict::kValid:
        return true;
      case Verdict::kNonFinite:
        ++scene_.removed.non_finite;
        return false;
      case Verdict::kZeroArea:
        ++scene_.removed.zero_area;
        return false;
    }
    return false;
  }

  Scene& scene_;
};

}  // namespace sahbench
