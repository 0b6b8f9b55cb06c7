#pragma once
// Embree's own BVH is traced through its own API, one ray at a time or in packets: each way is a layout
// of Embree's, beside ours (traversal/layout.h), in every run that has an Embree row.

#include <iosfwd>
#include <vector>

namespace sahbench {

/// One of Embree's layouts: its name in the CSV's layout column, and how many rays it traces at once.
struct EmbreeLayout {
  const char* name;
  int packet_width;  // 1: rtcIntersect1 / rtcOccluded1
};
inline constexpr EmbreeLayout kEmbreeLayouts[] = {{"embree_1", 1}, {"embree_8", 8}, {"embree_16", 16}};

/// The Embree layouts this CPU runs. Embree's packet kernels exist only where the CPU has the vector
/// width (16 lanes: AVX-512); the cells of a missing width do not apply here and are left out, each
/// layout with a line on `log` that says why.
std::vector<EmbreeLayout> supported_embree_layouts(std::ostream& log);

}  // namespace sahbench
