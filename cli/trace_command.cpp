#include "cli/trace_command.h"

#include <fmt/format.h>

#include <fstream>
#include <ostream>
#include <vector>

#include "builders/registry.h"
#include "core/error.h"
#include "harness/config/config.h"
#include "scenes/load.h"
#include "scenes/ray_file.h"
#include "traversal/layout.h"

namespace sahbench {

void run_trace_command(const TraceCommandOptions& options, std::ostream& log) {
  const std::vector<Ray> rays = read_rays(options.rays);
  const Scene scene = load_scene(options.scene);
  BuilderRun spec = parse_builder_run(options.builder);
  if (spec.is_embree())
    throw Error("--builder '" + options.builder +
                "': trace runs our kernels on our trees; embree_bvh builds Embree's tree in our format");
  resolve(spec);
  const BuilderInfo& info = *spec.info;
  const ParamSet& params = spec.values;
  const Bvh bvh = info.build(BuildInput::from_triangles(scene.triangles), params);
  const auto layout = compile_layout(options.layout, bvh, scene.triangles);
  std::vector<Hit> hits(rays.size());
  layout->trace_closest(rays, hits);

  std::ofstream out(options.out);
  if (!out) throw Error(options.out.string() + ": cannot open for writing");
  out << "ray,hit,prim,t,u,v\n";
  std::size_t found = 0;
  for (std::size_t i = 0; i < hits.size(); ++i) {
    const Hit& h = hits[i];
    if (h.found()) {
      ++found;
      out << fmt::format("{},1,{},{:.9g},{:.9g},{:.9g}\n", i, h.prim, h.t, h.u, h.v);
    } else {
      out << i << ",0,,,,\n";
    }
  }
  if (!out) throw Error(options.out.string() + ": write failed");
  log << fmt::format("{} rays, {} hits, {} on {} ({} triangles) -> {}\n", rays.size(), found,
                     info.name + " " + params.to_string(), scene.name, scene.triangles.size(),
                     options.out.string());
}

}  // namespace sahbench
