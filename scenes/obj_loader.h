#pragma once
// Wavefront OBJ loader (tinyobjloader's streaming parser): positions and faces only.

#include <filesystem>

#include "scenes/scene.h"

namespace sahbench {

/// Reads `v` and `f` lines; polygons are fan-triangulated; negative (relative) indices are resolved
/// against the vertices read so far. Materials are ignored: `mtllib` files are never opened, so a
/// missing .mtl does not fail the load. Lines, points, normals and texture coordinates are skipped.
/// Scene::name is left empty; Scene::source is the path.
Scene load_obj(const std::filesystem::path& path);

}  // namespace sahbench
