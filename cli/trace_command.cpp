#include "cli/trace_command.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <iostream>
#include <ostream>
#include <string>
#include <vector>

#include "builders/registry.h"
#include "core/error.h"
#include "harness/config/config.h"
#include "harness/embree/embree_layouts.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "scenes/load.h"
#include "scenes/ray_file.h"
#include "traversal/layout.h"

namespace sahbench {

TraceQuery parse_trace_query(std::string_view text) {
  if (text == "closest") return TraceQuery::kClosest;
  if (text == "any") return TraceQuery::kAny;
  throw Error("--query '" + std::string(text) + "': expected closest or any");
}

std::string_view to_string(TraceQuery query) {
  return query == TraceQuery::kAny ? "any" : "closest";
}

namespace {

// The answers of one trace, and what gave them: the builder with its resolved parameters, the layout and
// the ISA its kernels ran with.
struct TraceAnswers {
  std::string builder, layout, isa;
  std::vector<Hit> hits;          // closest-hit queries
  std::vector<uint8_t> occluded;  // any-hit queries
};

TraceAnswers trace_ours(const BuilderRun& run, std::string_view layout_text, const Scene& scene,
                        const std::vector<Ray>& rays, TraceQuery query) {
  if (find_embree_layout(layout_text))
    throw Error("--layout '" + std::string(layout_text) +
                "' traces Embree's own BVH: use it with --builder embree");
  const LayoutSpec spec = parse_layout_spec(layout_text);
  if (const auto why = layout_unavailable(spec)) throw Error("--layout '" + spec.text() + "': " + *why);
  require_layout_of_arity(run, spec);
  const Bvh bvh = run.info->build(BuildInput::from_triangles(scene.triangles), run.values);
  const auto layout = compile_layout(spec, bvh, scene.triangles);
  TraceAnswers out{run.name + ":" + run.params_text(), spec.text(), layout->isa(), {}, {}};
  if (query == TraceQuery::kAny) {
    out.occluded.resize(rays.size());
    layout->trace_any(rays, out.occluded);
  } else {
    out.hits.resize(rays.size());
    layout->trace_closest(rays, out.hits);
  }
  return out;
}

TraceAnswers trace_embree(const BuilderRun& run, std::string_view layout_text, const Scene& scene,
                          const std::vector<Ray>& rays, TraceQuery query, const std::string& ray_file,
                          const std::vector<std::size_t>& lines) {
  // Named by its line, as read_rays names the rays it refuses.
  if (const auto far = std::find_if_not(rays.begin(), rays.end(), embree_accepts); far != rays.end())
    throw Error(
        fmt::format("{}:{}: an origin or direction component beyond {:g}, outside the range Embree "
                    "traces (its assertion would stop the process)",
                    ray_file, lines.at(static_cast<std::size_t>(far - rays.begin())), kEmbreeLargeFloat));
  const EmbreeLayout* layout = find_embree_layout(layout_text);
  if (!layout) {
    std::string known;
    for (const auto& l : kEmbreeLayouts) known += (known.empty() ? "" : ", ") + std::string(l.name);
    throw Error("--layout '" + std::string(layout_text) + "': Embree's BVH is traced by Embree's layouts (" +
                known + ")");
  }
  // No thread limit of its own: the device follows TBB's, as our kernels do.
  EmbreeDevice device(0);
  if (const auto why = embree_layout_unsupported(device, *layout))
    throw Error("--layout '" + std::string(layout_text) + "': " + *why);
  const EmbreeScene embree(device, scene.triangles, run.quality, run.embree_options());
  TraceAnswers out{run.name + ":" + run.params_text(), layout->name, "embree:" + embree_isa(device), {}, {}};
  if (query == TraceQuery::kAny) {
    out.occluded.resize(rays.size());
    embree_trace_any(embree, *layout, rays, out.occluded);
  } else {
    out.hits.resize(rays.size());
    embree_trace_closest(embree, *layout, rays, out.hits);
  }
  return out;
}

}  // namespace

void run_trace_command(const TraceCommandOptions& options, std::ostream& log) {
  std::vector<std::size_t> lines;
  const std::vector<Ray> rays = read_rays(options.rays, &lines);
  const Scene scene = load_scene(options.scene);
  BuilderRun run = parse_builder_run(options.builder);
  resolve(run);
  const std::string layout_text = !options.layout.empty() ? options.layout
                                  : run.is_embree()       ? kEmbreeLayouts[0].name
                                                          : default_layout(run);
  const TraceAnswers answers = run.is_embree() ? trace_embree(run, layout_text, scene, rays, options.query,
                                                              options.rays.string(), lines)
                                               : trace_ours(run, layout_text, scene, rays, options.query);
  const std::string what = fmt::format("builder={} layout={} isa={} query={}", answers.builder,
                                       answers.layout, answers.isa, to_string(options.query));

  // "-" is standard output, for a pipe into another tool.
  const bool to_stdout = options.out == "-";
  std::ofstream file;
  if (!to_stdout) {
    file.open(options.out);
    if (!file) throw Error(options.out.string() + ": cannot open for writing");
  }
  std::ostream& out = to_stdout ? std::cout : file;
  out << "# " << what << "\n";
  out << "ray,hit,prim,t,u,v\n";
  std::size_t found = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    if (options.query == TraceQuery::kAny) {
      found += answers.occluded[i] != 0;
      out << i << (answers.occluded[i] != 0 ? ",1,,,,\n" : ",0,,,,\n");
      continue;
    }
    const Hit& h = answers.hits[i];
    if (h.found()) {
      ++found;
      // + 0.0f: a barycentric of -0 (a hit on an edge) prints as 0.
      out << fmt::format("{},1,{},{:.9g},{:.9g},{:.9g}\n", i, h.prim, h.t, h.u + 0.0f, h.v + 0.0f);
    } else {
      out << i << ",0,,,,\n";
    }
  }
  out.flush();
  if (!out)
    throw Error((to_stdout ? std::string("standard output") : options.out.string()) + ": write failed");
  log << fmt::format("{}\n{} rays, {} hits on {} ({} triangles) -> {}\n", what, rays.size(), found,
                     scene.name, scene.triangles.size(),
                     to_stdout ? std::string("standard output") : options.out.string());
}

}  // namespace sahbench
