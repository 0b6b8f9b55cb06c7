#include "harness/embree/embree_layouts.h"

#include <fmt/format.h>

#include <ostream>

#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"

namespace sahbench {

const EmbreeLayout* find_embree_layout(std::string_view name) {
  for (const auto& l : kEmbreeLayouts)
    if (name == l.name) return &l;
  return nullptr;
}

std::optional<std::string> embree_layout_unsupported(const EmbreeDevice& device, const EmbreeLayout& layout) {
  if (layout.packet_width == 1 || embree_packets_supported(device, layout.packet_width)) return std::nullopt;
  return fmt::format("Embree has no native {}-wide packets on this CPU (Embree's kernels here: {}{})",
                     layout.packet_width, embree_isa(device),
                     layout.packet_width == 16 ? "; 16-wide packets need AVX-512" : "");
}

void embree_trace_closest(const EmbreeScene& scene, const EmbreeLayout& layout, std::span<const Ray> rays,
                          std::span<Hit> hits) {
  if (layout.packet_width == 1)
    embree_intersect1(scene, rays, hits);
  else
    embree_intersect_packets(scene, rays, hits, layout.packet_width);
}

void embree_trace_any(const EmbreeScene& scene, const EmbreeLayout& layout, std::span<const Ray> rays,
                      std::span<uint8_t> occluded) {
  if (layout.packet_width == 1)
    embree_occluded1(scene, rays, occluded);
  else
    embree_occluded_packets(scene, rays, occluded, layout.packet_width);
}

std::vector<EmbreeLayout> supported_embree_layouts(std::ostream& log) {
  std::vector<EmbreeLayout> out;
  EmbreeDevice probe(1);
  for (const auto& l : kEmbreeLayouts) {
    if (const auto why = embree_layout_unsupported(probe, l))
      log << fmt::format("skipping layout {}: {}\n", l.name, *why);
    else
      out.push_back(l);
  }
  return out;
}

}  // namespace sahbench
