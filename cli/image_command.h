#pragma once
// `sahbench image`: per-pixel maps of one builder and layout on a scene's primary rays (the primary ray
// set of harness/run/ray_sets.h: the scene's camera or the automatic framing, its rays in the tile order
// of primary_pixel_order, each written back at its pixel (x, y), y * width + x, row 0 at the top):
//
//   PREFIX_nodes.{png,exr}    nodes visited by the closest-hit counting kernel (EXR: raw counts, Y)
//   PREFIX_prims.{png,exr}    ray/primitive tests (EXR: raw counts, Y)
//   PREFIX_depth.{png,exr}    hit distance t (EXR: raw, Z, +inf on a miss; PNG: near white, far dark,
//                             misses black, normalised to the range of the hits)
//   PREFIX_normal.{png,exr}   the hit triangle's unit geometric normal in its winding order (EXR: raw
//                             R, G, B, zero on a miss; PNG: mapped from [-1, 1] to [0, 1])
//
// PNG counts are false colour (viridis) from the image's minimum to its 99.5th percentile (the few
// pixels above it in the top colour); minimum, maximum and the colour range go to the log, so the
// pictures need no legend. `sahbench image-diff A.exr B.exr --out D` writes D.exr (B - A, signed) and
// D.png (diverging blue-grey-red, symmetric about zero, full colour at the 99.5th percentile of the
// non-zero magnitudes) and reports the largest and mean absolute difference.

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace sahbench {

struct ImageCommandOptions {
  std::string scene;
  std::string builder =
      "binned_sah";         ///< NAME or NAME:key=value,... (a registered builder: ours or embree_bvh)
  std::string layout = {};  ///< a layout spec, NAME[:key=value,...]; empty: default_layout of the builder
  uint32_t width = 512, height = 512;
  std::string ray_set = "primary";  ///< only primary rays map one to one onto pixels
  /// A view in place of the scene's camera (scenes/camera.h: look_at_camera), as "x,y,z" texts; eye and
  /// target go together, up and fov need them. Empty: the scene's camera or the automatic framing.
  std::string eye, target, up = "0,1,0";
  float fov = 45.0f;          ///< vertical, degrees
  std::filesystem::path out;  ///< prefix: PREFIX_nodes.png, ...
};

/// The files the command writes for `prefix`, in the order above, PNG then EXR for each map.
std::vector<std::filesystem::path> image_files(const std::filesystem::path& prefix);

/// Builds, compiles, traces and writes the maps; ranges and hit count go to `log`. Bad input (scene,
/// builder, layout, size, ray set, an output folder that does not exist) is an Error naming it.
void run_image_command(const ImageCommandOptions& options, std::ostream& log);

struct ImageDiffOptions {
  std::filesystem::path a, b;
  std::filesystem::path out;  ///< prefix: OUT.exr and OUT.png (an .exr or .png extension is dropped)
};

struct ImageDiffResult {
  double max_abs = 0.0;  ///< over the values both images have (finite, or equal)
  double mean_abs = 0.0;
  uint64_t compared = 0;  ///< values compared (pixels x channels)
  uint64_t differing_pixels = 0;
  /// Values where exactly one image is finite (a hit in one, a miss in the other): NaN in the EXR,
  /// black in the PNG, left out of max_abs and mean_abs.
  uint64_t one_sided = 0;
};

/// Writes B - A; images of different sizes or channel counts are an Error naming both.
ImageDiffResult run_image_diff_command(const ImageDiffOptions& options, std::ostream& log);

}  // namespace sahbench
