#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "builders/binned_sah.h"
#include "core/build_input.h"
#include "core/error.h"
#include "harness/run/ray_sets.h"
#include "harness/run/result_row.h"
#include "scenes/load.h"
#include "traversal/brute_force.h"

namespace sahbench {
namespace {

std::vector<RaySetConfig> all_kinds() {
  std::vector<RaySetConfig> c(5);
  const RayKind kinds[] = {RayKind::kPrimary, RayKind::kShadow, RayKind::kDiffuse, RayKind::kAmbientOcclusion,
                           RayKind::kRandom};
  for (int i = 0; i < 5; ++i) {
    c[i].kind = kinds[i];
    c[i].name = to_string(kinds[i]);
    c[i].width = c[i].height = 48;
    c[i].count = kinds[i] == RayKind::kRandom ? 3000 : 0;
  }
  return c;
}

bool same_rays(const std::vector<Ray>& a, const std::vector<Ray>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!(a[i].org == b[i].org && a[i].dir == b[i].dir && a[i].tmin == b[i].tmin && a[i].tmax == b[i].tmax))
      return false;
  return true;
}

// The primary ray of pixel (x, y) of a width-wide image.
const Ray& ray_at(const std::vector<Ray>& rays, uint32_t width, uint32_t height, uint32_t x, uint32_t y) {
  const std::vector<uint32_t> order = primary_pixel_order(width, height);
  const auto i = std::find(order.begin(), order.end(), y * width + x) - order.begin();
  return rays.at(static_cast<std::size_t>(i));
}

TEST(HarnessRaySets, SameSeedSameRaysForAnyThreadCount) {
  const Scene scene = load_scene("proc:sphere:tris=5000");
  const auto configs = all_kinds();
  auto generate = [&](int threads, uint64_t seed) {
    tbb::task_arena arena(threads);
    return arena.execute([&] { return generate_ray_sets(scene, configs, seed); });
  };
  const auto one = generate(1, 3), two = generate(2, 3), other = generate(2, 4);
  ASSERT_EQ(one.sets.size(), 5u);
  for (std::size_t s = 0; s < one.sets.size(); ++s) {
    EXPECT_TRUE(same_rays(one.sets[s].rays, two.sets[s].rays)) << one.sets[s].name;
    EXPECT_FALSE(one.sets[s].rays.empty());
  }
  // Primary rays do not depend on the seed; the random sets do.
  EXPECT_TRUE(same_rays(one.sets[0].rays, other.sets[0].rays));
  EXPECT_FALSE(same_rays(one.sets[2].rays, other.sets[2].rays));
  EXPECT_FALSE(same_rays(one.sets[4].rays, other.sets[4].rays));
}

TEST(HarnessRaySets, KindsHaveTheirQueriesAndExtents) {
  const Scene scene = load_scene("proc:sphere:tris=5000");
  const auto out = generate_ray_sets(scene, all_kinds(), 1);
  ASSERT_EQ(out.sets.size(), 5u);
  EXPECT_FALSE(out.sets[0].occlusion);
  EXPECT_TRUE(out.sets[1].occlusion);   // shadow
  EXPECT_FALSE(out.sets[2].occlusion);  // diffuse
  EXPECT_TRUE(out.sets[3].occlusion);   // ao
  // The automatic camera frames the whole sphere: a good share of primary rays hit it.
  std::size_t hits = 0;
  for (const Ray& r : out.sets[0].rays) hits += brute_force_closest(scene.triangles, r).found();
  EXPECT_GT(hits, out.sets[0].rays.size() / 5);
  // Secondary sets have one ray per primary hit; shadow rays end just before their light (t < 1).
  EXPECT_EQ(out.sets[1].rays.size(), hits);
  for (const Ray& r : out.sets[1].rays) EXPECT_LT(r.tmax, 1.0f);
  for (const Ray& r : out.sets[3].rays) EXPECT_TRUE(std::isfinite(r.tmax));
}

TEST(HarnessRaySets, DiffuseRaysLeaveTheSurfaceWithoutHittingItAgain) {
  // From the outside of a closed sphere, a ray leaving the surface outward must not hit the triangle it
  // starts on: the origin offset (Waechter and Binder 2019) keeps it off the surface.
  const Scene scene = load_scene("proc:sphere:tris=5000");
  auto configs = all_kinds();
  const auto out = generate_ray_sets(scene, configs, 1);
  std::size_t self_hits = 0;
  for (const Ray& r : out.sets[2].rays) {
    const Hit h = brute_force_closest(scene.triangles, r);
    self_hits += h.found() && h.t < 1e-3f;
  }
  EXPECT_EQ(self_hits, 0u);
}

TEST(HarnessRaySets, SceneLightsMissingSkipsTheSetWithAReason) {
  const Scene scene = load_scene("proc:sphere:tris=2000");
  RaySetConfig shadow;
  shadow.name = "shadow_scene";
  shadow.kind = RayKind::kShadow;
  shadow.light_source = "scene";
  const auto out = generate_ray_sets(scene, std::vector<RaySetConfig>{shadow}, 1);
  EXPECT_TRUE(out.sets.empty());
  ASSERT_EQ(out.skipped.size(), 1u);
  EXPECT_EQ(out.skipped[0].first, "shadow_scene");
  EXPECT_NE(out.skipped[0].second.find("no lights"), std::string::npos);
}

// A closed sphere encloses the automatic lights that land inside it (its box's top tenth is partly
// inside): the shadow set lists them, in a note its rows carry, and every shadow ray to them is occluded.
// A light of the scene's own at the centre is enclosed, one above the sphere is not, and a single
// triangle encloses nothing.
TEST(HarnessRaySets, ShadowSetNotesTheLightsTheSceneEncloses) {
  Scene scene = load_scene("proc:sphere:tris=2000");
  RaySetConfig automatic;
  automatic.name = "shadow";
  automatic.kind = RayKind::kShadow;
  automatic.width = automatic.height = 32;
  RaySetConfig own = automatic;
  own.name = "shadow_scene";
  own.light_source = "scene";
  Aabb box;
  for (const Triangle& t : scene.triangles) box.extend(t.bounds());
  const Vec3 centre = box.center();
  const float radius = 0.5f * box.extent().y;
  scene.lights = {centre + Vec3{0.0f, 2.0f * radius, 0.0f}, centre};
  const auto out = generate_ray_sets(scene, std::vector<RaySetConfig>{automatic, own}, 1);
  ASSERT_EQ(out.sets.size(), 2u);

  // Which automatic lights lie inside, by their distance to the centre: none is within 1% of the radius of
  // the surface, where 2000 triangles stray from the sphere by about 0.2%.
  const std::vector<Vec3> lights = automatic_lights(scene, automatic.lights, 1);
  std::vector<std::size_t> inside;
  for (std::size_t i = 0; i < lights.size(); ++i) {
    const float d = length(lights[i] - centre);
    ASSERT_GT(std::abs(d - radius), 0.01f * radius) << "light " << i << " too near the surface to tell";
    if (d < radius) inside.push_back(i);
  }
  ASSERT_FALSE(inside.empty());
  ASSERT_LT(inside.size(), lights.size());
  std::string listed;
  for (const std::size_t i : inside) listed += (listed.empty() ? "" : ", ") + std::to_string(i + 1);
  EXPECT_NE(out.sets[0].note.find(listed + " of 4 enclosed"), std::string::npos) << out.sets[0].note;
  for (std::size_t i = 0; i < out.sets[0].rays.size(); ++i) {
    if (std::find(inside.begin(), inside.end(), i % lights.size()) != inside.end()) {
      EXPECT_TRUE(brute_force_any(scene.triangles, out.sets[0].rays[i])) << "shadow ray " << i;
    }
  }
  EXPECT_NE(out.sets[1].note.find("scene light 2 of 2 enclosed"), std::string::npos) << out.sets[1].note;

  CsvRow row;
  put_ray_set(row, out.sets[0]);
  EXPECT_EQ(row.at("notes"), out.sets[0].note);

  const Bvh bvh = build_binned_sah(BuildInput::from_triangles(scene.triangles), {});
  EXPECT_TRUE(enclosed(bvh, scene.triangles, centre));
  EXPECT_FALSE(enclosed(bvh, scene.triangles, scene.lights[0]));
  const std::vector<Triangle> one{{{-1, 0, -1}, {1, 0, -1}, {0, 0, 1}}};
  const Bvh single = build_binned_sah(BuildInput::from_triangles(one), {});
  EXPECT_FALSE(enclosed(single, one, Vec3{0.0f, 0.5f, 0.0f}));
}

TEST(HarnessRaySets, PrimaryRaysComeInTilesOfFourByFour) {
  // 10 x 7: partial tiles at the right and bottom edges.
  constexpr uint32_t kW = 10, kH = 7;
  const std::vector<uint32_t> order = primary_pixel_order(kW, kH);
  ASSERT_EQ(order.size(), std::size_t{kW} * kH);
  std::vector<int> seen(order.size(), 0);
  for (uint32_t p : order) ++seen.at(p);
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), static_cast<std::ptrdiff_t>(order.size()));
  // The first tile row by row, then the next tile to the right, then the part of a tile at the edge.
  const std::vector<uint32_t> first(order.begin(), order.begin() + 24);
  EXPECT_EQ(first, (std::vector<uint32_t>{0,  1,  2,  3,  10, 11, 12, 13, 20, 21, 22, 23,
                                          30, 31, 32, 33, 4,  5,  6,  7,  14, 15, 16, 17}));
  EXPECT_EQ(order[32], 8u);
  EXPECT_EQ(order[33], 9u);
  EXPECT_EQ(order[34], 18u);
  EXPECT_EQ(order[40], 40u);  // the second row of tiles starts at row 4
  EXPECT_EQ(order.back(), 69u);

  // Each ray is its pixel's: the look-at camera's directions recomputed here for (x, y).
  Scene scene = load_scene("proc:sphere:tris=200");
  const Vec3 eye{0.0f, 0.0f, 5.0f}, target{0.0f, 0.0f, 0.0f}, up{0.0f, 1.0f, 0.0f};
  scene.camera = look_at_camera(eye, target, up, 60.0f);
  RaySetConfig primary;
  primary.width = kW;
  primary.height = kH;
  const auto out = generate_ray_sets(scene, std::vector<RaySetConfig>{primary}, 1);
  ASSERT_EQ(out.sets.size(), 1u);
  const auto& rays = out.sets[0].rays;
  ASSERT_EQ(rays.size(), order.size());
  const float half_h = std::tan(0.5f * 60.0f * 3.14159265f / 180.0f), half_w = half_h * kW / kH;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const uint32_t x = order[i] % kW, y = order[i] / kW;
    const float sx = (2.0f * (x + 0.5f) / kW - 1.0f) * half_w, sy = (1.0f - 2.0f * (y + 0.5f) / kH) * half_h;
    // Looking down -z with y up: right is +x.
    const Vec3 want = normalize(Vec3{sx, sy, -1.0f});
    EXPECT_NEAR(rays[i].dir.x, want.x, 1e-5f) << "ray " << i << ", pixel " << x << "," << y;
    EXPECT_NEAR(rays[i].dir.y, want.y, 1e-5f) << "ray " << i << ", pixel " << x << "," << y;
    EXPECT_NEAR(rays[i].dir.z, want.z, 1e-5f) << "ray " << i << ", pixel " << x << "," << y;
  }
}

TEST(HarnessRaySets, LookAtCameraAimsThePrimaryRaysAndRejectsBadViews) {
  Scene scene = load_scene("proc:sphere:tris=2000");
  const Vec3 eye{3.0f, 1.0f, -2.0f}, target{0.0f, 0.0f, 0.0f};
  scene.camera = look_at_camera(eye, target, Vec3{0.0f, 2.0f, 0.0f}, 30.0f);
  EXPECT_EQ(scene.camera->up, (Vec3{0.0f, 1.0f, 0.0f}));
  EXPECT_FLOAT_EQ(scene.camera->yfov, 30.0f * 3.14159265f / 180.0f);
  RaySetConfig primary;
  primary.width = primary.height = 33;  // odd: the centre pixel looks at the target
  const auto out = generate_ray_sets(scene, std::vector<RaySetConfig>{primary}, 1);
  ASSERT_EQ(out.sets.size(), 1u);
  const auto& rays = out.sets[0].rays;
  for (const Ray& r : rays) EXPECT_EQ(r.org, eye);
  const Vec3 centre = ray_at(rays, 33, 33, 16, 16).dir, toward = normalize(target - eye);
  EXPECT_NEAR(dot(centre, toward), 1.0f, 1e-6f);
  // Row 0 is the top of the image: its rays point further up than the bottom row's.
  const Vec3 top = ray_at(rays, 33, 33, 16, 0).dir, bottom = ray_at(rays, 33, 33, 16, 32).dir;
  EXPECT_GT(top.y, bottom.y);
  // The view spans the field of view: the top and bottom rows' rays are about 30 degrees apart.
  const float spread = std::acos(dot(top, bottom)) * 180.0f / 3.14159265f;
  EXPECT_NEAR(spread, 30.0f * 32.0f / 33.0f, 0.1f);

  auto message = [](auto&& make) {
    try {
      make();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const Vec3 up{0.0f, 1.0f, 0.0f};
  EXPECT_NE(message([&] { look_at_camera(eye, eye, up, 45.0f); }).find("must differ from the eye"),
            std::string::npos);
  EXPECT_NE(message([&] { look_at_camera(eye, target, eye, 45.0f); }).find("not parallel"),
            std::string::npos);
  EXPECT_NE(message([&] { look_at_camera(eye, target, up, 180.0f); }).find("(0, 180)"), std::string::npos);
  EXPECT_NE(message([&] { look_at_camera(eye, target, up, -1.0f); }).find("fov = -1"), std::string::npos);
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_NE(message([&] {
              look_at_camera(Vec3{inf, 0, 0}, target, up, 45.0f);
            }).find("eye (inf, 0, 0) is not finite"),
            std::string::npos);
  EXPECT_NE(message([&] { look_at_camera(eye, target, up, std::nanf("")); }).find("fov = nan"),
            std::string::npos);
  // A distance whose float square overflows is still a distance.
  const Camera far = look_at_camera(Vec3{0, 0, 1e30f}, Vec3{0, 0, 0}, up, 45.0f);
  EXPECT_EQ(far.forward.z, -1.0f);
  EXPECT_NE(message([&] {
              look_at_camera(Vec3{0, 0, 3e38f}, Vec3{0, 0, -3e38f}, up, 45.0f);
            }).find("by a finite, non-zero distance"),
            std::string::npos);
}

}  // namespace
}  // namespace sahbench
