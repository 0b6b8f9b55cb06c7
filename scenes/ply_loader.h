#pragma once
// PLY (Stanford polygon file format, Turk 1994) loader: ascii, binary_little_endian and
// binary_big_endian; positions from the `vertex` element and polygons from the `face` element.

#include <filesystem>

#include "scenes/scene.h"

namespace sahbench {

/// Reads x, y, z (any scalar type) of each `vertex` and the `vertex_indices` (or `vertex_index`) list of
/// each `face`, fan-triangulating polygons. Other properties and elements are skipped. Throws Error,
/// naming the file and what was expected, for a malformed header or a truncated body. Scene::name is
/// left empty; Scene::source is the path.
Scene load_ply(const std::filesystem::path& path);

}  // namespace sahbench
