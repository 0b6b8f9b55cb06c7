#pragma once
// `sahbench run` for an animation experiment (a config with an [animation] table): refit against
// rebuild, frame by frame. For every animated scene (static ones are skipped with a message) and every
// frame of the configured times, each of our builders gives two kinds of cells:
//   builder "refit(NAME)": NAME's tree built on the first frame, refitted (core/refit.h) to this
//       frame's triangles; build_ms is the refit alone;
//   builder "NAME": a fresh build on this frame's triangles (per-primitive bounds included, as in a
//       static run);
// and Embree gives `embree` rows: quality refit is Embree's own refit of its first-frame build (a dynamic
// scene whose vertex buffer is updated and recommitted; build_ms covers rtcUpdateGeometryBuffer,
// rtcCommitGeometry and rtcCommitScene), other qualities a fresh rtcCommitScene per frame.
// Every tree is validated, statistics (SAH cost) computed, and traced in each configured layout of its
// arity on rays generated from that frame's triangles, with the mismatch count against the frame's
// reference. A rebuild is compiled into each layout every frame (layout_ms: the compile). A refit's
// layouts are compiled once, from the first frame's tree, and refitted in place to every frame
// (CompiledLayout::refit; the extra column layout_refit_ms, after layout_ms, is its median time over the
// build repetitions; layout_ms stays empty). So a refit costs build_ms + layout_refit_ms per frame
// against a rebuild's build_ms + layout_ms. The camera is the scene's own, else the
// automatic framing of the box around all frames, so every frame is seen from the same place.
// Rows carry the frame index in `frame` and its time in seconds in the extra column `frame_time`.

#include <iosfwd>
#include <string>
#include <vector>

#include "harness/config/config.h"
#include "harness/run/run_options.h"

namespace sahbench {

/// The CSV columns of an animation run: result_columns() with layout_refit_ms after layout_ms, then
/// frame_time.
std::vector<std::string> animation_columns();

/// Runs `cfg` (which must have an animation table) with the run options (resume, --only, output) as
/// run_experiment does, and prints a summary of refit against rebuild per scene at the end. Returns 0,
/// or 1 when a tree failed validation. Bad input throws sahbench::Error.
int run_animation_experiment(const ExperimentConfig& cfg, const RunOptions& options, std::ostream& log);

}  // namespace sahbench
