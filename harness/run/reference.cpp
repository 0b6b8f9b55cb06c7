#include "harness/run/reference.h"

#include <tbb/parallel_for.h>

#include <map>
#include <mutex>

#include "core/aabb.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "traversal/brute_force.h"
#include "traversal/exact_reference.h"
#include "traversal/hit_compare.h"

namespace sahbench {

// The exact answers of one ray set's disagreements: the CGAL reference is built on the first (most cells
// agree with Embree on every ray, and building it costs a pass over the scene), and each ray settled once
// for every cell that disagrees on it. It keeps its own copy of the triangles, since a reference outlives
// the scene value it was made from where frames are moved or copied (animation_runner.cpp).
class ExactSettler {
 public:
  explicit ExactSettler(std::span<const Triangle> triangles)
      : triangles_(triangles.begin(), triangles.end()) {}

  /// The exact closest hits of `rays[i]` for each i of `indices`, computed in parallel where not known.
  std::vector<ExactHit> settle(std::span<const Ray> rays, std::span<const std::size_t> indices) {
    std::vector<ExactHit> out(indices.size());
    std::vector<std::size_t> unknown;
    {
      const std::lock_guard lock(mutex_);
      if (!exact_) exact_ = std::make_unique<ExactReference>(triangles_);
      for (std::size_t k = 0; k < indices.size(); ++k) {
        const auto it = known_.find(indices[k]);
        if (it != known_.end())
          out[k] = it->second;
        else
          unknown.push_back(k);
      }
    }
    tbb::parallel_for(std::size_t{0}, unknown.size(), [&](std::size_t u) {
      const std::size_t k = unknown[u];
      out[k] = exact_->closest(rays[indices[k]]);
    });
    const std::lock_guard lock(mutex_);
    for (const std::size_t k : unknown) known_.emplace(indices[k], out[k]);
    return out;
  }

 private:
  std::vector<Triangle> triangles_;
  std::mutex mutex_;
  std::unique_ptr<ExactReference> exact_;
  std::map<std::size_t, ExactHit> known_;
};

ReferencePolicy resolved_reference(ReferencePolicy policy, std::size_t triangles,
                                   uint64_t brute_force_max_triangles) {
  if (policy != ReferencePolicy::kAuto) return policy;
  return triangles <= brute_force_max_triangles ? ReferencePolicy::kBruteForce : ReferencePolicy::kEmbree;
}

Reference make_reference(const Scene& scene, const RaySet& rs, ReferencePolicy policy,
                         uint64_t brute_force_max_triangles, const std::function<void()>& between_chunks) {
  policy = resolved_reference(policy, scene.triangles.size(), brute_force_max_triangles);
  Reference ref;
  const std::size_t n = rs.rays.size();
  if (policy == ReferencePolicy::kBruteForce) {
    ref.name = "brute_force";
    if (rs.occlusion)
      ref.occluded.resize(n);
    else
      ref.hits.resize(n);
    for (std::size_t begin = 0; begin < n; begin += kReferenceChunk) {
      tbb::parallel_for(begin, std::min(n, begin + kReferenceChunk), [&](std::size_t i) {
        if (rs.occlusion)
          ref.occluded[i] = brute_force_any(scene.triangles, rs.rays[i]);
        else
          ref.hits[i] = brute_force_closest(scene.triangles, rs.rays[i]);
      });
      if (between_chunks) between_chunks();
    }
  } else if (policy == ReferencePolicy::kEmbree) {
    // Embree in robust mode, so that its own edge cases do not count as our mismatches, and the exact
    // reference where a cell disagrees with it, so that its roundings do not either.
    ref.name = "embree_robust+exact";
    ref.settler = std::make_shared<ExactSettler>(scene.triangles);
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
  std::vector<std::size_t> differ;
  if (!ref.hits.empty())
    for (std::size_t i = 0; i < hits.size(); ++i)
      if (!same_hit(hits[i], ref.hits[i], scene_diagonal / length(rs.rays[i].dir))) differ.push_back(i);
  if (!ref.occluded.empty())
    for (std::size_t i = 0; i < occluded.size(); ++i)
      if ((occluded[i] != 0) != (ref.occluded[i] != 0)) differ.push_back(i);
  if (differ.empty() || !ref.settler) return differ.size();

  const std::vector<ExactHit> exact = ref.settler->settle(rs.rays, differ);
  uint64_t wrong = 0;
  for (std::size_t k = 0; k < differ.size(); ++k) {
    const std::size_t i = differ[k];
    const ExactHit& truth = exact[k];
    if (!ref.occluded.empty()) {
      wrong += (occluded[i] != 0) != truth.found();
      continue;
    }
    const Hit& ours = hits[i];
    // One of the primitives at the exact closest distance, or another at that distance within the
    // tie tolerance (same_hit's rule, against the exact distance).
    const Hit closest{truth.prim(), truth.t};
    const bool right =
        ours.found() == truth.found() && (!ours.found() || truth.accepts(ours.prim) ||
                                          same_hit(ours, closest, scene_diagonal / length(rs.rays[i].dir)));
    wrong += !right;
  }
  return wrong;
}

}  // namespace sahbench
