#pragma once
// The flat sheet of square cells that the terrain and wave generators displace: its size for a
// triangle budget, where its vertices lie, and its triangles. Internal to scenes/.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/triangle.h"
#include "core/vec3.h"

namespace sahbench {

/// nx by nz square cells spanning x in [-1, 1], centred on z = 0; vertices row by row (x fastest),
/// nx + 1 to a row.
struct SurfaceGrid {
  std::size_t nx = 1, nz = 1;
  double cell = 2.0;  // side of a cell
  double z0 = -1.0;   // z of the first row

  std::size_t row() const { return nx + 1; }
  std::size_t vertex_count() const { return row() * (nz + 1); }
  double x(std::size_t vertex) const { return -1.0 + cell * static_cast<double>(vertex % row()); }
  double z(std::size_t vertex) const { return z0 + cell * static_cast<double>(vertex / row()); }
};

/// The grid with 2 nx nz ~ `tris` triangles and cells as square as whole numbers allow.
SurfaceGrid surface_grid(uint64_t tris);

/// Two triangles per cell of `grid`, from its displaced `vertices` (grid.vertex_count(), in grid order):
/// cell q's are triangles 2q and 2q + 1, in parallel.
std::vector<Triangle> triangulate(const SurfaceGrid& grid, std::span<const Vec3> vertices);

}  // namespace sahbench
