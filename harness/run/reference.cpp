#include "harness/run/reference.h"

#include <tbb/parallel_for.h>

#include "core/aabb.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "traversal/brute_force.h"
#include "traversal/hit_compare.h"

namespace sahbench {

Reference make_reference(const Scene& scene, const RaySet& rs, ReferencePolicy policy,
                         uint64_t brute_force_max_triangles) {
  if (policy == ReferencePolicy::kAuto)
    policy = scene.triangles.size() <= brute_force_max_triangles ? ReferencePolicy::kBruteForce
                                                                 : ReferencePolicy::kEmbree;
  Reference ref;
  const std::size_t n = rs.rays.size();
  if (policy == ReferencePolicy::kBruteForce) {
    ref.name = "brute_force";
    if (rs.occlusion) {
      ref.occluded.resize(n);
      tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
        ref.occluded[i] = brute_force_any(scene.triangles, rs.rays[i]);
      });
    } else {
      ref.hits.resize(n);
      tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
        ref.hits[i] = brute_force_closest(scene.triangles, rs.rays[i]);
      });
    }
  } else if (policy == ReferencePolicy::kEmbree) {
    // Embree in robust mode, so that its own edge cases do not count as our mismatches.
    ref.name = "embree_robust";
    check_embree_range(rs.rays, "ray set '" + rs.name + "' (reference = embree)");
    // A device of its own, released before any timed cell: Embree turns a device's thread count into
    // a process-wide TBB limit, and a live unlimited device would lift the limit of the timed cells.
    EmbreeDevice device(0);
    EmbreeSceneOptions options;
    options.robust = true;
    const EmbreeScene reference_scene(device, scene.triangles, EmbreeQuality::kMedium, options);
    if (rs.occlusion) {
      ref.occluded.resize(n);
      embree_occluded1(reference_scene, rs.rays, ref.occluded);
    } else {
      ref.hits.resize(n);
      embree_intersect1(reference_scene, rs.rays, ref.hits);
    }
  }
  return ref;
}

float scene_diagonal(std::span<const Triangle> triangles) {
  Aabb box;
  for (const auto& t : triangles) box.extend(t.bounds());
  return box.is_empty() ? 1.0f : length(box.extent());
}

uint64_t count_mismatches(const Reference& ref, const RaySet& rs, float scene_diagonal,
                          std::span<const Hit> hits, std::span<const uint8_t> occluded) {
  uint64_t m = 0;
  if (!ref.hits.empty())
    for (std::size_t i = 0; i < hits.size(); ++i)
      m += !same_hit(hits[i], ref.hits[i], scene_diagonal / length(rs.rays[i].dir));
  if (!ref.occluded.empty())
    for (std::size_t i = 0; i < occluded.size(); ++i) m += (occluded[i] != 0) != (ref.occluded[i] != 0);
  return m;
}

}  // namespace sahbench
