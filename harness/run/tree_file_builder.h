#pragma once
// The `file` builder: a tree read from a tree file (scenes/tree_file.h, docs/tree_format.md) is a tree
// source of the cell pipeline like any builder, so that a tree made by another program is costed,
// compiled to every layout of its arity and traced against Embree in the same rows. It lives in the
// harness because builders/ does no file I/O.

#include <span>

#include "core/triangle.h"
#include "harness/config/config.h"

namespace sahbench {

/// Registers "file" with builders/registry.h: parameters path (kPath, required), c_trav and c_isect (the
/// SAH constants its statistics are reported with). Its arity is the file's, read from the header when
/// the run is resolved; its build reads the file and checks it against the scene (load_tree_file), so its
/// build time is the time to read and check the file. Calling it again does nothing. Not thread-safe:
/// call at startup, like register_builder.
void register_tree_file_builder();

/// Where `run` reads a tree file (a `file` run, or a pass whose source chain holds one): each file's
/// header checked against the scene's `triangles` (check_tree_file_scene), so that a tree for another
/// scene is refused when the scene is loaded, before any build. Other runs: nothing.
void check_tree_file_fits(const BuilderRun& run, std::span<const Triangle> triangles);

}  // namespace sahbench
