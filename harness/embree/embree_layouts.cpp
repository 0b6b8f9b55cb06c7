#include "harness/embree/embree_layouts.h"

#include <fmt/format.h>

#include <ostream>

#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"

namespace sahbench {

std::vector<EmbreeLayout> supported_embree_layouts(std::ostream& log) {
  std::vector<EmbreeLayout> out;
  EmbreeDevice probe(1);
  for (const auto& l : kEmbreeLayouts) {
    if (l.packet_width == 1 || embree_packets_supported(probe, l.packet_width)) {
      out.push_back(l);
    } else {
      log << fmt::format("skipping layout {}: Embree has no native {}-wide packets on this CPU\n", l.name,
                         l.packet_width);
    }
  }
  return out;
}

}  // namespace sahbench
