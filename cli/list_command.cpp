#include "cli/list_command.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <fmt/ranges.h>

#include <ostream>

#include "builders/registry.h"
#include "scenes/procedural.h"
#include "scenes/scene_path.h"
#include "traversal/kernel_variant.h"
#include "traversal/layout.h"

namespace sahbench {

void print_catalogue(std::ostream& out) {
  fmt::print(out, "builders (--builder NAME[:key=value,...]):\n");
  for (const auto& b : builders()) {
    fmt::print(out, "  {:<14} {}\n", b.name, b.summary);
    for (const auto& p : b.params) {
      if (p.type == ParamType::kSource) {
        fmt::print(out,
                   "      {:<14} default {:<8} a binary builder or pass (source.KEY=value: its own)  {}\n",
                   p.name, p.default_source, p.help);
        continue;
      }
      if (p.type == ParamType::kPath) {
        fmt::print(out, "      {:<14} default {:<8} a file path  {}\n", p.name, "none", p.help);
        continue;
      }
      if (p.type == ParamType::kChoice) {
        fmt::print(out, "      {:<14} default {:<8} one of {}  {}\n", p.name,
                   p.choices.at(static_cast<std::size_t>(p.default_value)), fmt::join(p.choices, "|"),
                   p.help);
        continue;
      }
      fmt::print(out, "      {:<14} default {:<8} range [{}, {}]  {}\n", p.name, p.default_value, p.min_value,
                 p.max_value, p.help);
    }
  }
  fmt::print(out, "  {:<14} {}\n", "embree_low", "Embree 3 rtcCommitScene, RTC_BUILD_QUALITY_LOW");
  fmt::print(out, "  {:<14} {}\n", "embree_medium", "Embree 3 rtcCommitScene, RTC_BUILD_QUALITY_MEDIUM");
  fmt::print(out, "  {:<14} {}\n", "embree_high",
             "Embree 3 rtcCommitScene, RTC_BUILD_QUALITY_HIGH (spatial splits)");
  fmt::print(out, "  {:<14} {}\n", "embree:robust=1",
             "any of them in Embree's robust mode (RTC_SCENE_FLAG_ROBUST, watertight Pluecker test); "
             "config: robust = true");

  fmt::print(out,
             "\nlayouts (config: layouts = "
             "[\"NAME[:tri=watertight|mt|mt0|mtn,box=robust|fast|fma,anyhit={},isa=...]\"]):\n",
             any_hit_order_names("|"));
  for (const auto& l : layouts())
    fmt::print(out, "  {:<14} arity {}{}  {}\n", l.name, l.arity,
               l.has_isa      ? ", isa and packet options"
               : l.has_packet ? ", packet option (isa with it)"
                              : "",
               l.summary);
  fmt::print(out, "  kernel ISAs available here:");
  for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kSse, KernelIsa::kAvx2, KernelIsa::kAvx512})
    if (kernel_isa_available(isa)) fmt::print(out, " {}", to_string(isa));
  fmt::print(out, " (auto = {})\n", to_string(preferred_kernel_isa()));
  fmt::print(out, "  {:<14} {}\n", "embree_1/8/16",
             "Embree's own BVH, rtcIntersect1/Occluded1 and 8/16-wide packets (builder embree)");

  fmt::print(out, "\nray sets (config: [[ray_set]] kind = ...):\n");
  fmt::print(out, "  {:<14} {}\n", "primary",
             "pinhole camera: the config's [[camera]], else the file's, else automatic framing; width x "
             "height rays");
  fmt::print(out, "  {:<14} {}\n", "shadow",
             "any-hit, from primary hits to point lights (light_source auto|scene, lights)");
  fmt::print(out, "  {:<14} {}\n", "diffuse", "closest-hit, cosine-weighted bounces from primary hits");
  fmt::print(out, "  {:<14} {}\n", "ao", "any-hit, cosine-weighted, length ao_radius x scene diagonal");
  fmt::print(out, "  {:<14} {}\n", "random",
             "closest-hit, uniform origins in the scene box and directions (count)");

  fmt::print(out, "\nprocedural scenes (--scene proc:KIND[:key=value,...]):\n");
  for (const auto& kind : procedural_kinds()) {
    fmt::print(out, "  {:<14} {}\n", kind.name, kind.help);
    for (const auto& p : kind.params)
      fmt::print(out, "      {:<14} default {:<10} range [{}, {}]  {}\n", p.name, p.default_value, p.min,
                 p.max, p.help);
  }

  fmt::print(out, "\nshared scenes (--scene NAME), search path:");
  const auto dirs = scene_search_path();
  if (dirs.empty()) fmt::print(out, " none found (set SAHBENCH_SCENE_PATH)");
  for (const auto& d : dirs) fmt::print(out, " {}", d.string());
  fmt::print(out, "\n");
  for (const auto& s : list_shared_scenes()) fmt::print(out, "  {:<22} {}\n", s.name, s.path.string());
}

void print_scene_names(std::ostream& out) {
  for (const auto& s : list_shared_scenes()) out << s.name << "\n";
}

}  // namespace sahbench
