#include "harness/run/static_plan.h"

#include "harness/run/result_row.h"
#include "harness/run/run_common.h"

namespace sahbench {

std::vector<PlannedCell> static_cells(const ExperimentConfig& cfg, const std::vector<std::string>& scenes,
                                      std::span<const EmbreeLayout> embree_layouts) {
  std::vector<PlannedCell> out;
  for (const auto& scene : scenes)
    for (std::size_t b = 0; b < cfg.builders.size(); ++b) {
      const BuilderRun& run = cfg.builders[b];
      for (const CellLayout& layout : layouts_for(run, cfg.layouts, embree_layouts))
        for (const int threads : cfg.threads)
          for (const auto& rs : cfg.ray_sets)
            out.push_back({scene, b, layout.name, threads, rs.name,
                           cell_key(scene, run.name, run.params_text(), layout.name, threads, rs.name, 0)});
    }
  return out;
}

bool is_anchor_cell(const ExperimentConfig& cfg, const PlannedCell& cell) {
  const BuilderRun& run = cfg.builders[cell.builder];
  return run.is_embree() && run.quality == EmbreeQuality::kMedium;
}

}  // namespace sahbench
