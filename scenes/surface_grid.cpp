#include "scenes/surface_grid.h"

#include <algorithm>
#include <cmath>

#include "scenes/parallel_index.h"

namespace sahbench {

SurfaceGrid surface_grid(uint64_t tris) {
  SurfaceGrid g;
  g.nx = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::llround(std::sqrt(static_cast<double>(tris) / 2.0))));
  g.nz = std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(static_cast<double>(tris) /
                                                                        (2.0 * static_cast<double>(g.nx)))));
  g.cell = 2.0 / static_cast<double>(g.nx);
  g.z0 = -0.5 * g.cell * static_cast<double>(g.nz);
  return g;
}

std::vector<Triangle> triangulate(const SurfaceGrid& grid, std::span<const Vec3> vertices) {
  const std::size_t nx = grid.nx, row = grid.row();
  std::vector<Triangle> out(2 * nx * grid.nz);
  parallel_for_each_index(nx * grid.nz, [&](std::size_t q) {
    const std::size_t i = q % nx, k = q / nx;
    const Vec3 a = vertices[k * row + i], b = vertices[k * row + i + 1];
    const Vec3 c = vertices[(k + 1) * row + i], d = vertices[(k + 1) * row + i + 1];
    out[2 * q] = {a, c, d};
    out[2 * q + 1] = {a, d, b};
  });
  return out;
}

}  // namespace sahbench
