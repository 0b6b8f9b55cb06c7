#include "cli/trace_command.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <fstream>
#include <limits>
#include <ostream>
#include <sstream>

#include "builders/registry.h"
#include "core/error.h"
#include "core/text_file.h"
#include "harness/config/config.h"
#include "harness/embree/embree_layouts.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "scenes/load.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

// A token as an error message can show it: bytes outside printable ASCII (a NUL would cut the message)
// as \xNN.
std::string printable(std::string_view token) {
  std::string out;
  for (const char c : token) {
    const auto u = static_cast<unsigned char>(c);
    out += u >= 0x20 && u < 0x7f ? std::string(1, c) : fmt::format("\\x{:02x}", u);
  }
  return out;
}

float parse_float(std::string_view token, const std::string& where) {
  // from_chars takes no leading '+'; a number written with one is still a number.
  const bool plus =
      token.size() > 1 && token.front() == '+' &&
      (std::isdigit(static_cast<unsigned char>(token[1])) || token[1] == '.' || token[1] == 'i');
  const std::string_view digits = plus ? token.substr(1) : token;
  if (digits == "inf") return std::numeric_limits<float>::infinity();
  if (token == "-inf") return -std::numeric_limits<float>::infinity();
  float value = 0.0f;
  const auto result = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (result.ptr != digits.data() + digits.size() || result.ec == std::errc::invalid_argument)
    throw Error(where + ": '" + printable(token) + "' is not a number");
  if (result.ec == std::errc::result_out_of_range)
    throw Error(where + ": '" + printable(token) +
                "' is outside the range of a float (magnitudes 1.4e-45 to 3.4e38, or 0, inf)");
  return value;
}

// Whether `token` reads as a word rather than a number: a header line's column name.
bool is_word(std::string_view token) {
  if (token.empty() || !std::isalpha(static_cast<unsigned char>(token.front()))) return false;
  std::string lower(token);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower != "inf" && lower != "infinity" && lower != "nan";
}

}  // namespace

std::vector<Ray> read_rays(const std::filesystem::path& path) {
  std::istringstream in(read_text_file(path, "ray file"));
  std::vector<Ray> rays;
  std::string line;
  bool first = true;  // the first non-empty line, which may be a header
  for (std::size_t number = 1; std::getline(in, line); ++number) {
    const std::string where = path.string() + ":" + std::to_string(number);
    std::vector<std::string_view> tokens;
    std::string_view rest = std::string_view(line).substr(0, line.find('#'));  // a comment runs to the end
    while (!rest.empty()) {
      const auto start = rest.find_first_not_of(" \t,\r");
      if (start == std::string_view::npos) break;
      rest = rest.substr(start);
      const auto end = rest.find_first_of(" \t,\r");
      tokens.push_back(rest.substr(0, end));
      rest = end == std::string_view::npos ? std::string_view{} : rest.substr(end);
    }
    if (tokens.empty()) continue;
    // A first line of column names ("ox oy oz dx dy dz") is a header, not data.
    const bool header = first && std::all_of(tokens.begin(), tokens.end(), is_word);
    first = false;
    if (header) continue;
    if (tokens.size() != 6 && tokens.size() != 8)
      throw Error(where + ": expected 6 or 8 numbers (ox oy oz dx dy dz [tmin tmax]), found " +
                  std::to_string(tokens.size()));
    float v[8] = {0, 0, 0, 0, 0, 0, 0, std::numeric_limits<float>::infinity()};
    for (std::size_t i = 0; i < tokens.size(); ++i) v[i] = parse_float(tokens[i], where);
    Ray ray;
    ray.org = {v[0], v[1], v[2]};
    ray.dir = {v[3], v[4], v[5]};
    ray.tmin = v[6];
    ray.tmax = v[7];
    if (ray.dir == Vec3{0, 0, 0}) throw Error(where + ": the direction is zero");
    rays.push_back(ray);
  }
  if (rays.empty()) throw Error(path.string() + ": no rays in the ray file");
  return rays;
}

TraceQuery parse_trace_query(std::string_view text) {
  if (text == "closest") return TraceQuery::kClosest;
  if (text == "any") return TraceQuery::kAny;
  throw Error("--query '" + printable(text) + "': expected closest or any");
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
                          const std::vector<Ray>& rays, TraceQuery query) {
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
  const EmbreeScene embree(device, scene.triangles, run.quality);
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
  const std::vector<Ray> rays = read_rays(options.rays);
  const Scene scene = load_scene(options.scene);
  BuilderRun run = parse_builder_run(options.builder);
  resolve(run);
  const std::string layout_text = !options.layout.empty() ? options.layout
                                  : run.is_embree()       ? kEmbreeLayouts[0].name
                                                          : "bvh2";
  const TraceAnswers answers = run.is_embree() ? trace_embree(run, layout_text, scene, rays, options.query)
                                               : trace_ours(run, layout_text, scene, rays, options.query);
  const std::string what = fmt::format("builder={} layout={} isa={} query={}", answers.builder,
                                       answers.layout, answers.isa, to_string(options.query));

  std::ofstream out(options.out);
  if (!out) throw Error(options.out.string() + ": cannot open for writing");
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
      out << fmt::format("{},1,{},{:.9g},{:.9g},{:.9g}\n", i, h.prim, h.t, h.u, h.v);
    } else {
      out << i << ",0,,,,\n";
    }
  }
  if (!out) throw Error(options.out.string() + ": write failed");
  log << fmt::format("{}\n{} rays, {} hits on {} ({} triangles) -> {}\n", what, rays.size(), found,
                     scene.name, scene.triangles.size(), options.out.string());
}

}  // namespace sahbench
