#pragma once
// glTF 2.0 loader (.gltf with external or data-URI buffers, and binary .glb), via tinygltf.

#include <filesystem>

#include "scenes/scene.h"

namespace sahbench {

/// Reads only POSITION and indices of each mesh primitive. TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN
/// become triangles; points and lines are skipped. The default scene (else the first scene, else every
/// root node) is traversed and node transforms (matrix or TRS) are applied in double precision, so a
/// mesh used by several nodes is placed once per use. Skins, morph targets, materials and images are
/// ignored (missing image files do not fail the load); gltf_animation.h evaluates skins, morph targets
/// and animations over the same triangles. Every accessor and buffer view range is checked
/// against its buffer before it is read: a malformed file throws Error naming the file and the mesh or
/// accessor. `binary` selects GLB. Scene::name is left empty; Scene::source is the path.
Scene load_gltf(const std::filesystem::path& path, bool binary);

}  // namespace sahbench
