#pragma once
// When two kernels' answers for the same ray count as the same: used by the harness's reference checks
// and by the tests, so both apply one rule.

#include <algorithm>
#include <cmath>

#include "core/ray.h"

namespace sahbench {

/// Hit distances of two triangles sharing the edge or vertex a ray passes through agree to within the
/// rounding of the triangle test, a few ulps of t; 1e-5 relative is far above that and far below any
/// real difference between surfaces.
inline constexpr float kTieTolerance = 1e-5f;

inline bool same_hit_distance(float a, float b) {
  return std::fabs(a - b) <= kTieTolerance * std::max(1.0f, std::fabs(b));
}

/// Both miss, or both hit at the same distance (the same primitive, or a tie on a shared edge: a
/// different primitive at that distance is not a mismatch).
inline bool same_hit(const Hit& a, const Hit& b) {
  if (a.found() != b.found()) return false;
  return !a.found() || same_hit_distance(a.t, b.t);
}

}  // namespace sahbench
