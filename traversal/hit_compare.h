#pragma once
// When two kernels' answers for the same ray count as the same: used by the harness's reference checks
// and by the tests, so both apply one rule.

#include <algorithm>
#include <cmath>

#include "core/ray.h"

namespace sahbench {

/// Hit distances of two triangles sharing the edge or vertex a ray passes through agree to within the
/// rounding of the triangle tests: a few ulps of the coordinates, in units of t. 1e-5 relative to the
/// larger of t and the scene's size (in t units: box diagonal / |dir|) is far above that and far below
/// any real difference between surfaces.
inline constexpr float kTieTolerance = 1e-5f;

/// `t_scale`: the scene's size in units of t along the ray (1 where unknown).
inline bool same_hit_distance(float a, float b, float t_scale = 1.0f) {
  return std::fabs(a - b) <= kTieTolerance * std::max({1.0f, std::fabs(b), t_scale});
}

/// Both miss; or both hit the same primitive (its distance may differ by rounding between two triangle
/// tests: that is a precision metric, not a wrong answer); or both hit different primitives at the same
/// distance, a tie on a shared edge or vertex.
inline bool same_hit(const Hit& a, const Hit& b, float t_scale = 1.0f) {
  if (a.found() != b.found()) return false;
  if (!a.found() || a.prim == b.prim) return true;
  return same_hit_distance(a.t, b.t, t_scale);
}

}  // namespace sahbench
