#include "scenes/scene_path.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdlib>
#include <map>
#include <system_error>

namespace sahbench {

namespace fs = std::filesystem;

namespace {

constexpr std::array<std::string_view, 4> kTopLevelExtensions{".glb", ".gltf", ".obj", ".ply"};
constexpr std::array<std::string_view, 4> kFolderExtensions{".gltf", ".glb", ".obj", ".ply"};

bool is_file(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

bool is_dir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

// A folder whose scene file is NAME.{gltf,glb,obj,ply} or scene.gltf.
std::optional<fs::path> find_in_folder(const fs::path& folder, std::string_view name) {
  for (std::string_view ext : kFolderExtensions) {
    fs::path p = folder / (std::string(name) + std::string(ext));
    if (is_file(p)) return p;
  }
  fs::path p = folder / "scene.gltf";
  if (is_file(p)) return p;
  return std::nullopt;
}

}  // namespace

std::string lower_extension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

bool has_scene_extension(const fs::path& path) {
  const std::string ext = lower_extension(path);
  return std::find(kTopLevelExtensions.begin(), kTopLevelExtensions.end(), ext) != kTopLevelExtensions.end();
}

std::vector<fs::path> scene_search_path_candidates() {
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("SAHBENCH_SCENE_PATH")) {
    std::string_view rest(env);
    while (!rest.empty()) {
      const std::size_t colon = rest.find(':');
      const std::string_view entry = rest.substr(0, colon);
      if (!entry.empty()) candidates.emplace_back(entry);
      if (colon == std::string_view::npos) break;
      rest.remove_prefix(colon + 1);
    }
  }
  std::error_code ec;
  const fs::path cwd = fs::current_path(ec);
  if (!ec) candidates.push_back(cwd / ".." / "shared" / "scenes");
  candidates.push_back(fs::path(SAHBENCH_SOURCE_DIR) / ".." / "shared" / "scenes");
  return candidates;
}

std::vector<fs::path> scene_search_path() {
  std::vector<fs::path> dirs;
  for (const fs::path& candidate : scene_search_path_candidates()) {
    if (!is_dir(candidate)) continue;
    std::error_code ec;
    fs::path canonical = fs::canonical(candidate, ec);
    if (ec) continue;
    if (std::find(dirs.begin(), dirs.end(), canonical) == dirs.end()) dirs.push_back(std::move(canonical));
  }
  return dirs;
}

std::optional<fs::path> find_scene_file_in(const fs::path& dir, std::string_view name) {
  if (name.empty()) return std::nullopt;
  const std::string n(name);
  if (is_file(dir / n)) return dir / n;
  for (std::string_view ext : kTopLevelExtensions) {
    fs::path p = dir / (n + std::string(ext));
    if (is_file(p)) return p;
  }
  if (is_dir(dir / n)) return find_in_folder(dir / n, name);
  return std::nullopt;
}

std::optional<fs::path> find_scene_file(std::string_view name) {
  for (const fs::path& dir : scene_search_path())
    if (auto p = find_scene_file_in(dir, name)) return p;
  return std::nullopt;
}

std::vector<SharedSceneEntry> list_shared_scenes() {
  std::map<std::string, fs::path> found;  // sorted by name; the first directory wins
  for (const fs::path& dir : scene_search_path()) {
    std::error_code ec;
    for (const fs::directory_entry& entry : fs::directory_iterator(dir, ec)) {
      const fs::path& p = entry.path();
      std::string name;
      if (is_file(p) && has_scene_extension(p)) {
        // find_scene_file tries lower-case extensions only; a file with another case is found by its
        // full name.
        name = p.extension().string() == lower_extension(p) ? p.stem().string() : p.filename().string();
      } else if (is_dir(p) && find_in_folder(p, p.filename().string())) {
        name = p.filename().string();
      } else {
        continue;
      }
      if (found.contains(name)) continue;
      if (auto resolved = find_scene_file(name)) found.emplace(name, *resolved);
    }
  }
  std::vector<SharedSceneEntry> entries;
  for (auto& [name, path] : found) entries.push_back({name, path});
  return entries;
}

}  // namespace sahbench
