#pragma once
// The procedural deforming scene: a sheet over [-1, 1]^2 moved by a sum of Gerstner waves (Tessendorf
// 2001, "Simulating Ocean Water", section 3.3; Finch 2004, GPU Gems chapter 1). Vertices move up and
// down and, unlike a pure heightfield, also sideways, so boxes grow and shrink as in a skinned
// animation. The motion loops with period kWavePeriod; every wave completes a whole number of cycles.

#include <cstdint>
#include <vector>

#include "core/triangle.h"

namespace sahbench {

/// Seconds of one loop of the wave animation: frames are sampled in [0, kWavePeriod].
inline constexpr double kWavePeriod = 1.0;

struct WaveParams {
  uint64_t tris = 20000;   ///< target triangle count: an nx * nz grid with 2 nx nz within nx of it
  uint64_t seed = 1;       ///< draws each wave's direction, wavelength, speed and phase
  double amplitude = 0.1;  ///< height of a wave of wavelength 1 (shorter waves are proportionally lower)
  int waves = 4;           ///< number of Gerstner waves summed
};

/// The sheet's triangles at time `t` seconds (any real t; the pattern repeats every kWavePeriod).
/// Deterministic: the same parameters and t give bit-identical triangles for any thread count, and the
/// triangle order never changes with t.
std::vector<Triangle> generate_wave(const WaveParams& params, double t);

}  // namespace sahbench
