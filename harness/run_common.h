#pragma once
// Pieces of `sahbench run` that the static runner (runner.cpp) and the animation runner
// (animation_runner.cpp) share, so that both name runs, pick scenes and layouts, resume and log the same
// way. Internal to the harness.

#include <filesystem>
#include <iosfwd>
#include <set>
#include <string>
#include <vector>

#include "harness/config.h"

namespace sahbench {

/// Embree's own BVH is traced through its own API, one ray at a time or in packets: each is a layout.
struct EmbreeLayout {
  const char* name;
  int packet_width;  // 1: rtcIntersect1 / rtcOccluded1
};
inline constexpr EmbreeLayout kEmbreeLayouts[] = {{"embree_1", 1}, {"embree_8", 8}, {"embree_16", 16}};

/// The Embree layouts this CPU runs. Embree's packet kernels exist only where the CPU has the vector
/// width (16 lanes: AVX-512); the cells of a missing width do not apply here and are left out, each
/// layout with a line on `log` that says why.
std::vector<EmbreeLayout> supported_embree_layouts(std::ostream& log);

/// The time now in UTC as YYYYMMDD-HHMMSS: the suffix of a run id.
std::string now_stamp();

/// Whole seconds as "42s", or "3m07s" from a minute on, for progress lines.
std::string format_duration(double seconds);

/// The scenes a run covers: `cfg.scenes`, then each of `cfg.optional_scenes` found on the scene search
/// path. Required scenes must exist before the first cell runs, not fail hours in: a missing one throws
/// the loader's Error; a missing optional one is skipped with a line on `log`.
std::vector<std::string> scenes_to_run(const ExperimentConfig& cfg, std::ostream& log);

/// --resume: the cell keys (cell_key) of the rows already in `output`. A resumed run continues the same
/// run: where a row came from the same config, `run_id` becomes its run id, so a report shows them
/// together. Says on `log` how many cells are finished.
std::set<std::string> finished_cells(const std::filesystem::path& output, const ExperimentConfig& cfg,
                                     std::string& run_id, std::ostream& log);

}  // namespace sahbench
