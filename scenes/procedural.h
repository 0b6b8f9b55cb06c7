#pragma once
// Procedural scenes from a spec "proc:KIND[:key=value,...]" (DESIGN.md: generators give every test
// and the default run data of their own). Kinds: sphere, terrain, soup, needles, multiscale, and the
// animated wave; all take `tris` (target triangle count, e.g. 100k or 1M) and `seed`. See generators.h
// and wave.h for what each makes.

#include <span>
#include <string_view>

#include "scenes/proc_spec.h"
#include "scenes/scene.h"
#include "scenes/wave.h"

namespace sahbench {

/// True if `spec` starts with "proc:".
bool is_procedural_spec(std::string_view spec);

/// The generator kinds with their parameters and defaults (for `sahbench list` and error messages).
std::span<const ProcKindInfo> procedural_kinds();

/// True for the kinds whose triangles move with time (Scene::animated): "wave".
bool is_animated_kind(std::string_view kind);

/// The wave generator's parameters from a parsed "proc:wave" spec.
WaveParams wave_params(const ProcSpec& spec);

/// Generates the scene (an animated kind at t = 0). Scene::name is `spec` as given; Scene::source is the
/// normalised spec with every parameter's value (e.g. "proc:soup:tris=1000000,seed=1"). Throws Error for an
/// unknown kind or key or a bad value, naming it.
Scene generate_procedural(std::string_view spec);

}  // namespace sahbench
