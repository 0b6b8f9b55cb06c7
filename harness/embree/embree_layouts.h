#pragma once
// Embree's own BVH is traced through its own API, one ray at a time or in packets: each way is a layout
// of Embree's, beside ours (traversal/layout.h), in every run that has an Embree row.

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/ray.h"

namespace sahbench {

/// One of Embree's layouts: its name in the CSV's layout column, and how many rays it traces at once.
struct EmbreeLayout {
  const char* name;
  int packet_width;  // 1: rtcIntersect1 / rtcOccluded1
};
inline constexpr EmbreeLayout kEmbreeLayouts[] = {{"embree_1", 1}, {"embree_8", 8}, {"embree_16", 16}};

class EmbreeDevice;
class EmbreeScene;

/// The Embree layout called `name`, or nullptr where `name` is none of kEmbreeLayouts.
const EmbreeLayout* find_embree_layout(std::string_view name);

/// Why `device` cannot trace `layout` (Embree has no native packets of its width on this CPU), or nullopt
/// when it can.
std::optional<std::string> embree_layout_unsupported(const EmbreeDevice& device, const EmbreeLayout& layout);

/// Closest hits of `rays` through `layout`'s calls: rtcIntersect1, or packets of its width
/// (embree_trace.h). `hits` must have the size of `rays`.
void embree_trace_closest(const EmbreeScene& scene, const EmbreeLayout& layout, std::span<const Ray> rays,
                          std::span<Hit> hits);
/// Occlusion of `rays` through `layout`'s calls: rtcOccluded1, or packets of its width.
void embree_trace_any(const EmbreeScene& scene, const EmbreeLayout& layout, std::span<const Ray> rays,
                      std::span<uint8_t> occluded);

/// The Embree layouts this CPU runs. Embree's packet kernels exist only where the CPU has the vector
/// width (16 lanes: AVX-512); the cells of a missing width do not apply here and are left out, each
/// layout with a line on `log` that says why.
std::vector<EmbreeLayout> supported_embree_layouts(std::ostream& log);

}  // namespace sahbench
