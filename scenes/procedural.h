#pragma once
// Procedural scenes from a spec "proc:KIND[:key=value,...]" (DESIGN.md: generators give every test
// and the default run data of their own). Kinds: sphere, terrain, soup, needles, multiscale; all take
// `tris` (target triangle count, e.g. 100k or 1M) and `seed`. See generators.h for what each makes.

#include <span>
#include <string_view>

#include "scenes/proc_spec.h"
#include "scenes/scene.h"

namespace sahbench {

/// True if `spec` starts with "proc:".
bool is_procedural_spec(std::string_view spec);

/// The generator kinds with their parameters and defaults (for `sahbench list` and error messages).
std::span<const ProcKindInfo> procedural_kinds();

/// Generates the scene. Scene::name is `spec` as given; Scene::source is the normalised spec with every
/// parameter's value (e.g. "proc:soup:tris=1000000,seed=1"). Throws Error for an unknown kind or key
/// or a bad value, naming it.
Scene generate_procedural(std::string_view spec);

}  // namespace sahbench
