#pragma once
// `sahbench trace`: rays from a file, traced on one builder's tree, one output line per ray.
//
// Rays are read with read_rays (scenes/ray_file.h). Output CSV: ray,hit,prim,t,u,v (ray = 0-based index
// among the rays; hit = 1 or 0; prim, t, u, v empty on a miss; t, u, v printed with 9 significant
// digits, enough to read back the same float).

#include <filesystem>
#include <iosfwd>
#include <string>

namespace sahbench {

struct TraceCommandOptions {
  std::string scene;
  std::string builder = "binned_sah";  ///< NAME or NAME:key=value,...
  std::string layout = "bvh2";
  std::filesystem::path rays;
  std::filesystem::path out;
};

void run_trace_command(const TraceCommandOptions& options, std::ostream& log);

}  // namespace sahbench
