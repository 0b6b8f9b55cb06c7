#pragma once
// Comparison of a kernel's answers with the brute-force reference, shared by the builder, traversal and
// layout suites.

#include <gtest/gtest.h>

#include <cmath>
#include <span>
#include <string>

#include "core/ray.h"
#include "core/triangle.h"
#include "traversal/hit_compare.h"
#include "traversal/triangle_tests.h"

namespace sahbench::test {

inline bool same_t(float a, float b) {
  return same_hit_distance(a, b);
}

/// Equal when both miss; or the same primitive at the same t; or a tie: another primitive that the
/// watertight test also hits, at a t within kTieTolerance of the reference's.
inline ::testing::AssertionResult same_closest_hit(const Hit& got, const Hit& ref,
                                                   std::span<const Triangle> tris, const Ray& ray) {
  auto describe = [](const Hit& h) {
    return h.found() ? "prim " + std::to_string(h.prim) + " at t=" + std::to_string(h.t)
                     : std::string("miss");
  };
  if (got.found() != ref.found() || (got.found() && !same_t(got.t, ref.t)))
    return ::testing::AssertionFailure() << "got " << describe(got) << ", reference " << describe(ref);
  if (!got.found() || got.prim == ref.prim) return ::testing::AssertionSuccess();
  float t, u, v;
  const WatertightTriangleTest test(ray);
  if (got.prim < tris.size() && test.intersect(tris[got.prim], ray.tmin, ray.tmax, t, u, v) &&
      same_t(t, ref.t))
    return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "got " << describe(got) << ", reference " << describe(ref)
                                       << ", and the got primitive is not hit at that t";
}

}  // namespace sahbench::test
