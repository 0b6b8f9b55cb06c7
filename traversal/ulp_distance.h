#pragma once
// Distance between two floats in units in the last place, the usual measure of a float result's error
// against the correctly rounded one.

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

namespace sahbench {

/// The number of representable floats between `a` and `b`, counting one end: 0 when equal (+0 and -0
/// are equal), 1 for neighbours. Saturates at UINT32_MAX when either is NaN or exactly one is infinite.
inline uint32_t ulp_distance(float a, float b) {
  constexpr uint32_t kSaturated = std::numeric_limits<uint32_t>::max();
  if (std::isnan(a) || std::isnan(b)) return kSaturated;
  if (a == b) return 0;
  if (std::isinf(a) || std::isinf(b)) return kSaturated;
  // Sign-magnitude bits to a monotonic integer line (negative floats below -0, +0 and -0 both at 0).
  auto ordered = [](float f) {
    const auto bits = static_cast<int64_t>(std::bit_cast<uint32_t>(f) & 0x7FFFFFFFu);
    return std::signbit(f) ? -bits : bits;
  };
  const int64_t d = ordered(a) - ordered(b);
  return static_cast<uint32_t>(d < 0 ? -d : d);
}

}  // namespace sahbench
