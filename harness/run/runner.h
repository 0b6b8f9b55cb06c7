#pragma once
// `sahbench run CONFIG`: expands an experiment config into cells (scene x builder run x layout x threads x
// ray set), measures each, and appends one CSV row per cell as soon as it finishes.

#include <iosfwd>

#include "harness/run/result_row.h"
#include "harness/run/run_options.h"

namespace sahbench {

/// Runs the experiment (an animation experiment, with an [animation] table, through
/// run_animation_experiment). Returns 0, or 1 when a tree failed validation (its cells are still written,
/// with the failure in `notes`). Bad input throws sahbench::Error.
int run_experiment(const RunOptions& options, std::ostream& log);

}  // namespace sahbench
