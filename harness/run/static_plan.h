#pragma once
// The cells of a static experiment, in the order the runner measures them: scene, builder run, layout,
// threads, ray set. `sahbench run` filters this list (--resume, --only, --shard); `plan` and `merge`
// read the same list, so a shard is a filter on it and never a second expansion.

#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

#include "harness/config/config.h"
#include "harness/embree/embree_layouts.h"
#include "traversal/layout.h"

namespace sahbench {

/// The layouts a run traces: the config's own and Embree's, less those the CPU cannot run.
struct RunLayouts {
  std::vector<LayoutSpec> ours;
  std::vector<EmbreeLayout> embree;
};

/// Those of `specs` that this CPU and build can run (layout_unavailable); each one skipped gets a line on
/// `log` naming it and why. What `run` and `stress` trace.
std::vector<LayoutSpec> runnable_specs(const std::vector<LayoutSpec>& specs, std::ostream& log);

/// The layouts of `cfg` this machine runs: ours that its CPU and build can run (layout_unavailable) and
/// Embree's that its CPU supports (supported_embree_layouts). Each one skipped gets a line on `log`
/// naming it and why, so one config runs on CPUs with and without AVX-512.
RunLayouts runnable_layouts(const ExperimentConfig& cfg, std::ostream& log);

/// One cell of a static experiment (frame 0).
struct PlannedCell {
  std::string scene;
  std::size_t builder = 0;  ///< index into ExperimentConfig::builders
  std::string layout;       ///< the CSV's layout column (CellLayout::name)
  int threads = 1;
  std::string ray_set;
  std::string key;  ///< cell_key (result_row.h), as a row of this cell has it
};

/// Every cell of `cfg` over `scenes` (scenes_to_run) traced with `layouts`: for each scene, builder run,
/// layout of its arity (layouts_for), thread count and ray set.
std::vector<PlannedCell> static_cells(const ExperimentConfig& cfg, const std::vector<std::string>& scenes,
                                      const RunLayouts& layouts);

/// Whether the cell is an anchor of the ratios to Embree (harness/report/result_cells.h): Embree's
/// medium-quality BVH, in its default or robust mode, in any of its layouts: one ray at a time
/// (embree_1) anchors our single-ray kernels, and its packets are the like-for-like of our packet
/// layouts. Its build is made for embree_1 anyway, so tracing its packets too costs little.
bool is_anchor_cell(const ExperimentConfig& cfg, const PlannedCell& cell);

}  // namespace sahbench
