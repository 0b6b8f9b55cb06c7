#pragma once
// `sahbench trace`: rays from a file, traced on one builder's tree, one output line per ray.
//
// Ray file format (text): one ray per line, "ox oy oz dx dy dz [tmin tmax]", numbers separated by
// spaces, tabs or commas; tmin defaults to 0 and tmax to infinity ("inf" is accepted). Blank lines and
// lines starting with '#' are ignored. Output CSV: ray,hit,prim,t,u,v (ray = 0-based index among the
// rays; hit = 1 or 0; prim, t, u, v empty on a miss; t, u, v printed with 9 significant digits, enough
// to read back the same float).

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "core/ray.h"

namespace sahbench {

struct TraceCommandOptions {
  std::string scene;
  std::string builder = "binned_sah";  ///< NAME or NAME:key=value,...
  std::string layout = "bvh2";
  std::filesystem::path rays;
  std::filesystem::path out;
};

/// Reads a ray file: one ray per line, `ox oy oz dx dy dz [tmin tmax]`, separated by spaces, tabs or commas;
/// `#` starts a comment, and a first line of column names is a header. A malformed line, a number outside
/// float range, a zero direction, a directory or a file without rays is an Error naming the file, line and
/// token.
std::vector<Ray> read_rays(const std::filesystem::path& path);

void run_trace_command(const TraceCommandOptions& options, std::ostream& log);

}  // namespace sahbench
