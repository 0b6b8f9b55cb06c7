#include "traversal/brute_force.h"

#include <cstdint>

namespace sahbench {

template <class TriangleTest>
Hit brute_force_closest(std::span<const Triangle> triangles, const Ray& ray) {
  if (!traceable(ray)) return {};
  const TriangleTest test(ray);
  Hit best;
  float best_t = far_limit(ray);
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    float t, u, v;
    if (!test.intersect(triangles[i], ray.tmin, best_t, t, u, v)) continue;
    // The test accepts t == best_t; keeping the earlier (lower-index) hit then is the tie rule.
    if (best.found() && !(t < best_t)) continue;
    best = {static_cast<uint32_t>(i), t, u, v};
    best_t = t;
  }
  return best;
}

template <class TriangleTest>
bool brute_force_any(std::span<const Triangle> triangles, const Ray& ray) {
  if (!traceable(ray)) return false;
  const TriangleTest test(ray);
  for (const Triangle& tri : triangles) {
    float t, u, v;
    if (intersect_any(test, tri, ray.tmin, far_limit(ray), t, u, v)) return true;
  }
  return false;
}

template Hit brute_force_closest<WatertightTriangleTest>(std::span<const Triangle>, const Ray&);
template Hit brute_force_closest<MollerTrumboreTest>(std::span<const Triangle>, const Ray&);
template bool brute_force_any<WatertightTriangleTest>(std::span<const Triangle>, const Ray&);
template bool brute_force_any<MollerTrumboreTest>(std::span<const Triangle>, const Ray&);
template Hit brute_force_closest<MollerTrumboreNormalTest>(std::span<const Triangle>, const Ray&);
template bool brute_force_any<MollerTrumboreNormalTest>(std::span<const Triangle>, const Ray&);

}  // namespace sahbench
