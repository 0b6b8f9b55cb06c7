#include "scenes/wave.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "scenes/rng.h"
#include "scenes/triangle_filter.h"

namespace sahbench {

namespace {

// Vertices per task: large enough that scheduling is negligible.
constexpr std::size_t kGrain = 4096;
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
  // Square cells, nx along x and nz along z, with 2 nx nz ~ tris (as the terrain generator).
  const auto nx = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::llround(std::sqrt(static_cast<double>(params.tris) / 2.0))));
  const auto nz =
      std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(static_cast<double>(params.tris) /
                                                                     (2.0 * static_cast<double>(nx)))));
  const double cell = 2.0 / static_cast<double>(nx);
  const double z0 = -0.5 * cell * static_cast<double>(nz);
  const std::vector<Wave> waves = draw_waves(params);

  const std::size_t row = nx + 1;
  std::vector<Vec3> grid(row * (nz + 1));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, grid.size(), kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t v = r.begin(); v != r.end(); ++v) {
                        const double x = -1.0 + cell * static_cast<double>(v % row);
                        const double z = z0 + cell * static_cast<double>(v / row);
                        // Gerstner: P = (x + sum q a dx cos th, sum a sin th, z + sum q a dz cos th), th = k
                        // d.x0 - omega t + phase.
                        double px = x, py = 0.0, pz = z;
                        for (const Wave& w : waves) {
                          const double theta = w.k * (w.dx * x + w.dz * z) - w.omega * t + w.phase;
                          const double c = std::cos(theta), s = std::sin(theta);
                          px += w.q * w.a * w.dx * c;
                          pz += w.q * w.a * w.dz * c;
                          py += w.a * s;
                        }
                        grid[v] = {to_float(px), to_float(py), to_float(pz)};
                      }
                    });

  std::vector<Triangle> out(2 * nx * nz);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nx * nz, kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t q = r.begin(); q != r.end(); ++q) {
                        const std::size_t i = q % nx, k = q / nx;
                        const Vec3 a = grid[k * row + i], b = grid[k * row + i + 1];
                        const Vec3 c = grid[(k + 1) * row + i], d = grid[(k + 1) * row + i + 1];
                        out[2 * q] = {a, c, d};
                        out[2 * q + 1] = {a, d, b};
                      }
                    });
  return out;
}

}  // namespace sahbench
