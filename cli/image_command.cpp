#include "cli/image_command.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <optional>
#include <ostream>

#include "builders/registry.h"
#include "core/build_input.h"
#include "core/error.h"
#include "core/validate.h"
#include "harness/config/config.h"
#include "harness/report/color_maps.h"
#include "harness/report/image_io.h"
#include "harness/run/ray_sets.h"
#include "scenes/load.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

constexpr const char* kMapNames[] = {"nodes", "prims", "depth", "normal"};

// The false-colour scales end at this quantile of the values, not at the largest: a few pixels on
// silhouettes and grazing edges visit several times the nodes of the rest, and a scale stretched to
// them leaves the picture dark. Values above it are drawn in the top colour; the log gives both ends.
constexpr double kColourScaleQuantile = 0.995;

// The kColourScaleQuantile quantile of `values` (nearest rank); 0 for none.
float scale_top(std::vector<float> values) {
  if (values.empty()) return 0.0f;
  const auto k = static_cast<std::size_t>(kColourScaleQuantile * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

std::filesystem::path with_suffix(const std::filesystem::path& prefix, const std::string& suffix) {
  return prefix.parent_path() / (prefix.filename().string() + suffix);
}

// Checked before any work, so that a typo in --out fails at once rather than after the build and trace.
void check_output_folder(const std::filesystem::path& prefix, const char* option) {
  if (prefix.empty() || prefix.filename().empty())
    throw Error(std::string(option) + " '" + prefix.string() + "': needs a file name prefix, not a folder");
  const auto folder = prefix.parent_path().empty() ? std::filesystem::path(".") : prefix.parent_path();
  if (!std::filesystem::is_directory(folder))
    throw Error(std::string(option) + " '" + prefix.string() + "': the folder '" + folder.string() +
                "' does not exist");
}

struct Range {
  float lo = std::numeric_limits<float>::infinity();
  float hi = -std::numeric_limits<float>::infinity();
  void add(float v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool empty() const { return lo > hi; }
  // [lo, hi] onto [0, 1]; a flat image maps to 0.
  float normalise(float v) const { return hi > lo ? (v - lo) / (hi - lo) : 0.0f; }
};

RgbImage false_colour(const FloatImage& counts, const Range& range) {
  RgbImage png{counts.width, counts.height, std::vector<uint8_t>(counts.pixels.size() * 3)};
  for (std::size_t i = 0; i < counts.pixels.size(); ++i) {
    const Rgb8 c = sequential_color(range.normalise(counts.pixels[i]));
    std::copy(c.begin(), c.end(), png.pixels.begin() + static_cast<std::ptrdiff_t>(3 * i));
  }
  return png;
}

// "x,y,z" as a finite point or direction for option `option` (blanks around the numbers allowed).
Vec3 parse_vec3(const std::string& text, const char* option) {
  auto fail = [&](const std::string& why) -> Error {
    return Error(std::string(option) + " '" + text + "': " + why);
  };
  Vec3 out;
  std::size_t at = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = text.find(',', at);
    if ((i < 2) != (comma != std::string::npos)) throw fail("expected three numbers, x,y,z");
    const std::size_t end = i < 2 ? comma : text.size();
    std::string part = text.substr(at, end - at);
    part.erase(0, part.find_first_not_of(" \t"));
    part.erase(part.find_last_not_of(" \t") + 1);
    char* stop = nullptr;
    const float v = part.empty() ? 0.0f : std::strtof(part.c_str(), &stop);
    if (part.empty() || stop != part.c_str() + part.size()) throw fail("expected three numbers, x,y,z");
    if (!std::isfinite(v)) throw fail("'" + part + "' is not a finite number");
    out[i] = v;
    at = end + 1;
  }
  return out;
}

uint8_t to_byte(float v) {
  return static_cast<uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

}  // namespace

std::vector<std::filesystem::path> image_files(const std::filesystem::path& prefix) {
  std::vector<std::filesystem::path> files;
  for (const char* map : kMapNames)
    for (const char* ext : {".png", ".exr"})
      files.push_back(with_suffix(prefix, std::string("_") + map + ext));
  return files;
}

void run_image_command(const ImageCommandOptions& options, std::ostream& log) {
  check_output_folder(options.out, "--out");
  if (options.ray_set != "primary") {
    if (!parse_ray_kind(options.ray_set))
      throw Error("--ray-set '" + options.ray_set + "': no such ray set; per-pixel maps are of the primary " +
                  "rays (--ray-set primary, the default)");
    throw Error("--ray-set '" + options.ray_set +
                "': per-pixel maps need one ray per pixel, which only the primary "
                "set has (secondary sets start from the primary hits only)");
  }
  if (options.width == 0 || options.height == 0 || options.width > kMaxImageSide ||
      options.height > kMaxImageSide)
    throw Error(fmt::format("image size {}x{}: each side must be in 1..{}", options.width, options.height,
                            kMaxImageSide));
  BuilderRun spec = parse_builder_run(options.builder);
  if (spec.is_embree())
    throw Error("--builder '" + options.builder +
                "': Embree's own BVH cannot be traversed with counters here; "
                "embree_bvh builds Embree's tree in our format");
  resolve(spec);
  const BuilderInfo& info = *spec.info;
  const ParamSet& params = spec.values;
  const LayoutSpec layout_spec =
      parse_layout_spec(options.layout.empty() ? default_layout(spec) : options.layout);
  if (const auto why = layout_unavailable(layout_spec))
    throw Error("--layout '" + layout_spec.text() + "': " + *why);
  require_layout_of_arity(spec, layout_spec);

  if (options.eye.empty() != options.target.empty())
    throw Error("--eye and --target go together: give both, or neither for the scene's own view");
  std::optional<Camera> view;
  if (!options.eye.empty()) {
    const Vec3 eye = parse_vec3(options.eye, "--eye"), target = parse_vec3(options.target, "--target"),
               up = parse_vec3(options.up, "--up");
    try {
      view = look_at_camera(eye, target, up, options.fov);
    } catch (const Error& e) {
      throw Error(fmt::format("--eye {} --target {} --up {} --fov {}: {}", options.eye, options.target,
                              options.up, options.fov, e.what()));
    }
  }

  Scene scene = load_scene(options.scene);
  if (view) scene.camera = view;
  if (scene.triangles.empty()) throw Error("scene '" + options.scene + "' has no triangles");
  const Bvh bvh = info.build(BuildInput::from_triangles(scene.triangles), params);
  const ValidationReport valid = validate(bvh, std::span<const Triangle>(scene.triangles));
  if (!valid.ok())
    throw Error(info.name + " built an invalid tree on '" + options.scene + "':\n" + valid.summary());
  const auto layout = compile_layout(layout_spec, bvh, scene.triangles);

  RaySetConfig primary;
  primary.name = "primary";
  primary.width = options.width;
  primary.height = options.height;
  // Primary rays do not depend on the seed; 1 is the configs' default.
  const GeneratedRaySets generated = generate_ray_sets(scene, std::span<const RaySetConfig>(&primary, 1), 1);
  if (generated.sets.empty())
    throw Error("scene '" + options.scene + "': " + generated.skipped.front().second);
  const std::vector<Ray>& rays = generated.sets.front().rays;

  std::vector<Hit> hits(rays.size());
  std::vector<TraceCounts> counts(rays.size());
  layout->trace_closest(rays, hits);
  layout->count_closest_per_ray(rays, counts);

  const uint32_t w = options.width, h = options.height;
  const std::vector<uint32_t> pixel = primary_pixel_order(w, h);  // ray i's pixel
  FloatImage nodes{w, h, {"Y"}, std::vector<float>(rays.size()), kMapNames[0]};
  FloatImage prims{w, h, {"Y"}, std::vector<float>(rays.size()), kMapNames[1]};
  FloatImage depth{w, h, {"Z"}, std::vector<float>(rays.size()), kMapNames[2]};
  FloatImage normal{w, h, {"R", "G", "B"}, std::vector<float>(3 * rays.size(), 0.0f), kMapNames[3]};
  Range node_range, prim_range, depth_range;  // [min, max] of each map
  std::size_t hit_count = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const std::size_t p = pixel[i];
    nodes.pixels[p] = static_cast<float>(counts[i].nodes_visited);
    prims.pixels[p] = static_cast<float>(counts[i].prims_tested);
    node_range.add(nodes.pixels[p]);
    prim_range.add(prims.pixels[p]);
    depth.pixels[p] = hits[i].found() ? hits[i].t : std::numeric_limits<float>::infinity();
    if (!hits[i].found()) continue;
    ++hit_count;
    depth_range.add(hits[i].t);
    const Vec3 n = normalize(scene.triangles[hits[i].prim].normal());
    for (int c = 0; c < 3; ++c) normal.pixels[3 * p + c] = n[c];
  }

  RgbImage depth_png{w, h, std::vector<uint8_t>(3 * rays.size(), 0)};
  RgbImage normal_png{w, h, std::vector<uint8_t>(3 * rays.size(), 0)};
  for (std::size_t p = 0; p < rays.size(); ++p) {
    if (!std::isfinite(depth.pixels[p])) continue;
    // Near bright, far dark; a flat range (one hit distance) is drawn bright.
    const uint8_t grey = to_byte(1.0f - 0.9f * depth_range.normalise(depth.pixels[p]));
    std::fill_n(depth_png.pixels.begin() + static_cast<std::ptrdiff_t>(3 * p), 3, grey);
    for (int c = 0; c < 3; ++c)
      normal_png.pixels[3 * p + c] = to_byte(0.5f * (normal.pixels[3 * p + c] + 1.0f));
  }

  const Range node_scale{node_range.lo, std::max(node_range.lo, scale_top(nodes.pixels))};
  const Range prim_scale{prim_range.lo, std::max(prim_range.lo, scale_top(prims.pixels))};
  const auto files = image_files(options.out);
  write_rgb_image(files[0], false_colour(nodes, node_scale));
  write_float_image(files[1], nodes);
  write_rgb_image(files[2], false_colour(prims, prim_scale));
  write_float_image(files[3], prims);
  write_rgb_image(files[4], depth_png);
  write_float_image(files[5], depth);
  write_rgb_image(files[6], normal_png);
  write_float_image(files[7], normal);

  fmt::print(log, "{} on {} ({} triangles), layout {}: {}x{} primary rays, {} hits\n",
             info.name + " " + params.to_string(), scene.name, scene.triangles.size(), layout_spec.text(), w,
             h, hit_count);
  fmt::print(log,
             "nodes visited per pixel: min {} max {} (PNG colours from {} to {})\n"
             "primitives tested per pixel: min {} max {} (PNG colours from {} to {})\n",
             node_range.lo, node_range.hi, node_scale.lo, node_scale.hi, prim_range.lo, prim_range.hi,
             prim_scale.lo, prim_scale.hi);
  if (depth_range.empty())
    fmt::print(log, "depth: no hits\n");
  else
    fmt::print(log, "depth: min {:.6g} max {:.6g} (PNG: near bright, far dark, misses black)\n",
               depth_range.lo, depth_range.hi);
  fmt::print(log, "wrote {}_{{nodes,prims,depth,normal}}.{{png,exr}}\n", options.out.string());
}

ImageDiffResult run_image_diff_command(const ImageDiffOptions& options, std::ostream& log) {
  std::filesystem::path prefix = options.out;
  if (prefix.extension() == ".exr" || prefix.extension() == ".png") prefix.replace_extension();
  check_output_folder(prefix, "--out");
  const FloatImage a = read_float_image(options.a);
  const FloatImage b = read_float_image(options.b);
  for (const auto& [image, path] : {std::pair{&a, &options.a}, std::pair{&b, &options.b}})
    if (image->from_integers)
      throw Error(path->string() +
                  ": an image of integer samples (as the PNGs, false-colour pictures of the maps); "
                  "image-diff compares the values, in the .exr files that sahbench image writes beside them");
  if (a.width != b.width || a.height != b.height || a.channel_count() != b.channel_count())
    throw Error(fmt::format("{} is {}x{} with {} channels, {} is {}x{} with {} channels: not comparable",
                            options.a.string(), a.width, a.height, a.channel_count(), options.b.string(),
                            b.width, b.height, b.channel_count()));
  if (!a.kind.empty() && !b.kind.empty() && a.kind != b.kind)
    throw Error(fmt::format("{} is a map of {}, {} one of {}: not comparable", options.a.string(), a.kind,
                            options.b.string(), b.kind));

  FloatImage diff{a.width, a.height, a.channels, std::vector<float>(a.pixels.size()),
                  a.kind.empty() ? std::string() : a.kind + " difference"};
  ImageDiffResult result;
  double sum_abs = 0.0;
  for (std::size_t i = 0; i < a.pixels.size(); ++i) {
    const float va = a.pixels[i], vb = b.pixels[i];
    float d;
    if (va == vb) {
      d = 0.0f;  // also both +inf (a miss in both depth images)
    } else if (std::isfinite(va) != std::isfinite(vb)) {
      d = std::numeric_limits<float>::quiet_NaN();
      ++result.one_sided;
    } else {
      d = vb - va;
    }
    diff.pixels[i] = d;
    if (std::isnan(d)) continue;
    ++result.compared;
    result.max_abs = std::max(result.max_abs, static_cast<double>(std::fabs(d)));
    sum_abs += std::fabs(d);
  }
  result.mean_abs = result.compared ? sum_abs / static_cast<double>(result.compared) : 0.0;

  // PNG: per pixel, the channel whose difference is largest in magnitude, on a scale symmetric about 0
  // that ends at the kColourScaleQuantile quantile of the non-zero magnitudes.
  std::vector<float> magnitudes;
  for (const float d : diff.pixels)
    if (d != 0.0f && !std::isnan(d)) magnitudes.push_back(std::fabs(d));
  const float scale = scale_top(std::move(magnitudes));
  const std::size_t channels = a.channel_count();
  RgbImage png{a.width, a.height, std::vector<uint8_t>(3 * std::size_t{a.width} * a.height, 0)};
  for (std::size_t p = 0; p < std::size_t{a.width} * a.height; ++p) {
    float strongest = 0.0f;
    bool one_sided = false, differs = false;
    for (std::size_t c = 0; c < channels; ++c) {
      const float d = diff.pixels[p * channels + c];
      if (std::isnan(d)) {
        one_sided = true;
      } else if (std::fabs(d) > std::fabs(strongest)) {
        strongest = d;
      }
      differs = differs || d != 0.0f;  // NaN != 0: a one-sided value is a difference
    }
    result.differing_pixels += differs;
    if (one_sided) continue;  // black
    const Rgb8 colour = diverging_color(scale > 0 ? strongest / scale : 0.0f);
    std::copy(colour.begin(), colour.end(), png.pixels.begin() + static_cast<std::ptrdiff_t>(3 * p));
  }

  write_float_image(with_suffix(prefix, ".exr"), diff);
  write_rgb_image(with_suffix(prefix, ".png"), png);
  fmt::print(
      log, "{} - {}: {}x{}, {} channel{}: max |diff| {:.6g}, mean |diff| {:.6g}, {} of {} pixels differ{}\n",
      options.b.string(), options.a.string(), a.width, a.height, channels, channels == 1 ? "" : "s",
      result.max_abs, result.mean_abs, result.differing_pixels, std::size_t{a.width} * a.height,
      result.one_sided
          ? fmt::format(", {} values finite in only one image (NaN in the EXR, black in the PNG)",
                        result.one_sided)
          : "");
  fmt::print(log, "wrote {}.exr (B - A) and {}.png (blue: B < A, red: B > A, full colour at +-{:.6g})\n",
             prefix.string(), prefix.string(), scale);
  return result;
}

}  // namespace sahbench
