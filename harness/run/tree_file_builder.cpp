#include "harness/run/tree_file_builder.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <span>
#include <string>
#include <tuple>

#include "builders/registry.h"
#include "core/error.h"
#include "core/fnv1a.h"
#include "core/sah.h"
#include "scenes/tree_file.h"

namespace sahbench {
namespace {

constexpr const char* kBuilderName = "file";

const std::string& path_of(const ParamSet& p) {
  const std::string& path = p.get_path("path");
  if (path.empty())
    throw Error(std::string(kBuilderName) +
                ": parameter 'path' is required (file:path=TREE, or path = \"TREE\" "
                "in a config)");
  return path;
}

// The file's contents as FNV-1a 64 of its bytes, so that a run over a changed file is another run (its
// builder_params and fingerprint differ). Empty for a file that cannot be read: the header check, which
// runs next, says why. A config's runs resolve their parameters several times, so the hash is kept per
// path, size and modification time, and a file written over is hashed again.
std::string contents_hash(const std::string& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  const auto written = std::filesystem::last_write_time(path, ec);
  if (ec) return {};
  static std::mutex mutex;
  static std::map<std::string, std::tuple<std::uintmax_t, std::filesystem::file_time_type, std::string>>
      known;
  const std::lock_guard lock(mutex);
  if (const auto it = known.find(path);
      it != known.end() && std::get<0>(it->second) == size && std::get<1>(it->second) == written)
    return std::get<2>(it->second);
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  uint64_t hash = kFnv1aOffset;
  std::array<char, 1 << 16> buffer;
  while (in.read(buffer.data(), buffer.size()) || in.gcount() > 0)
    hash = fnv1a(std::string_view(buffer.data(), static_cast<std::size_t>(in.gcount())), hash);
  known[path] = {size, written, hash_text(hash)};
  return hash_text(hash);
}

// The tree of the file the run was resolved with: one written over since then (its rows would carry the
// old file's hash) is an error, not another tree measured under that name.
Bvh load_resolved(const ParamSet& p, std::span<const Triangle> triangles) {
  const std::string& path = path_of(p);
  const std::string& resolved = p.get_path_identity("path");
  if (const std::string now = contents_hash(path); !resolved.empty() && now != resolved)
    throw Error(path + ": the tree file changed since the run was planned (its hash was " + resolved +
                ", it is " + (now.empty() ? std::string("unreadable") : now) +
                "); rerun to measure the new tree as a run of its own");
  return load_tree_file(path, triangles);
}

}  // namespace

void register_tree_file_builder() {
  for (const auto& b : builders())
    if (b.name == kBuilderName) return;
  const SahCost defaults;
  register_builder(
      {kBuilderName,
       "a tree read from a tree file (docs/tree_format.md, `sahbench build --save`), checked against the "
       "scene and validated; its build time is reading and checking the file",
       {path_param("path",
                   "the tree file: in a config relative to the config's folder, on the command line to the "
                   "current one; recorded by its name, with the hash of its bytes as path_hash",
                   contents_hash),
        {"c_trav", ParamType::kFloat, defaults.c_trav, 0, 1e6, "SAH cost of visiting an inner node"},
        {"c_isect", ParamType::kFloat, defaults.c_isect, 1e-6, 1e6, "SAH cost of one ray/triangle test"}},
       [](const BuildInput& input, const ParamSet& p) { return load_resolved(p, input.triangles); },
       // The header when the run is resolved: a missing or foreign file fails as the config is read.
       [](const ParamSet& p) { read_tree_file_header(path_of(p)); },
       [](const ParamSet& p) { return read_tree_file_header(path_of(p)).arity; }});
}

namespace {

// The file builder's tree at `name` with `params`, and those of the sources below it (a pass over a
// tree file), checked against the scene.
void check_files_below(const std::string& name, const ParamSet& params, std::span<const Triangle> triangles) {
  if (name == kBuilderName) {
    const std::string& path = path_of(params);
    const TreeFileHeader header = read_tree_file_header(path);
    check_tree_file_scene(header.scene_hash, header.triangle_count, path, triangles);
  }
  for (const SourceSpec* source : params.own_sources())
    check_files_below(source->name(), *source->params, triangles);
}

}  // namespace

void check_tree_file_fits(const BuilderRun& run, std::span<const Triangle> triangles) {
  if (!run.is_embree()) check_files_below(run.name, run.values, triangles);
}

}  // namespace sahbench
