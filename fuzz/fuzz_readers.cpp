#include "fuzz/fuzz_readers.h"

#include <unistd.h>

#include <array>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <string>

#include "core/error.h"
#include "harness/config/config.h"
#include "harness/config/stress_config.h"
#include "scenes/gltf_loader.h"
#include "scenes/obj_loader.h"
#include "scenes/ply_loader.h"
#include "scenes/procedural.h"
#include "scenes/ray_file.h"
#include "scenes/tree_file.h"

namespace sahbench::fuzz {
namespace {

// A GLB file starts with the magic "glTF" (glTF 2.0, section 4.4.2); anything else is read as a .gltf.
bool starts_with_glb_magic(const std::filesystem::path& path) {
  std::array<char, 4> magic{};
  std::ifstream in(path, std::ios::binary);
  return in.read(magic.data(), magic.size()) && std::memcmp(magic.data(), "glTF", magic.size()) == 0;
}

// The scene of the tree_file seeds (saved by `sahbench build --scene proc:soup:tris=64,seed=1 --save`),
// so that inputs mutated from them pass the scene check and reach the validator.
const Scene& tree_file_scene() {
  static const Scene scene = generate_procedural(kTreeFileFuzzScene);
  return scene;
}

constexpr std::array kReaders = {
    FuzzReader{"obj", ".obj", [](const std::filesystem::path& p) { load_obj(p); }},
    FuzzReader{"ply", ".ply", [](const std::filesystem::path& p) { load_ply(p); }},
    FuzzReader{"gltf", ".gltf",
               [](const std::filesystem::path& p) { load_gltf(p, starts_with_glb_magic(p)); }},
    FuzzReader{"config", ".toml", [](const std::filesystem::path& p) { load_experiment_config(p); }},
    FuzzReader{"stress_config", ".toml", [](const std::filesystem::path& p) { load_stress_config(p); }},
    FuzzReader{"rays", ".txt", [](const std::filesystem::path& p) { read_rays(p); }},
    FuzzReader{"tree_file", ".sbt",
               [](const std::filesystem::path& p) { load_tree_file(p, tree_file_scene().triangles); }},
};

// The input files written so far, one per reader, removed when the process exits normally.
std::map<std::string_view, std::filesystem::path>& input_files() {
  static std::map<std::string_view, std::filesystem::path> files;
  return files;
}

void remove_input_files() {
  std::error_code ignored;
  for (const auto& [name, path] : input_files()) std::filesystem::remove(path, ignored);
}

}  // namespace

std::span<const FuzzReader> fuzz_readers() {
  return kReaders;
}

const FuzzReader& fuzz_reader(std::string_view name) {
  for (const FuzzReader& reader : kReaders)
    if (reader.name == name) return reader;
  throw Error("no fuzzed reader named '" + std::string(name) + "'");
}

void read_or_refuse(const FuzzReader& reader, const std::filesystem::path& path) {
  try {
    reader.read(path);
  } catch (const Error&) {
  }
}

const std::filesystem::path& write_input(const FuzzReader& reader, const uint8_t* data, std::size_t size) {
  auto& files = input_files();
  auto it = files.find(reader.name);
  if (it == files.end()) {
    if (files.empty()) std::atexit(remove_input_files);
    const std::string file = "sahbench_fuzz_" + std::to_string(getpid()) + "_" + std::string(reader.name) +
                             std::string(reader.extension);
    it = files.emplace(reader.name, std::filesystem::temp_directory_path() / file).first;
  }
  std::ofstream out(it->second, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) throw Error(it->second.string() + ": cannot write the fuzz input");
  return it->second;
}

}  // namespace sahbench::fuzz
