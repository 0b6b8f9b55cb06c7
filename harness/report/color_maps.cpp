#include "harness/report/color_maps.h"

#include <algorithm>
#include <cmath>
#include <span>

namespace sahbench {
namespace {

struct Stop {
  float t;
  float r, g, b;  // 0..255
};

// t outside [first.t, last.t] is clamped; NaN maps to the first stop.
Rgb8 interpolate(std::span<const Stop> stops, float t) {
  if (!(t > stops.front().t)) t = stops.front().t;
  t = std::min(t, stops.back().t);
  std::size_t i = 1;
  while (i + 1 < stops.size() && t > stops[i].t) ++i;
  const Stop& a = stops[i - 1];
  const Stop& b = stops[i];
  const float w = (t - a.t) / (b.t - a.t);
  auto mix = [w](float x, float y) { return static_cast<uint8_t>(std::lround(x + (y - x) * w)); };
  return {mix(a.r, b.r), mix(a.g, b.g), mix(a.b, b.b)};
}

// viridis at 0, 1/4, 1/2, 3/4, 1: #440154 #3b528b #21918c #5ec962 #fde725.
constexpr Stop kViridis[] = {{0.00f, 68, 1, 84},
                             {0.25f, 59, 82, 139},
                             {0.50f, 33, 145, 140},
                             {0.75f, 94, 201, 98},
                             {1.00f, 253, 231, 37}};

// Moreland 2009: the cool-warm end points and the grey at its centre (sRGB).
constexpr Stop kCoolWarm[] = {{-1.0f, 59, 76, 192}, {0.0f, 221, 221, 221}, {1.0f, 180, 4, 38}};

}  // namespace

Rgb8 sequential_color(float t) {
  return interpolate(kViridis, t);
}

Rgb8 diverging_color(float t) {
  return interpolate(kCoolWarm, t);
}

}  // namespace sahbench
