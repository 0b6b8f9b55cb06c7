#pragma once
// Loading a scene from what a user or config names: a procedural spec, a file, or a shared scene.

#include <filesystem>
#include <optional>
#include <string_view>

#include "scenes/scene.h"
#include "scenes/scene_path.h"

namespace sahbench {

/// Loads `spec`, which is one of
///  - a procedural spec "proc:KIND[:key=value,...]" (procedural.h),
///  - a path to a .gltf, .glb, .obj or .ply file (extension in any letter case),
///  - a shared-scene name, resolved with find_scene_file on the scene search path.
/// Scene::name is `spec`; Scene::source is the resolved file or the normalised procedural spec.
/// Throws Error for an unsupported extension, a missing file, an unknown name (listing the search path
/// tried), or a malformed file.
Scene load_scene(std::string_view spec);

/// The file load_scene reads for `spec` (a path, first as given, then a shared scene name on the search
/// path), or nullopt for a procedural spec or where there is none.
std::optional<std::filesystem::path> scene_file_of(std::string_view spec);

/// Loads one file, choosing the loader by its extension. Scene::name and Scene::source are the path.
Scene load_scene_file(const std::filesystem::path& path);

}  // namespace sahbench
