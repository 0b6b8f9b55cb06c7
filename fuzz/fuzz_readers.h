#pragma once
// The readers of user-supplied files that are fuzzed (fuzz/*_fuzzer.cpp) and whose past findings are
// replayed by the test suite (tests/fuzz): one table, so that the fuzzer and the replay call each reader
// the same way. Every reader is called through its real entry point, on a path.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string_view>

namespace sahbench::fuzz {

/// The scene the tree_file reader checks trees against, and its seeds were saved for.
inline constexpr const char* kTreeFileFuzzScene = "proc:soup:tris=64,seed=1";

struct FuzzReader {
  /// The fuzz target's name without "_fuzzer", and its folder under fuzz/corpus and fuzz/regressions.
  std::string_view name;
  /// The input file's extension (the readers do not look at it; it makes a saved input easy to open).
  std::string_view extension;
  /// Reads the file at the path into its typed value and drops it.
  void (*read)(const std::filesystem::path& path);
};

/// Every fuzzed reader: obj, ply, gltf (a .gltf, or a GLB when the bytes start with GLB's magic),
/// config (experiment configs), stress_config, rays (ray files) and tree_file (tree files, checked
/// against the scene kTreeFileFuzzScene).
std::span<const FuzzReader> fuzz_readers();

/// The reader named `name`; an unknown name is an Error.
const FuzzReader& fuzz_reader(std::string_view name);

/// Runs `reader` on `path`. A sahbench::Error is the reader refusing bad input, which is correct and
/// returns normally; any other exception propagates (a finding).
void read_or_refuse(const FuzzReader& reader, const std::filesystem::path& path);

/// Writes `size` bytes to this process's input file for `reader` (created on first use in the temporary
/// directory, rewritten for every input, removed at exit) and returns its path.
const std::filesystem::path& write_input(const FuzzReader& reader, const uint8_t* data, std::size_t size);

}  // namespace sahbench::fuzz
