#pragma once
// Error metrics of one traversal variant on one stress case, against the exact reference
// (traversal/exact_reference.h): the columns the stress suite writes next to the variant's rays/second.

#include <cstdint>
#include <span>

#include "core/ray.h"
#include "traversal/exact_reference.h"

namespace sahbench {

struct ErrorMetrics {
  uint64_t rays = 0;
  uint64_t exact_hits = 0;    ///< rays the exact reference says hit
  uint64_t false_misses = 0;  ///< the exact ray hits, the variant reports a miss
  uint64_t false_hits = 0;    ///< the exact ray misses, the variant reports a hit
  /// Both hit, but the variant's primitive is not among those hit at the exact closest distance (a
  /// tie accepts any of its primitives, so a tie is never a wrong primitive).
  uint64_t wrong_prim = 0;
  uint64_t ties = 0;          ///< rays whose exact closest hit is a tie of several primitives
  /// |t - exact t| in ulps (ulp_distance to the correctly rounded exact t), over the rays where the
  /// variant's primitive is accepted.
  uint64_t t_err_ulps_max = 0;
  double t_err_ulps_mean = 0.0;
  /// Rays that must hit (from inside a closed mesh, or aimed into one from outside; the exact
  /// reference agreeing) and that the variant misses.
  uint64_t leaks = 0;

  uint64_t errors() const { return false_misses + false_hits + wrong_prim; }
};

/// Compares a variant's closest hits with the exact ones. `must_hit` (same size, or empty) flags the
/// rays that count as leaks when missed.
ErrorMetrics measure_errors(std::span<const Hit> hits, std::span<const ExactHit> exact,
                            std::span<const uint8_t> must_hit);

}  // namespace sahbench
