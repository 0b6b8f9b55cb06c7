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

bool is_clear_of_origin(const Ray& ray, float t) {
  auto length = [](Vec3 v) {
    return std::hypot(static_cast<double>(v.x), static_cast<double>(v.y), static_cast<double>(v.z));
  };
  return t > 0.0f && static_cast<double>(t) * length(ray.dir) >= 0x1p-20 * length(ray.org);
}

ErrorMetrics measure_errors(std::span<const Hit> hits, std::span<const ExactHit> exact,
                            std::span<const uint8_t> must_hit, std::span<const Ray> rays) {
  if (hits.size() != exact.size() || (!must_hit.empty() && must_hit.size() != hits.size()) ||
      (!rays.empty() && rays.size() != hits.size()))
    throw Error("measure_errors: " + std::to_string(hits.size()) + " hits, " + std::to_string(exact.size()) +
                " exact hits, " + std::to_string(must_hit.size()) + " must-hit flags and " +
                std::to_string(rays.size()) + " rays differ in number");
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
      if (!rays.empty() && is_clear_of_origin(rays[i], e.t))
        m.t_err_ulps_max_clear = std::max<uint64_t>(m.t_err_ulps_max_clear, ulps);
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
