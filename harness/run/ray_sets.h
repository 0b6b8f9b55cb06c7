#pragma once
// Ray sets, generated once per scene from a seed and given unchanged to every builder, layout and to
// Embree (DESIGN.md). Each ray is a pure function of (seed, set, index), so generation runs in parallel
// and gives the same rays for any thread count.
//
// Primary rays come in tiles of 4 x 4 pixels (primary_pixel_order) from the scene's camera (glTF) when it has
// one, else from the automatic framing: a pinhole camera with a 45-degree vertical field of view, looking at
// the centre of the scene's box from the direction (1, 0.6, 1.4) (above and to the side, y up), at the
// distance where the box's bounding sphere fills the view. Secondary rays (shadow, diffuse, ambient
// occlusion) start at the primary hits, found by a reference tree (binned SAH, watertight test), and are
// offset from the surface as in Waechter and Binder 2019, "A Fast and Robust Method for Avoiding
// Self-Intersection" (Ray Tracing Gems, chapter 6).

#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/bvh.h"
#include "core/ray.h"
#include "core/triangle.h"
#include "harness/config/config.h"
#include "scenes/camera.h"
#include "scenes/scene.h"

namespace sahbench {

struct RaySet {
  std::string name = {};
  RayKind kind = RayKind::kPrimary;
  bool occlusion = false;  ///< any-hit query (shadow, ambient occlusion) rather than closest hit
  std::vector<Ray> rays = {};
  /// What a reader of the set's figures should know about its rays (a shadow set's lights enclosed by
  /// the scene), for the rows' notes and the run's log; empty when nothing.
  std::string note = {};
};

struct GeneratedRaySets {
  std::vector<RaySet> sets;
  std::vector<std::pair<std::string, std::string>> skipped;  ///< (set name, reason)
};

/// Generates every configured set for `scene`. A set that does not apply (a shadow set asking for the
/// scene's own lights when it has none; secondary rays when no primary ray hits) is skipped with a
/// reason rather than generated empty.
GeneratedRaySets generate_ray_sets(const Scene& scene, std::span<const RaySetConfig> configs, uint64_t seed);

/// The pixel (y * width + x) of each primary ray, in the order the rays are made: tiles of 4 x 4 pixels,
/// tile rows top to bottom and tiles left to right along a row, each tile's pixels row by row (the part
/// of a tile that the image has, at its right and bottom edges). Where the width and height are multiples
/// of 4, the rays of a 16-ray packet are one tile and those of an 8-ray packet half of one (4 x 2); elsewhere
/// packets past the first partial tile straddle two tiles. So renderers feed Embree's rtcIntersect8/16
/// (its tutorials trace 4 x 4 and 4 x 2 blocks of a tile); the secondary sets follow, ray by ray.
std::vector<uint32_t> primary_pixel_order(uint32_t width, uint32_t height);

/// Where a secondary ray leaving the surface point `p` with unit normal `n` starts: p moved off the
/// surface along n (Waechter and Binder 2019, "A Fast and Robust Method for Avoiding Self-Intersection").
Vec3 offset_ray_origin(Vec3 p, Vec3 n);

/// The automatic point lights: `count` points in the top tenth of the scene box, spread over its middle
/// 80% horizontally (y up), deterministic from the seed.
std::vector<Vec3> automatic_lights(const Scene& scene, uint32_t count, uint64_t seed);

/// Rays cast from a light to tell whether the scene encloses it.
inline constexpr uint32_t kEnclosureProbes = 64;

/// Whether every one of kEnclosureProbes rays from `p`, in directions spread evenly over the sphere (a
/// Fibonacci lattice: González 2010, "Measurement of areas on a sphere using Fibonacci and
/// latitude-longitude lattices"), hits a triangle of `bvh`. A light there lights only the inside of a
/// closed surface (a model's hull, a lamp's shade): nearly every shadow ray to it is occluded near the
/// light, which measures that enclosure rather than the scene's shadows. Automatic lights land there in
/// closed models, whose box's top tenth lies inside them.
bool enclosed(const Bvh& bvh, std::span<const Triangle> triangles, Vec3 p);

}  // namespace sahbench
