// `sahbench image` and `image-diff` on a small procedural sphere: every map is written at the asked
// size, depth and normals agree with brute force pixel by pixel, the per-pixel counts add up to the
// batch counts of every layout, a difference image is B - A (zero against itself), and bad input is
// an error naming what is wrong.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <string_view>

#include "builders/params.h"
#include "builders/registry.h"
#include "cli/image_command.h"
#include "core/build_input.h"
#include "harness/config/config.h"
#include "harness/report/image_io.h"
#include "harness/run/ray_sets.h"
#include "scenes/load.h"
#include "tests/scenes/temp_dir.h"
#include "traversal/brute_force.h"
#include "traversal/layout.h"
#include "traversal/triangle_tests.h"

namespace sahbench {
namespace {

using test::error_message;
using test::TempDir;

constexpr const char* kScene = "proc:sphere:tris=600";
// Not square, so that swapped width and height would show.
constexpr uint32_t kWidth = 24, kHeight = 16;

std::vector<Ray> primary_rays(const Scene& scene, uint32_t width, uint32_t height) {
  RaySetConfig cfg;
  cfg.width = width;
  cfg.height = height;
  return generate_ray_sets(scene, std::span<const RaySetConfig>(&cfg, 1), 1).sets.at(0).rays;
}

ImageCommandOptions options(const std::filesystem::path& prefix, const std::string& builder = "binned_sah") {
  ImageCommandOptions o;
  o.scene = kScene;
  o.builder = builder;
  o.width = kWidth;
  o.height = kHeight;
  o.out = prefix;
  return o;
}

TEST(HarnessImage, MapsHaveTheImageSizeAndMatchBruteForce) {
  TempDir dir;
  std::ostringstream log;
  run_image_command(options(dir.path() / "sphere"), log);
  EXPECT_NE(log.str().find("nodes visited per pixel: min"), std::string::npos) << log.str();

  const auto files = image_files(dir.path() / "sphere");
  ASSERT_EQ(files.size(), 8u);
  const std::size_t channels[] = {3, 1, 3, 1, 3, 1, 3, 3};  // PNGs are RGB; EXR: nodes, prims, depth, normal
  for (std::size_t i = 0; i < files.size(); ++i) {
    ASSERT_TRUE(std::filesystem::is_regular_file(files[i])) << files[i];
    const FloatImage image = read_float_image(files[i]);
    EXPECT_EQ(image.width, kWidth) << files[i];
    EXPECT_EQ(image.height, kHeight) << files[i];
    EXPECT_EQ(image.channel_count(), channels[i]) << files[i];
  }
  const FloatImage nodes = read_float_image(dir.path() / "sphere_nodes.exr");
  const FloatImage prims = read_float_image(dir.path() / "sphere_prims.exr");
  const FloatImage depth = read_float_image(dir.path() / "sphere_depth.exr");
  const FloatImage normal = read_float_image(dir.path() / "sphere_normal.exr");

  const Scene scene = load_scene(kScene);
  const auto rays = primary_rays(scene, kWidth, kHeight);
  std::vector<std::size_t> ray_of_pixel(rays.size());
  const std::vector<uint32_t> order = primary_pixel_order(kWidth, kHeight);
  for (std::size_t i = 0; i < order.size(); ++i) ray_of_pixel[order[i]] = i;
  int hits = 0, misses = 0;
  for (uint32_t y = 0; y < kHeight; ++y)
    for (uint32_t x = 0; x < kWidth; ++x) {
      const Ray& ray = rays[ray_of_pixel[std::size_t{y} * kWidth + x]];
      const Hit ref = brute_force_closest(scene.triangles, ray);
      if (!ref.found()) {
        ++misses;
        EXPECT_TRUE(std::isinf(depth.at(x, y))) << x << "," << y;
        EXPECT_EQ(normal.at(x, y, 0), 0.0f);
        continue;
      }
      ++hits;
      EXPECT_NEAR(depth.at(x, y), ref.t, 1e-5f * ref.t) << x << "," << y;
      EXPECT_GT(nodes.at(x, y), 0.0f) << x << "," << y;
      EXPECT_GT(prims.at(x, y), 0.0f) << x << "," << y;
      const Vec3 got{normal.at(x, y, 0), normal.at(x, y, 1), normal.at(x, y, 2)};
      // Another triangle hit at the same distance (a shared edge) is a tie: its normal is as right.
      auto normal_of_a_hit_at_t = [&] {
        const WatertightTriangleTest test(ray);
        for (const Triangle& tri : scene.triangles) {
          float t, u, v;
          if (test.intersect(tri, ray.tmin, ray.tmax, t, u, v) && t == ref.t &&
              length(got - normalize(tri.normal())) <= 1e-5f)
            return true;
        }
        return false;
      };
      if (length(got - normalize(scene.triangles[ref.prim].normal())) > 1e-5f) {
        EXPECT_TRUE(normal_of_a_hit_at_t()) << "normal of no triangle hit at " << x << "," << y;
      }
      EXPECT_NEAR(length(got), 1.0f, 1e-5f);
    }
  // The automatic framing fits the sphere's bounding sphere in the view: the centre hits, corners miss.
  EXPECT_GT(hits, 0);
  EXPECT_GT(misses, 0);
}

TEST(HarnessImage, PerRayCountsAddUpToTheBatchCountsOfEveryLayout) {
  const Scene scene = load_scene(kScene);
  const auto rays = primary_rays(scene, kWidth, kHeight);
  const BuildInput input = BuildInput::from_triangles(scene.triangles);
  ASSERT_GE(layouts().size(), 2u);
  for (const LayoutInfo& info : layouts()) {
    SCOPED_TRACE(info.name);
    const std::string builder = info.arity == 2 ? "binned_sah" : "wide_binned_sah";
    const BuilderInfo& b = find_builder(builder);
    ParamOverrides overrides;
    if (info.arity != 2) overrides.push_back({"arity", std::to_string(info.arity)});
    const Bvh bvh = b.build(input, resolve_params(b.name, b.params, overrides));
    const auto layout = compile_layout(info.name, bvh, scene.triangles);
    std::vector<TraceCounts> per_ray(rays.size());
    layout->count_closest_per_ray(rays, per_ray);
    const TraceCounts batch = layout->count_closest(rays);
    TraceCounts sum;
    for (const auto& c : per_ray) {
      EXPECT_EQ(c.rays, 1u);
      sum.rays += c.rays;
      sum.nodes_visited += c.nodes_visited;
      sum.prims_tested += c.prims_tested;
    }
    EXPECT_EQ(sum.rays, rays.size());
    EXPECT_GT(sum.nodes_visited, sum.rays / 2);
    EXPECT_EQ(sum.rays, batch.rays) << info.name;
    EXPECT_EQ(sum.nodes_visited, batch.nodes_visited) << info.name;
    EXPECT_EQ(sum.prims_tested, batch.prims_tested) << info.name;
    std::vector<TraceCounts> wrong_size(rays.size() - 1);
    EXPECT_THROW(layout->count_closest_per_ray(rays, wrong_size), Error);
  }
}

TEST(HarnessImage, DiffIsBMinusAAndZeroAgainstItself) {
  TempDir dir;
  std::ostringstream log;
  run_image_command(options(dir.path() / "a", "binned_sah:bins=8"), log);
  run_image_command(options(dir.path() / "b", "sweep_sah"), log);
  const auto a = dir.path() / "a_nodes.exr", b = dir.path() / "b_nodes.exr";

  const ImageDiffResult self = run_image_diff_command({a, a, dir.path() / "self"}, log);
  EXPECT_EQ(self.max_abs, 0.0);
  EXPECT_EQ(self.mean_abs, 0.0);
  EXPECT_EQ(self.differing_pixels, 0u);
  EXPECT_EQ(self.compared, std::size_t{kWidth} * kHeight);
  for (const float v : read_float_image(dir.path() / "self.exr").pixels) EXPECT_EQ(v, 0.0f);
  EXPECT_TRUE(std::filesystem::is_regular_file(dir.path() / "self.png"));

  const ImageDiffResult ab = run_image_diff_command({a, b, dir.path() / "ab.exr"}, log);
  const FloatImage ia = read_float_image(a), ib = read_float_image(b),
                   d = read_float_image(dir.path() / "ab.exr");
  double max_abs = 0.0;
  uint64_t differing = 0;
  for (std::size_t i = 0; i < d.pixels.size(); ++i) {
    EXPECT_EQ(d.pixels[i], ib.pixels[i] - ia.pixels[i]) << i;
    max_abs = std::max(max_abs, std::fabs(double{ib.pixels[i]} - ia.pixels[i]));
    differing += ia.pixels[i] != ib.pixels[i];
  }
  EXPECT_GT(max_abs, 0.0) << "two different trees should visit different node counts somewhere";
  EXPECT_EQ(ab.max_abs, max_abs);
  EXPECT_EQ(ab.differing_pixels, differing);

  // Depth: the same hits (both exact against the same triangles), misses (+inf) in the same pixels.
  const ImageDiffResult depth = run_image_diff_command(
      {dir.path() / "a_depth.exr", dir.path() / "b_depth.exr", dir.path() / "depth"}, log);
  EXPECT_EQ(depth.one_sided, 0u);
  EXPECT_LE(depth.max_abs, 1e-5);
  // The normal maps have three channels.
  EXPECT_EQ(run_image_diff_command(
                {dir.path() / "a_normal.exr", dir.path() / "a_normal.exr", dir.path() / "n"}, log)
                .compared,
            3u * kWidth * kHeight);
}

TEST(HarnessImage, EyeAndTargetGiveTheView) {
  TempDir dir;
  // Facing the sphere from close by it fills the picture; facing away, every pixel misses.
  auto facing = options(dir.path() / "facing");
  facing.eye = "0,0,3";
  facing.target = "0,0,0";
  facing.fov = 30.0f;
  std::ostringstream facing_log;
  run_image_command(facing, facing_log);
  auto hits = [](const std::string& log) {
    const std::size_t end = log.find(" hits\n"), start = log.rfind(' ', end - 1);
    return end == std::string::npos ? -1 : std::stoi(log.substr(start + 1, end - start - 1));
  };
  // The automatic framing leaves a margin round the sphere; this view does not.
  std::ostringstream automatic_log;
  run_image_command(options(dir.path() / "automatic"), automatic_log);
  EXPECT_GT(hits(facing_log.str()), hits(automatic_log.str()) * 3 / 2)
      << facing_log.str() << automatic_log.str();
  auto away = facing;
  away.out = dir.path() / "away";
  away.target = "0,0,6";
  std::ostringstream away_log;
  run_image_command(away, away_log);
  EXPECT_EQ(hits(away_log.str()), 0) << away_log.str();
  EXPECT_NE(away_log.str().find("depth: no hits"), std::string::npos) << away_log.str();

  std::ostringstream log;
  // Each bad view is an error that names the option and its value, and writes nothing.
  auto expect_error = [&](auto view, std::string_view text) {
    view.out = dir.path() / "bad";
    const std::string message = error_message([&] { run_image_command(view, log); });
    EXPECT_NE(message.find(text), std::string::npos) << "expected '" << text << "' in: " << message;
  };
  auto lone_eye = options(dir.path() / "x");
  lone_eye.eye = "0,0,3";
  expect_error(lone_eye, "--eye and --target go together");
  auto short_target = facing;
  short_target.target = "0,0";
  expect_error(short_target, "--target '0,0': expected three numbers");
  auto junk = facing;
  junk.up = "0,1,x";
  expect_error(junk, "--up '0,1,x'");
  auto spaced = facing;
  spaced.out = dir.path() / "spaced";
  spaced.eye = " 0 , 0,3 ";
  run_image_command(spaced, log);
  auto infinite = facing;
  infinite.eye = "1e999,0,3";
  expect_error(infinite, "--eye '1e999,0,3': '1e999' is not a finite");
  auto wide = facing;
  wide.fov = 200.0f;
  expect_error(wide, "--fov 200: camera fov = 200 degrees");
  auto four = facing;
  four.eye = "0,0,3,4";
  expect_error(four, "--eye '0,0,3,4'");
  auto same = facing;
  same.target = "0,0,3";
  expect_error(same, "must differ from the eye");
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    EXPECT_NE(entry.path().filename().string().rfind("bad", 0), 0u) << "written on error: " << entry.path();
}

TEST(HarnessImage, BadInputIsAnErrorNamingIt) {
  TempDir dir;
  std::ostringstream log;
  const auto missing_folder = dir.path() / "no_such_folder" / "img";
  EXPECT_NE(error_message([&] { run_image_command(options(missing_folder), log); }).find("does not exist"),
            std::string::npos);
  auto shadow = options(dir.path() / "x");
  shadow.ray_set = "shadow";
  EXPECT_NE(error_message([&] { run_image_command(shadow, log); }).find("'shadow'"), std::string::npos);
  EXPECT_NE(error_message([&] {
              run_image_command(options(dir.path() / "x", "embree_medium"), log);
            }).find("embree_bvh"),
            std::string::npos);
  auto empty = options(dir.path() / "x");
  empty.width = 0;
  EXPECT_NE(error_message([&] { run_image_command(empty, log); }).find("0x16"), std::string::npos);
  auto bad_layout = options(dir.path() / "x");
  bad_layout.layout = "bvh3";
  EXPECT_NE(error_message([&] { run_image_command(bad_layout, log); }).find("bvh3"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "x_nodes.png"));

  run_image_command(options(dir.path() / "small"), log);
  auto square = options(dir.path() / "square");
  square.width = kHeight;
  run_image_command(square, log);
  const auto missing = dir.path() / "missing.exr";
  EXPECT_NE(error_message([&] {
              run_image_diff_command({missing, dir.path() / "small_nodes.exr", dir.path() / "d"}, log);
            }).find("missing.exr"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              run_image_diff_command(
                  {dir.path() / "small_nodes.exr", dir.path() / "square_nodes.exr", dir.path() / "d"}, log);
            }).find("not comparable"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              run_image_diff_command(
                  {dir.path() / "small_nodes.exr", dir.path() / "small_normal.exr", dir.path() / "d"}, log);
            }).find("3 channels"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              run_image_diff_command(
                  {dir.path() / "small_nodes.exr", dir.path() / "small_nodes.exr", missing_folder}, log);
            }).find("does not exist"),
            std::string::npos);
  // Maps of two kinds (node counts against depths), and the PNG pictures of maps, are no values to subtract.
  EXPECT_NE(error_message([&] {
              run_image_diff_command(
                  {dir.path() / "small_nodes.exr", dir.path() / "small_depth.exr", dir.path() / "d"}, log);
            }).find("is a map of nodes, " + (dir.path() / "small_depth.exr").string() + " one of depth"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              run_image_diff_command(
                  {dir.path() / "small_nodes.png", dir.path() / "small_nodes.png", dir.path() / "d"}, log);
            }).find("small_nodes.png: an image of integer samples"),
            std::string::npos);
  EXPECT_EQ(read_float_image(dir.path() / "small_prims.exr").kind, "prims");
}

}  // namespace
}  // namespace sahbench
