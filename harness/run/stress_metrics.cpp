#include "harness/run/stress_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "traversal/ulp_distance.h"

namespace sahbench {
namespace {

constexpr uint32_t kSaturatedUlps = std::numeric_limits<uint32_t>::max();

}  // namespace

ErrorMetrics measure_errors(std::span<const Hit> hits, std::span<const ExactHit> exact,
                            std::span<const uint8_t> must_hit) {
  if (hits.size() != exact.size() || (!must_hit.empty() && must_hit.size() != hits.size()))
    throw Error("measure_errors: " + std::to_string(hits.size()) + " hits, " + std::to_string(exact.size()) +
                " exact hits and " + std::to_string(must_hit.size()) + " must-hit flags differ in number");
  ErrorMetrics m;
  m.rays = hits.size();
  uint64_t measured = 0;
  double ulps_sum = 0.0;
  for (std::size_t i = 0; i < hits.size(); ++i) {
    const Hit& h = hits[i];
    const ExactHit& e = exact[i];
    m.exact_hits += e.found();
    m.ties += e.tied.size() > 1;
    if (e.found() && !h.found()) {
      ++m.false_misses;
      if (!must_hit.empty() && must_hit[i]) ++m.leaks;
    } else if (!e.found() && h.found()) {
      ++m.false_hits;
    } else if (e.found()) {
      if (!e.accepts(h.prim)) {
        ++m.wrong_prim;
        const double gap = std::abs(static_cast<double>(h.t) - static_cast<double>(e.t));
        m.wrong_prim_far += !(gap <= kFarRelative * std::max(std::abs(static_cast<double>(e.t)),
                                                             std::abs(static_cast<double>(h.t))));
        continue;
      }
      const uint32_t ulps = ulp_distance(h.t, e.t);
      m.t_err_ulps_max = std::max<uint64_t>(m.t_err_ulps_max, ulps);
      // An infinite t against a finite one (ulp_distance saturates) would swamp the mean: max only.
      if (ulps == kSaturatedUlps) continue;
      ulps_sum += ulps;
      ++measured;
    }
  }
  m.t_err_ulps_mean = measured ? ulps_sum / static_cast<double>(measured) : 0.0;
  return m;
}

}  // namespace sahbench
