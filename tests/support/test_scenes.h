#pragma once
// Random and adversarial inputs shared by the test suites. Deterministic from a seed.

#include <cstdint>
#include <vector>

#include "core/ray.h"
#include "core/triangle.h"

namespace sahbench::test {

/// `count` triangles with vertices uniform in [-extent, extent]^3 and edges up to `max_edge` long.
std::vector<Triangle> random_triangles(std::size_t count, uint64_t seed, float extent = 10.0f,
                                       float max_edge = 2.0f);

/// A closed, watertight grid of quads (two triangles each) on the six faces of a cube: every interior
/// edge and vertex is shared, so a leak through it is a kernel error.
std::vector<Triangle> cube_grid(int quads_per_side, float half_size);

/// A mix of rays aimed at the scene's box: random origins outside and inside, random directions, and
/// rays whose direction has +0 and -0 components (axis-parallel and in coordinate planes).
std::vector<Ray> random_rays(const std::vector<Triangle>& scene, std::size_t count, uint64_t seed);

/// random_rays in groups of `group` that a packet kernel traces together: each group's first ray is one
/// of random_rays, the others start near it and point nearly its way, with the same sign bit in each
/// direction component (so zero components stay +0 or -0 across the group) and the same interval.
std::vector<Ray> coherent_rays(const std::vector<Triangle>& scene, std::size_t count, uint64_t seed,
                               std::size_t group = 8);

/// random_rays in groups of `group` that agree on the sign bit of each direction component (so that a
/// packet kernel takes each group as one packet, unless box=fma sends a ray with a zero component alone)
/// and little else: each ray after a group's first starts up to a tenth of the scene's diagonal from it
/// on each axis, with each nonzero direction component of its own magnitude (so, unless the first ray is
/// axis-parallel, in a direction of its own within the octant), and every third ray ends sooner and every
/// fourth starts later than the first.
std::vector<Ray> diverging_rays(const std::vector<Triangle>& scene, std::size_t count, uint64_t seed,
                                std::size_t group = 8);

/// Rays as a set interleaves those of several sources (a shadow ray to each of `streams` lights from
/// every pixel): ray i belongs to stream i % streams, and every run of group * streams rays holds
/// `group` rays of each stream, so that a packet of consecutive rays mixes the streams. Each stream's first
/// ray in a run is one of random_rays; the others start up to a tenth of the scene's diagonal from it on each
/// axis and point within some ten degrees of it, with the same sign bit in each direction component, and
/// every third ends sooner.
std::vector<Ray> interleaved_rays(const std::vector<Triangle>& scene, std::size_t count, uint64_t seed,
                                  std::size_t group, std::size_t streams);

/// Shadow rays as a point-light set makes them: from points on the scene's triangles to `lights` points in
/// and around its box, ray i to light i % lights, unnormalised (t in [tmin, 1 - 1e-4]), tmin 0 or just
/// above it; the last light sits on a vertex of the scene. With `level`, every fifth ray starts level
/// with its light on one axis (a +0 direction component, which box=fma sends to the robust box test).
std::vector<Ray> shadow_rays(const std::vector<Triangle>& scene, std::size_t count, uint64_t seed,
                             std::size_t lights, bool level = true);

}  // namespace sahbench::test
