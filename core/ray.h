#pragma once
// Rays and hit records shared by every kernel, the brute-force reference and (later) Embree.

#include <cstdint>
#include <limits>

#include "core/vec3.h"

namespace sahbench {

/// A ray is the segment org + t * dir for t in [tmin, tmax]. `dir` need not be normalised and may have
/// +0 or -0 components; every kernel must accept both.
struct Ray {
  Vec3 org;
  float tmin = 0.0f;
  Vec3 dir{0.0f, 0.0f, 1.0f};
  float tmax = std::numeric_limits<float>::infinity();
};

/// Whether every kernel traces `ray`: a finite origin and direction and a non-NaN interval. Kernels
/// report any other ray as a miss without traversing (an infinite component makes every slab distance
/// NaN, which the box tests read as "inside", and would take a wide kernel into its empty child slots).
inline bool traceable(const Ray& ray) {
  auto finite = [](float x) { return x - x == 0.0f; };  // false for +-inf and NaN
  return finite(ray.org.x) && finite(ray.org.y) && finite(ray.org.z) && finite(ray.dir.x) &&
         finite(ray.dir.y) && finite(ray.dir.z) && ray.tmin == ray.tmin && ray.tmax == ray.tmax;
}

/// The far end of `ray` that every kernel and reference tests a hit against: tmax, but at most the largest
/// finite float. A hit's t is a float, so a crossing beyond it (t overflows to inf for a direction so short
/// that 1e-40 is its length) is no hit, whatever tmax says.
inline float far_limit(const Ray& ray) {
  constexpr float kLargest = std::numeric_limits<float>::max();
  return ray.tmax > kLargest ? kLargest : ray.tmax;
}

inline constexpr uint32_t kInvalidPrim = 0xFFFFFFFFu;

/// Closest-hit result. `prim` is the scene triangle index, or kInvalidPrim for a miss. (u, v) are the
/// barycentric coordinates of the hit with respect to v1 and v2: p = (1-u-v)*v0 + u*v1 + v*v2.
struct Hit {
  uint32_t prim = kInvalidPrim;
  float t = std::numeric_limits<float>::infinity();
  float u = 0.0f;
  float v = 0.0f;

  constexpr bool found() const { return prim != kInvalidPrim; }
};

}  // namespace sahbench
