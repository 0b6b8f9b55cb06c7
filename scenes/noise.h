#pragma once
// Two-dimensional gradient noise (Perlin, "Improving Noise", SIGGRAPH 2002: quintic fade and a fixed
// set of gradient directions), with lattice gradients chosen by hashing the lattice point and a seed
// instead of a permutation table, so any seed gives an independent, unbounded noise field.

#include <cmath>
#include <cstdint>

#include "scenes/rng.h"

namespace sahbench {

/// Gradient noise at (x, y): zero at lattice points, smooth (C2), roughly in [-1, 1].
inline double gradient_noise(double x, double y, uint64_t seed) {
  const double fx0 = std::floor(x), fy0 = std::floor(y);
  const auto ix = static_cast<int64_t>(fx0), iy = static_cast<int64_t>(fy0);
  const double dx = x - fx0, dy = y - fy0;

  // The eight directions of Perlin's 2D variant: axes and diagonals (unnormalised, as he uses them).
  auto dot_gradient = [seed](int64_t gx, int64_t gy, double px, double py) {
    const uint64_t h = mix64(mix64(seed) ^ (static_cast<uint64_t>(gx) * 0x9E3779B97F4A7C15ull) ^
                             (static_cast<uint64_t>(gy) * 0xC2B2AE3D27D4EB4Full));
    switch (h >> 61) {
      case 0:
        return px + py;
      case 1:
        return px - py;
      case 2:
        return -px + py;
      case 3:
        return -px - py;
      case 4:
        return px;
      case 5:
        return -px;
      case 6:
        return py;
      default:
        return -py;
    }
  };
  auto fade = [](double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); };
  auto lerp = [](double a, double b, double t) { return a + t * (b - a); };

  const double u = fade(dx), v = fade(dy);
  const double n00 = dot_gradient(ix, iy, dx, dy);
  const double n10 = dot_gradient(ix + 1, iy, dx - 1.0, dy);
  const double n01 = dot_gradient(ix, iy + 1, dx, dy - 1.0);
  const double n11 = dot_gradient(ix + 1, iy + 1, dx - 1.0, dy - 1.0);
  return lerp(lerp(n00, n10, u), lerp(n01, n11, u), v);
}

/// Fractal sum of `octaves` noise layers, each at twice the frequency and half the amplitude of the
/// previous one (fractional Brownian motion with lacunarity 2 and gain 1/2), each with its own seed.
inline double fractal_noise(double x, double y, uint64_t seed, int octaves) {
  double sum = 0.0, amplitude = 1.0, frequency = 1.0;
  for (int o = 0; o < octaves; ++o) {
    sum += amplitude * gradient_noise(x * frequency, y * frequency, seed + static_cast<uint64_t>(o));
    amplitude *= 0.5;
    frequency *= 2.0;
  }
  return sum;
}

}  // namespace sahbench
