#include "harness/run/ray_sets.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <optional>

#include "builders/binned_sah.h"
#include "core/build_input.h"
#include "core/error.h"
#include "traversal/bvh2_traversal.h"

namespace sahbench {
namespace {

// splitmix64 (Steele, Lea and Flood 2014): a counter-based generator, so ray i's numbers do not depend
// on which thread makes it or in what order.
uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

class RayRng {
 public:
  RayRng(uint64_t seed, uint64_t set, uint64_t index)
      : state_(splitmix64(seed ^ splitmix64(set * 0x100000001B3ull + index))) {}
  /// Uniform in [0, 1): the top 24 bits, exactly representable as a float.
  float next() {
    state_ = splitmix64(state_);
    return static_cast<float>(state_ >> 40) * 0x1.0p-24f;
  }

 private:
  uint64_t state_;
};

struct Frame {
  Vec3 t, b, n;
};

// An orthonormal basis around a unit normal (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
Frame basis(Vec3 n) {
  const float sign = std::copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float b = n.x * n.y * a;
  return {{1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x}, {b, sign + n.y * n.y * a, -n.y}, n};
}

// Cosine-weighted direction about `n` (Malley's method: a uniform disk point projected up).
Vec3 cosine_direction(Vec3 n, RayRng& rng) {
  const float r = std::sqrt(rng.next());
  const float phi = 2.0f * std::numbers::pi_v<float> * rng.next();
  const float x = r * std::cos(phi), y = r * std::sin(phi);
  const float z = std::sqrt(std::max(0.0f, 1.0f - x * x - y * y));
  const Frame f = basis(n);
  return f.t * x + f.b * y + f.n * z;
}

Vec3 uniform_sphere(RayRng& rng) {
  const float z = 1.0f - 2.0f * rng.next();
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 2.0f * std::numbers::pi_v<float> * rng.next();
  return {r * std::cos(phi), r * std::sin(phi), z};
}

Aabb scene_bounds(const Scene& scene) {
  Aabb box;
  for (const auto& t : scene.triangles) box.extend(t.bounds());
  return box;
}

struct Hitpoint {
  Vec3 position;  // offset off the surface, on the side the primary ray came from
  Vec3 normal;    // unit, facing the primary ray's origin
};

std::vector<Ray> primary_rays(const Scene& scene, const RaySetConfig& cfg, const Aabb& box) {
  // A file's camera is normalised here; the automatic one is unit already (and normalising it again
  // could change its last bits, and with them every ray).
  const Camera camera = scene.camera ? *scene.camera : automatic_camera(box);
  const Vec3 eye = camera.position;
  const Vec3 forward = scene.camera ? normalize(camera.forward) : camera.forward;
  const Vec3 up = scene.camera ? normalize(camera.up) : camera.up;
  const float fov_y = camera.yfov;
  const Vec3 right = normalize(cross(forward, up));
  const Vec3 true_up = cross(right, forward);
  const float aspect = static_cast<float>(cfg.width) / static_cast<float>(cfg.height);
  const float half_h = std::tan(0.5f * fov_y), half_w = half_h * aspect;
  const std::vector<uint32_t> pixels = primary_pixel_order(cfg.width, cfg.height);
  std::vector<Ray> rays(pixels.size());
  tbb::parallel_for(std::size_t{0}, pixels.size(), [&](std::size_t i) {
    const uint32_t x = pixels[i] % cfg.width, y = pixels[i] / cfg.width;
    const float sx = (2.0f * (static_cast<float>(x) + 0.5f) / static_cast<float>(cfg.width) - 1.0f) * half_w;
    const float sy = (1.0f - 2.0f * (static_cast<float>(y) + 0.5f) / static_cast<float>(cfg.height)) * half_h;
    rays[i].org = eye;
    rays[i].dir = normalize(forward + right * sx + true_up * sy);
  });
  return rays;
}

// Traces the primary rays on the reference tree and keeps the hit points, in ray order (the primary set's
// tiles), misses left out.
std::vector<Hitpoint> primary_hits(const Scene& scene, const Bvh& bvh, std::span<const Ray> rays) {
  std::vector<Hit> hits(rays.size());
  tbb::parallel_for(std::size_t{0}, rays.size(),
                    [&](std::size_t i) { hits[i] = closest_hit(bvh, scene.triangles, rays[i]); });
  std::vector<Hitpoint> out;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    if (!hits[i].found()) continue;
    const Ray& r = rays[i];
    Vec3 n = normalize(scene.triangles[hits[i].prim].normal());
    if (dot(n, r.dir) > 0.0f) n = -n;
    out.push_back({offset_ray_origin(r.org + r.dir * hits[i].t, n), n});
  }
  return out;
}

}  // namespace

// Waechter and Binder 2019: by a few ulps of p's integer representation (far from the origin) or by a
// small absolute amount (near it). Constants from the chapter.
Vec3 offset_ray_origin(Vec3 p, Vec3 n) {
  constexpr float kOrigin = 1.0f / 32.0f, kFloatScale = 1.0f / 65536.0f, kIntScale = 256.0f;
  Vec3 out;
  for (int a = 0; a < 3; ++a) {
    const auto of_i = static_cast<int32_t>(kIntScale * n[a]);
    const int32_t bits = std::bit_cast<int32_t>(p[a]);
    const float p_i = std::bit_cast<float>(bits + (p[a] < 0 ? -of_i : of_i));
    out[a] = std::fabs(p[a]) < kOrigin ? p[a] + kFloatScale * n[a] : p_i;
  }
  return out;
}

std::vector<uint32_t> primary_pixel_order(uint32_t width, uint32_t height) {
  constexpr uint32_t kTile = 4;
  std::vector<uint32_t> pixels;
  pixels.reserve(std::size_t{width} * height);
  for (uint32_t ty = 0; ty < height; ty += kTile)
    for (uint32_t tx = 0; tx < width; tx += kTile)
      for (uint32_t y = ty; y < std::min(ty + kTile, height); ++y)
        for (uint32_t x = tx; x < std::min(tx + kTile, width); ++x) pixels.push_back(y * width + x);
  return pixels;
}

std::vector<Vec3> automatic_lights(const Scene& scene, uint32_t count, uint64_t seed) {
  const Aabb box = scene_bounds(scene);
  const Vec3 e = box.extent();
  std::vector<Vec3> lights;
  for (uint32_t i = 0; i < count; ++i) {
    RayRng rng(seed, 0xA11CE, i);
    lights.push_back({box.min.x + e.x * (0.1f + 0.8f * rng.next()), box.max.y - e.y * 0.1f * rng.next(),
                      box.min.z + e.z * (0.1f + 0.8f * rng.next())});
  }
  return lights;
}

bool enclosed(const Bvh& bvh, std::span<const Triangle> triangles, Vec3 p) {
  const double golden_angle = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (uint32_t i = 0; i < kEnclosureProbes; ++i) {
    const double y = 1.0 - (2.0 * i + 1.0) / kEnclosureProbes;
    const double r = std::sqrt(1.0 - y * y), phi = golden_angle * i;
    Ray ray;
    ray.org = p;
    ray.dir = {static_cast<float>(r * std::cos(phi)), static_cast<float>(y),
               static_cast<float>(r * std::sin(phi))};
    if (!any_hit(bvh, triangles, ray)) return false;
  }
  return true;
}

namespace {

// The note of a shadow set whose lights the scene encloses; empty when it encloses none.
std::string enclosed_lights_note(const Bvh& bvh, std::span<const Triangle> triangles,
                                 std::span<const Vec3> lights, bool automatic) {
  std::vector<std::size_t> inside;
  for (std::size_t i = 0; i < lights.size(); ++i)
    if (enclosed(bvh, triangles, lights[i])) inside.push_back(i + 1);
  if (inside.empty()) return "";
  return fmt::format(
      "{} light{} {} of {} enclosed by the scene (each of {} rays from it hits a triangle): the shadow rays "
      "to {} end inside that enclosure",
      automatic ? "automatic" : "scene", inside.size() == 1 ? "" : "s", fmt::join(inside, ", "),
      lights.size(), kEnclosureProbes, inside.size() == 1 ? "it" : "them");
}

}  // namespace

GeneratedRaySets generate_ray_sets(const Scene& scene, std::span<const RaySetConfig> configs, uint64_t seed) {
  GeneratedRaySets out;
  if (scene.triangles.empty()) {
    for (const auto& c : configs) out.skipped.emplace_back(c.name, "the scene has no triangles");
    return out;
  }
  const Aabb box = scene_bounds(scene);
  const float diagonal = length(box.extent());
  // The reference tree (binned SAH, watertight test) that finds the primary hits and probes the lights,
  // built once, when a set first needs it.
  std::optional<Bvh> reference;
  auto tree = [&]() -> const Bvh& {
    if (!reference) reference = build_binned_sah(BuildInput::from_triangles(scene.triangles), {});
    return *reference;
  };
  // Secondary sets start from the hits of the primary image of their resolution; shared between sets.
  std::vector<std::pair<std::pair<uint32_t, uint32_t>, std::vector<Hitpoint>>> hit_cache;
  auto hits_for = [&](const RaySetConfig& cfg) -> const std::vector<Hitpoint>& {
    for (const auto& [size, hits] : hit_cache)
      if (size == std::make_pair(cfg.width, cfg.height)) return hits;
    hit_cache.emplace_back(std::make_pair(cfg.width, cfg.height),
                           primary_hits(scene, tree(), primary_rays(scene, cfg, box)));
    return hit_cache.back().second;
  };

  for (std::size_t set_index = 0; set_index < configs.size(); ++set_index) {
    const RaySetConfig& cfg = configs[set_index];
    RaySet set{.name = cfg.name,
               .kind = cfg.kind,
               .occlusion = cfg.kind == RayKind::kShadow || cfg.kind == RayKind::kAmbientOcclusion};
    if (cfg.kind == RayKind::kPrimary) {
      set.rays = primary_rays(scene, cfg, box);
      out.sets.push_back(std::move(set));
      continue;
    }
    if (cfg.kind == RayKind::kRandom) {
      const std::size_t count = cfg.count ? cfg.count : kDefaultRandomRays;
      set.rays.resize(count);
      tbb::parallel_for(std::size_t{0}, count, [&](std::size_t i) {
        RayRng rng(seed, set_index, i);
        Ray& r = set.rays[i];
        r.org = box.min + box.extent() * Vec3{rng.next(), rng.next(), rng.next()};
        r.dir = uniform_sphere(rng);
      });
      out.sets.push_back(std::move(set));
      continue;
    }

    std::vector<Vec3> lights;
    if (cfg.kind == RayKind::kShadow) {
      lights = cfg.light_source == "scene" ? scene.lights : automatic_lights(scene, cfg.lights, seed);
      if (lights.empty()) {
        out.skipped.emplace_back(cfg.name,
                                 cfg.light_source == "scene" ? "the scene has no lights" : "lights = 0");
        continue;
      }
      set.note = enclosed_lights_note(tree(), scene.triangles, lights, cfg.light_source != "scene");
    }
    const std::vector<Hitpoint>& hits = hits_for(cfg);
    if (hits.empty()) {
      out.skipped.emplace_back(cfg.name, "no primary ray hits the scene");
      continue;
    }
    const std::size_t count = cfg.count ? cfg.count : hits.size();
    set.rays.resize(count);
    tbb::parallel_for(std::size_t{0}, count, [&](std::size_t i) {
      RayRng rng(seed, set_index, i);
      const Hitpoint& h = hits[i % hits.size()];
      Ray& r = set.rays[i];
      r.org = h.position;
      switch (cfg.kind) {
        case RayKind::kShadow:
          // Unnormalised towards the light: t in [0, 1) stops just short of it.
          r.dir = lights[i % lights.size()] - h.position;
          r.tmax = 1.0f - 1e-4f;
          break;
        case RayKind::kDiffuse:
          r.dir = cosine_direction(h.normal, rng);
          break;
        default:  // ambient occlusion
          r.dir = cosine_direction(h.normal, rng);
          r.tmax = cfg.ao_radius * diagonal;
          break;
      }
    });
    out.sets.push_back(std::move(set));
  }
  return out;
}

}  // namespace sahbench
