#pragma once
// `sahbench list`: what a config or the command line may name.

#include <iosfwd>

namespace sahbench {

/// Builders with their parameters and defaults, Embree's builders, procedural scene kinds with their
/// parameters, and the shared scenes found on the search path.
void print_catalogue(std::ostream& out);

/// The shared scenes found, one name per line (for scripts).
void print_scene_names(std::ostream& out);

}  // namespace sahbench
