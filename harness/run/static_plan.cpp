#include "harness/run/static_plan.h"

#include <fmt/format.h>

#include <ostream>

#include "harness/run/result_row.h"
#include "harness/run/run_common.h"

namespace sahbench {

std::vector<LayoutSpec> runnable_specs(const std::vector<LayoutSpec>& specs, std::ostream& log) {
  std::vector<LayoutSpec> out;
  for (const LayoutSpec& spec : specs) {
    if (const auto why = layout_unavailable(spec))
      log << fmt::format("skipping layout {}: {}\n", spec.text(), *why);
    else
      out.push_back(spec);
  }
  return out;
}

RunLayouts runnable_layouts(const ExperimentConfig& cfg, std::ostream& log) {
  RunLayouts out;
  out.ours = runnable_specs(cfg.layouts, log);
  out.embree = supported_embree_layouts(log);
  for (const BuilderRun& b : cfg.builders)
    if (!b.is_embree() && layouts_for(b, out).empty())
      log << fmt::format("skipping builder {}: none of its layouts (arity {}) runs on this CPU\n", b.label(),
                         b.arity);
  return out;
}

std::vector<PlannedCell> static_cells(const ExperimentConfig& cfg, const std::vector<std::string>& scenes,
                                      const RunLayouts& layouts) {
  std::vector<PlannedCell> out;
  for (const auto& scene : scenes)
    for (std::size_t b = 0; b < cfg.builders.size(); ++b) {
      const BuilderRun& run = cfg.builders[b];
      for (const CellLayout& layout : layouts_for(run, layouts))
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
