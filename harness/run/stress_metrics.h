#pragma once
// Error metrics of one traversal variant on one stress case, against the exact reference
// (traversal/exact_reference.h): the columns the stress suite writes next to the variant's rays/second.

#include <cstdint>
#include <span>

#include "core/ray.h"
#include "traversal/exact_reference.h"

namespace sahbench {

/// Relative difference in t beyond which a wrong primitive is "far": 1e-5, the harness's tie tolerance
/// (traversal/hit_compare.h), far above the rounding of a triangle test and below any real gap.
inline constexpr double kFarRelative = 1e-5;

struct ErrorMetrics {
  uint64_t rays = 0;
  uint64_t exact_hits = 0;    ///< rays the exact reference says hit
  uint64_t false_misses = 0;  ///< the exact ray hits, the variant reports a miss
  uint64_t false_hits = 0;    ///< the exact ray misses, the variant reports a hit
  /// Both hit, but the variant's primitive is not among those hit at the exact closest distance (a
  /// tie accepts any of its primitives, so a tie is never a wrong primitive).
  uint64_t wrong_prim = 0;
  /// The part of wrong_prim whose distance also differs from the exact one by more than
  /// kFarRelative: the variant went past the closest surface (or stopped at one that is farther
  /// off), rather than choosing the neighbour across an edge within rounding of the exact point.
  uint64_t wrong_prim_far = 0;
  uint64_t ties = 0;  ///< rays whose exact closest hit is a tie of several primitives
  /// |t - exact t| in ulps (ulp_distance to the correctly rounded exact t), over the rays where the
  /// variant's primitive is accepted; the max is UINT32_MAX where a t is infinite and the exact one is
  /// not, and the mean leaves those out. Near t = 0 (a ray starting on a surface) ulps are tiny, so
  /// small absolute errors there are huge in ulps.
  uint64_t t_err_ulps_max = 0;
  double t_err_ulps_mean = 0.0;
  /// t_err_ulps_max over the hits clear of the ray's origin (is_clear_of_origin): the well-conditioned
  /// distances, on which the default kernels' bound (kMaxClearTErrorUlps) holds.
  uint64_t t_err_ulps_max_clear = 0;
  /// Rays that must hit (from inside a closed mesh, or aimed into one from outside; the exact
  /// reference agreeing) and that the variant misses.
  uint64_t leaks = 0;

  uint64_t errors() const { return false_misses + false_hits + wrong_prim; }
};

/// The bound on the default kernels' t error, in ulps, on hits clear of the origin: the watertight test
/// computes a hit's distance in double and rounds it once (traversal/triangle_tests.h:
/// plane_distance_in_double), so it is within one ulp of the exact distance unless the ray grazes the
/// plane within about 1e-7 rad. The stress suite fails a run where it does not hold.
inline constexpr uint64_t kMaxClearTErrorUlps = 1;

/// Whether a hit at exact distance `t` is clear of the ray's origin: t |dir| at least 2^-20 |org|. Closer
/// than that the origin lies on the surface to within a few float roundings of its own coordinates (a
/// ray starting on a surface), the exact t is tiny or zero, and an error in ulps of it says nothing.
bool is_clear_of_origin(const Ray& ray, float t);

/// Compares a variant's closest hits with the exact ones. `must_hit` (same size, or empty) flags the
/// rays that count as leaks when missed; `rays` (same size, or empty) are the rays traced, for
/// t_err_ulps_max_clear (0 without them).
ErrorMetrics measure_errors(std::span<const Hit> hits, std::span<const ExactHit> exact,
                            std::span<const uint8_t> must_hit, std::span<const Ray> rays = {});

}  // namespace sahbench
