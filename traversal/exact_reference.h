#pragma once
// The exact reference: the closest hit of a ray among triangles, decided in exact arithmetic with CGAL
// (Exact_predicates_exact_constructions_kernel: interval-filtered predicates, exact rationals where the
// filter cannot decide), so that the float kernels' errors can be measured against the truth rather
// than against another float kernel. Float inputs are exact rationals; nothing is rounded until the
// final distance is rounded to the nearest float for comparison.
//
// What counts as a hit (the same contract as the float tests in traversal/triangle_tests.h, decided
// exactly): the ray's segment {org + t dir : tmin <= t <= tmax} (closed) meets the closed triangle at
// a single point. A ray lying in the triangle's plane (the line meets it along a segment, or not at
// all) is not a hit, and neither is a triangle of exactly zero area: both have a zero determinant,
// which every float test treats as a miss. Points on edges and vertices count, so a ray through a
// shared edge or vertex hits every triangle around it at the same exact t: a tie.

#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include "core/ray.h"
#include "core/triangle.h"

namespace sahbench {

/// The exact closest hit of one ray.
struct ExactHit {
  /// Every primitive hit at exactly the closest distance, ascending; empty for a miss. More than one is
  /// a tie (a shared edge or vertex, or coincident triangles): any of them is a correct answer.
  std::vector<uint32_t> tied;
  /// The exact closest distance rounded to the nearest float (ties to even); +inf for a miss.
  float t = std::numeric_limits<float>::infinity();

  bool found() const { return !tied.empty(); }
  /// The lowest tied primitive (the float kernels' own tie rule), or kInvalidPrim for a miss.
  uint32_t prim() const { return tied.empty() ? kInvalidPrim : tied.front(); }
  /// Whether `prim` is one of the primitives hit at the closest distance.
  bool accepts(uint32_t prim) const;
};

/// Brute force over the triangles, with a conservative float bounding-box cull in front of the exact
/// tests. Bitwise-identical triangles are tested once and answer together (100,000 coincident triangles
/// cost one test). Thread-safe: closest() may be called concurrently (CGAL 5.5's lazy kernel is).
class ExactReference {
 public:
  /// `triangles` must outlive the reference; they must be finite (scenes filter the others out).
  explicit ExactReference(std::span<const Triangle> triangles);
  ~ExactReference();
  ExactReference(const ExactReference&) = delete;
  ExactReference& operator=(const ExactReference&) = delete;

  /// The exact closest hit of `ray` (its direction must not be the zero vector; a zero one misses).
  ExactHit closest(const Ray& ray) const;

  /// closest() of every ray, in parallel with TBB.
  std::vector<ExactHit> closest(std::span<const Ray> rays) const;

  /// Distinct triangles after merging bitwise-identical ones.
  std::size_t unique_triangles() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Whether the line of `ray` (tmin and tmax ignored) crosses `triangle` at a single point, decided
/// exactly as above; if so, `t` is that point's exact distance rounded to the nearest float. For tests
/// of hand-made cases.
bool exact_line_hit(const Triangle& triangle, const Ray& ray, float& t);

}  // namespace sahbench
