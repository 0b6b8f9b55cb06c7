#include "scenes/wave.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "scenes/parallel_index.h"
#include "scenes/rng.h"
#include "scenes/surface_grid.h"
#include "scenes/triangle_filter.h"

namespace sahbench {

namespace {

// Wavelengths drawn in this range (the sheet is 2 wide): several crests across it, none finer than the
// grid of a small scene can show.
constexpr double kMinWavelength = 0.25, kMaxWavelength = 1.0;
// Cycles of each wave per period: a whole number, so the animation loops.
constexpr int kMaxCycles = 3;
// Gerstner steepness Q in [0, 1]; at 1 the crests form cusps, above it the surface loops through itself
// (Finch 2004, section 1.2.2). 0.8 gives sharp crests and strong sideways motion without loops.
constexpr double kSteepness = 0.8;
// Item numbers of the per-wave draws, far from any other generator's items.
constexpr uint64_t kWaveItemBase = ~uint64_t{0} - 1024;

struct Wave {
  double dx, dz;  // unit direction of travel in the xz plane
  double k;       // wave number 2 pi / wavelength
  double a;       // amplitude
  double q;       // sideways displacement factor Q / (k a waves)
  double omega;   // angular frequency, 2 pi cycles / period
  double phase;
};

std::vector<Wave> draw_waves(const WaveParams& p) {
  std::vector<Wave> waves;
  for (int i = 0; i < p.waves; ++i) {
    SplitMix64 rng = SplitMix64::for_item(p.seed, kWaveItemBase + static_cast<uint64_t>(i));
    const double angle = rng.uniform(0.0, 2.0 * std::numbers::pi);
    const double wavelength = rng.uniform(kMinWavelength, kMaxWavelength);
    const int cycles = 1 + static_cast<int>(rng.uniform() * kMaxCycles);
    Wave w;
    w.dx = std::cos(angle), w.dz = std::sin(angle);
    w.k = 2.0 * std::numbers::pi / wavelength;
    w.a = p.amplitude * wavelength;
    w.q = w.a > 0.0 ? kSteepness / (w.k * w.a * p.waves) : 0.0;
    w.omega = 2.0 * std::numbers::pi * cycles / kWavePeriod;
    w.phase = rng.uniform(0.0, 2.0 * std::numbers::pi);
    waves.push_back(w);
  }
  return waves;
}

}  // namespace

std::vector<Triangle> generate_wave(const WaveParams& params, double t) {
  // The terrain generator's sheet (surface_grid), displaced by the waves.
  const SurfaceGrid grid = surface_grid(params.tris);
  const std::vector<Wave> waves = draw_waves(params);

  std::vector<Vec3> vertices(grid.vertex_count());
  parallel_for_each_index(vertices.size(), [&](std::size_t v) {
    const double x = grid.x(v), z = grid.z(v);
    // Gerstner: P = (x + sum q a dx cos th, sum a sin th, z + sum q a dz cos th), th = k d.x0 - omega t
    // + phase.
    double px = x, py = 0.0, pz = z;
    for (const Wave& w : waves) {
      const double theta = w.k * (w.dx * x + w.dz * z) - w.omega * t + w.phase;
      const double c = std::cos(theta), s = std::sin(theta);
      px += w.q * w.a * w.dx * c;
      pz += w.q * w.a * w.dz * c;
      py += w.a * s;
    }
    vertices[v] = {to_float(px), to_float(py), to_float(pz)};
  });
  return triangulate(grid, vertices);
}

}  // namespace sahbench
