#pragma once
// Finding shared scenes by name: the scene search path (DESIGN.md, "Shared scenes").

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace sahbench {

/// The directories searched for shared scenes, in order: each entry of the colon-separated environment
/// variable SAHBENCH_SCENE_PATH, then ../shared/scenes relative to the current directory, then
/// shared/scenes beside the source tree. Entries that are not existing directories are skipped;
/// the rest are canonical and without duplicates.
std::vector<std::filesystem::path> scene_search_path();

/// The candidate directories before filtering (for error messages that say where we looked).
std::vector<std::filesystem::path> scene_search_path_candidates();

/// The first existing file, trying in each search directory in turn: NAME (if it is a file),
/// NAME.{glb,gltf,obj,ply}, NAME/NAME.{gltf,glb,obj,ply}, NAME/scene.gltf.
std::optional<std::filesystem::path> find_scene_file(std::string_view name);

/// The same candidates as find_scene_file, within the single directory `dir`.
std::optional<std::filesystem::path> find_scene_file_in(const std::filesystem::path& dir,
                                                        std::string_view name);

struct SharedSceneEntry {
  std::string name;            ///< what load_scene accepts, e.g. "stanford_bunny" or "FlightHelmet"
  std::filesystem::path path;  ///< the file that name resolves to

  friend bool operator==(const SharedSceneEntry&, const SharedSceneEntry&) = default;
};

/// Every scene in the search directories, sorted by name: top-level files with a supported extension
/// (named by their stem) and subfolders holding NAME.{gltf,glb,obj,ply} or scene.gltf (named by the
/// folder). A name found in several directories is listed once, with the file find_scene_file returns.
std::vector<SharedSceneEntry> list_shared_scenes();

/// True if `path` ends in .gltf, .glb, .obj or .ply, in any letter case.
bool has_scene_extension(const std::filesystem::path& path);

/// The extension in lower case, including the dot (".glb"), or empty.
std::string lower_extension(const std::filesystem::path& path);

}  // namespace sahbench
