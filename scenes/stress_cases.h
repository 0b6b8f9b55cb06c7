#pragma once
// The stress suite's generated cases: scenes and rays built to break float ray tracing (closed meshes
// far from the origin and at extreme scales with rays aimed exactly at shared edges and vertices, +-0
// directions and rays in box face planes, grazing rays, huge and tiny coordinates together, degenerate
// and non-finite triangles, identical centroids, coincident triangles, needles, a tiny detail in a huge
// enclosure, rays starting on a surface, tmin = tmax). Each case is a pure function of its spec.
//
// Triangles enter the scene through the TriangleFilter (scenes/triangle_filter.h) like any loaded
// scene's, so invalid ones are removed and counted; a case says how many invalid triangles it made on
// purpose, so that the count can be checked.

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/ray.h"
#include "scenes/scene.h"

namespace sahbench {

/// One case of a stress config. `size` and the real parameters mean what the kind says (stress_kinds()).
struct StressCaseSpec {
  std::string name;
  std::string kind;
  uint64_t seed = 1;
  uint64_t size = 1000;  ///< about this many triangles (each kind says how it rounds)
  uint32_t rays = 2000;
  /// sphere, cube_grid, surface_origin: radius or half-size of the mesh; axis_thin: the triangles' reach
  double scale = 1.0;
  /// sphere, cube_grid: the mesh's centre is (offset, offset, offset); axis_thin: the rays' origin on
  /// their axis
  double offset = 0.0;
  double aspect = 1e4;  ///< needles: length / width
  double outer = 1e6;   ///< tiny_in_huge: half-size of the enclosing cube

  bool operator==(const StressCaseSpec&) const = default;
};

struct StressKindInfo {
  std::string_view name;
  std::string_view summary;
  /// The scene is made of closed watertight meshes and every ray is aimed into one or starts inside:
  /// the default variant (watertight triangle test, conservative box test) must not miss any ray.
  bool closed = false;
  /// Which of the real parameters (scale, offset, aspect, outer) the kind reads.
  std::vector<std::string_view> params;
};

struct StressCase {
  StressCaseSpec spec;
  bool closed = false;  ///< as the kind's StressKindInfo::closed
  Scene scene;          ///< valid triangles only; scene.removed counts the others
  std::vector<Ray> rays;
  /// 1 where the ray starts strictly inside a closed mesh or is aimed into one from outside, so that a
  /// miss is a leak through the mesh.
  std::vector<uint8_t> must_hit;
  /// Invalid triangles (zero area, non-finite) the generator made on purpose: the filter must remove
  /// exactly these.
  std::size_t invalid_made = 0;
};

/// The kinds, with what each generates and how it reads `size`.
std::span<const StressKindInfo> stress_kinds();

/// The kind called `name`; an unknown name is an error listing the known ones.
const StressKindInfo& find_stress_kind(std::string_view name);

/// Generates the case; deterministic from the spec (bit-identical rays and triangles on every run).
/// Throws Error for an unknown kind.
StressCase generate_stress_case(const StressCaseSpec& spec);

}  // namespace sahbench
