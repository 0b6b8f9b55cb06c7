#include "scenes/load.h"

#include <string>
#include <system_error>

#include "core/error.h"
#include "scenes/gltf_loader.h"
#include "scenes/obj_loader.h"
#include "scenes/ply_loader.h"
#include "scenes/procedural.h"

namespace sahbench {

namespace fs = std::filesystem;

namespace {

std::string describe_search_path() {
  const auto dirs = scene_search_path();
  std::string out;
  if (dirs.empty()) {
    out = "no scene directory exists; tried";
    for (const fs::path& c : scene_search_path_candidates()) out += " " + c.string();
    return out + " (set SAHBENCH_SCENE_PATH)";
  }
  out = "searched";
  for (const fs::path& d : dirs) out += " " + d.string();
  return out + " for NAME, NAME.{glb,gltf,obj,ply}, NAME/NAME.{gltf,glb,obj,ply} and NAME/scene.gltf";
}

}  // namespace

Scene load_scene_file(const fs::path& path) {
  const std::string ext = lower_extension(path);
  Scene scene;
  if (ext == ".gltf" || ext == ".glb")
    scene = load_gltf(path, ext == ".glb");
  else if (ext == ".obj")
    scene = load_obj(path);
  else if (ext == ".ply")
    scene = load_ply(path);
  else
    throw Error(path.string() + ": unsupported scene file extension '" + path.extension().string() +
                "' (supported: .gltf, .glb, .obj, .ply)");
  // The readers are lenient (tinyobjloader skips lines it cannot read), so a file that is not a scene at
  // all, or one cut off before its faces, would load as an empty scene and every figure of it be nothing.
  if (scene.triangles.empty() && scene.removed.total() > 0)
    throw Error(path.string() + ": no triangles left: all " + std::to_string(scene.removed.total()) +
                " were invalid (non-finite or degenerate) and removed");
  if (scene.triangles.empty())
    throw Error(path.string() +
                ": no triangles (a file of another format, cut off before its faces, or a "
                "scene without any)");
  scene.name = path.string();
  scene.source = path.string();
  return scene;
}

std::optional<fs::path> scene_file_of(std::string_view spec) {
  if (is_procedural_spec(spec)) return std::nullopt;
  fs::path path(spec);
  if (!path.has_filename()) path = path.parent_path();  // "dir/" names the folder "dir"
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) return path;
  // A scene folder given by path is resolved like a folder on the search path.
  if (fs::is_directory(path, ec))
    return find_scene_file_in(path.parent_path().empty() ? fs::path(".") : path.parent_path(),
                              path.filename().string());
  return find_scene_file(spec);
}

Scene load_scene(std::string_view spec) {
  if (spec.empty()) throw Error("empty scene name: expected a file, a shared scene name or proc:KIND");
  if (is_procedural_spec(spec)) return generate_procedural(spec);

  fs::path path(spec);
  if (!path.has_filename()) path = path.parent_path();  // "dir/" names the folder "dir"
  std::error_code ec;
  const std::optional<fs::path> file = scene_file_of(spec);
  if (!file && fs::is_directory(path, ec))
    throw Error(std::string(spec) +
                ": directory holds no scene file (NAME.{gltf,glb,obj,ply} or scene.gltf)");
  if (!file) {
    const bool path_like = spec.find('/') != std::string_view::npos || has_scene_extension(path);
    throw Error(std::string(spec) + ": " + (path_like ? "no such file" : "unknown scene") +
                ", and not a shared scene name (" + describe_search_path() + ")");
  }
  Scene scene = load_scene_file(*file);
  scene.name = std::string(spec);
  return scene;
}

}  // namespace sahbench
