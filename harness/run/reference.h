#pragma once
// The reference every cell of `sahbench run` is checked against (static and animation experiments):
// brute force on small scenes, Embree in robust mode on large ones, and the count of a cell's answers
// that differ from it (traversal/hit_compare.h says what counts as the same answer).

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/ray.h"
#include "core/triangle.h"
#include "harness/config/config.h"
#include "harness/run/ray_sets.h"
#include "scenes/scene.h"

namespace sahbench {

class ExactSettler;

/// The reference answers for one ray set: closest hits, or occlusion flags for any-hit sets. `name` is
/// the CSV's `reference` column: "brute_force", "embree_robust+exact", or "none" (no answers, no check).
struct Reference {
  std::string name = "none";
  std::vector<Hit> hits;
  std::vector<uint8_t> occluded;
  /// Above the brute-force limit: Embree's robust mode answers first, and where a cell disagrees with
  /// it the exact reference (traversal/exact_reference.h) settles the ray, so that a mismatch is a
  /// wrong answer, not a rounding of Embree's. Each settled ray is kept for the set's other cells.
  std::shared_ptr<ExactSettler> settler;
};

/// The answers of `policy` for `rs` on `scene`. kAuto is brute force up to `brute_force_max_triangles`
/// triangles and Embree robust above; kNone gives no answers. Runs in parallel with TBB under the
/// caller's thread limit (brute force), or on an Embree device of its own that is released before the
/// call returns. Brute force, which takes seconds on the larger scenes it is used for, calls
/// `between_chunks` (when given) after each chunk of kReferenceChunk rays, so that a run can stop there
/// on Ctrl-C (it throws).
inline constexpr std::size_t kReferenceChunk = 4096;
Reference make_reference(const Scene& scene, const RaySet& rs, ReferencePolicy policy,
                         uint64_t brute_force_max_triangles,
                         const std::function<void()>& between_chunks = {});

/// Which reference `policy` gives a scene of `triangles` triangles: kBruteForce, kEmbree or kNone.
ReferencePolicy resolved_reference(ReferencePolicy policy, std::size_t triangles,
                                   uint64_t brute_force_max_triangles);

/// The length of the diagonal of the box around `triangles` (1 when there are none): the scene's size,
/// from which count_mismatches derives each ray's tie tolerance.
float scene_diagonal(std::span<const Triangle> triangles);

/// Answers in `hits` (closest-hit sets) or `occluded` (any-hit sets) that differ from `ref`'s: a different
/// hit/miss answer, or a different primitive at a different distance (same_hit, with the tolerance scaled
/// by `scene_diagonal` in units of each ray's t). With a settler, each such answer counts only if it also
/// differs from the exact one (a miss where the exact segment meets a triangle, or the reverse; another
/// primitive than the exact closest ones at another distance).
uint64_t count_mismatches(const Reference& ref, const RaySet& rs, float scene_diagonal,
                          std::span<const Hit> hits, std::span<const uint8_t> occluded);

}  // namespace sahbench
