#pragma once
// The procedural scene generators. Each is deterministic: the same arguments give bit-identical
// triangles whatever the number of threads (every item draws from its own SplitMix64 stream, see
// rng.h). Triangles are returned unfiltered; procedural.h passes them through the TriangleFilter.

#include <cstdint>
#include <vector>

#include "core/triangle.h"

namespace sahbench {

/// UV sphere of radius 1 at the origin, 2 * n_lon * (n_lat - 1) triangles with n_lon ~ 2 n_lat chosen
/// to be within n_lat of `tris` (at least 6), rotated by a random rotation drawn from `seed` so that no
/// edge is axis-aligned. Watertight: neighbouring triangles share bit-identical vertices.
std::vector<Triangle> generate_sphere(uint64_t tris, uint64_t seed);

/// Heightfield over x in [-1, 1] and z in [-d, d] (square cells, d ~ 1): an nx * nz grid of quads split
/// into two triangles (2 nx nz within nx of `tris`, at least 2), height 0.25 * fractal gradient noise
/// with `octaves` octaves starting at 2 features per unit.
std::vector<Triangle> generate_terrain(uint64_t tris, uint64_t seed, int octaves);

/// Exactly `tris` independent triangles: first vertex uniform in [-1, 1]^3, the other two at distance
/// s from it in uniform random directions, s = 0.002 + 0.198 u^3 for u uniform in [0, 1) (many small,
/// a few large triangles, overlapping freely).
std::vector<Triangle> generate_soup(uint64_t tris, uint64_t seed);

/// Exactly `tris` needles: centre uniform in [-1, 1]^3, axis a uniform random direction, length
/// uniform in [0.05, 0.5], width length / `aspect`: the triangle (c - a l/2, c + a l/2, c + w p) with p
/// a random direction perpendicular to a.
std::vector<Triangle> generate_needles(uint64_t tris, uint64_t seed, double aspect);

/// "Teapot in a stadium": an enclosing cube of half-size `outer` (12 triangles facing inwards) around
/// small UV spheres of radius 0.002 (80 triangles, edges about 1.3e-3), centres uniform in [-1, 1]^3;
/// as many spheres as bring the total within 40 of `tris` (at least one).
std::vector<Triangle> generate_multiscale(uint64_t tris, uint64_t seed, double outer);

}  // namespace sahbench
