#pragma once
// The brute-force reference: every triangle tested against every ray. Slow and simple on purpose; the
// kernels and layouts are checked against it on small scenes.

#include <span>

#include "core/ray.h"
#include "core/triangle.h"
#include "traversal/triangle_tests.h"

namespace sahbench {

/// Closest hit of `ray` within [ray.tmin, ray.tmax] (closed) among `triangles`, by testing all of them in
/// index order. Ties: among hits at the same float t, the lowest primitive index wins (a later hit
/// replaces the current one only when strictly closer). Instantiated for WatertightTriangleTest (the
/// reference), MollerTrumboreTest with its default epsilon and MollerTrumboreNormalTest.
template <class TriangleTest = WatertightTriangleTest>
Hit brute_force_closest(std::span<const Triangle> triangles, const Ray& ray);

/// Whether any triangle is hit within [ray.tmin, ray.tmax] (closed).
template <class TriangleTest = WatertightTriangleTest>
bool brute_force_any(std::span<const Triangle> triangles, const Ray& ray);

extern template Hit brute_force_closest<WatertightTriangleTest>(std::span<const Triangle>, const Ray&);
extern template Hit brute_force_closest<MollerTrumboreTest>(std::span<const Triangle>, const Ray&);
extern template bool brute_force_any<WatertightTriangleTest>(std::span<const Triangle>, const Ray&);
extern template bool brute_force_any<MollerTrumboreTest>(std::span<const Triangle>, const Ray&);
extern template Hit brute_force_closest<MollerTrumboreNormalTest>(std::span<const Triangle>, const Ray&);
extern template bool brute_force_any<MollerTrumboreNormalTest>(std::span<const Triangle>, const Ray&);

}  // namespace sahbench
