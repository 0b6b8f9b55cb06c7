#pragma once
// `sahbench trace`: rays from a file, traced on one builder's tree (ours through one of our layouts, or
// Embree's through one of Embree's), one output line per ray.
//
// Rays are read with read_rays (scenes/ray_file.h). Output CSV: a first line "# builder=... layout=...
// isa=... query=..." naming what answered, then ray,hit,prim,t,u,v (ray = 0-based index among the rays; hit =
// 1 or 0; prim, t, u, v empty on a miss; t, u, v printed with 9 significant digits, enough to read back the
// same float). An any-hit query reports hit only: prim, t, u and v stay empty, as the any-hit kernels (ours
// and rtcOccluded) stop at the first hit they find and return only that there was one.

#include <filesystem>
#include <iosfwd>
#include <string>
#include <string_view>

namespace sahbench {

/// What each ray asks: its closest hit, or whether anything is hit in [tmin, tmax] (shadow rays).
enum class TraceQuery { kClosest, kAny };

/// "closest" or "any"; anything else is an Error naming the value.
TraceQuery parse_trace_query(std::string_view text);
std::string_view to_string(TraceQuery query);

struct TraceCommandOptions {
  std::string scene;
  std::string builder = "binned_sah";  ///< NAME or NAME:key=value,..., or embree[:quality=Q,robust=1]
  /// A layout spec of ours (traversal/layout.h) for our builders, embree_1/8/16 for Embree's; empty: bvh2
  /// for ours, embree_1 for Embree's.
  std::string layout;
  std::filesystem::path rays;
  std::filesystem::path out;
  TraceQuery query = TraceQuery::kClosest;
};

/// Traces the rays and writes the output CSV; names the builder (with its resolved parameters), the
/// layout, the ISA and the query on `log` as in the CSV's first line. An unknown builder, layout or query,
/// a layout of the other tree source, or an Embree layout the CPU cannot run is an Error naming it.
void run_trace_command(const TraceCommandOptions& options, std::ostream& log);

}  // namespace sahbench
