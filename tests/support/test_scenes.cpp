#include "tests/support/test_scenes.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "core/aabb.h"

namespace sahbench::test {
namespace {

// The diagonal of `box`, scaled by its largest extent first so that the squares of a scene 1e21 across
// do not overflow float (the huge scenes of the layout tests would otherwise get infinite ray origins).
float diagonal(const Aabb& box) {
  const Vec3 e = box.extent();
  const float m = std::max({e.x, e.y, e.z});
  return m > 0.0f ? m * length(e * (1.0f / m)) : 0.0f;
}

}  // namespace

std::vector<Triangle> random_triangles(std::size_t count, uint64_t seed, float extent, float max_edge) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> pos(-extent, extent);
  std::uniform_real_distribution<float> edge(-max_edge, max_edge);
  std::vector<Triangle> tris(count);
  for (auto& t : tris) {
    t.v0 = {pos(rng), pos(rng), pos(rng)};
    t.v1 = t.v0 + Vec3{edge(rng), edge(rng), edge(rng)};
    t.v2 = t.v0 + Vec3{edge(rng), edge(rng), edge(rng)};
  }
  return tris;
}

std::vector<Triangle> cube_grid(int n, float h) {
  std::vector<Triangle> tris;
  // For each face: a fixed axis and sign, and the two in-plane axes.
  for (int axis = 0; axis < 3; ++axis) {
    for (float sign : {-1.0f, 1.0f}) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      auto point = [&](int i, int j) {
        Vec3 p;
        p[axis] = sign * h;
        p[u] = -h + 2.0f * h * static_cast<float>(i) / static_cast<float>(n);
        p[v] = -h + 2.0f * h * static_cast<float>(j) / static_cast<float>(n);
        return p;
      };
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          tris.push_back({point(i, j), point(i + 1, j), point(i + 1, j + 1)});
          tris.push_back({point(i, j), point(i + 1, j + 1), point(i, j + 1)});
        }
    }
  }
  return tris;
}

std::vector<Ray> random_rays(const std::vector<Triangle>& scene, std::size_t count, uint64_t seed) {
  Aabb box;
  for (const auto& t : scene) box.extend(t.bounds());
  const Vec3 c = box.center();
  const float r = diagonal(box) * 0.5f + 1.0f;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::uniform_int_distribution<int> kind(0, 7);
  std::uniform_int_distribution<std::size_t> pick(0, scene.empty() ? 0 : scene.size() - 1);
  std::vector<Ray> rays(count);
  for (auto& ray : rays) {
    const Vec3 inside = c + Vec3{unit(rng), unit(rng), unit(rng)} * (r * 0.5f);
    switch (kind(rng)) {
      case 0:  // from outside towards a random point inside
      case 1: {
        const Vec3 from = c + normalize(Vec3{unit(rng), unit(rng), unit(rng)}) * (2.0f * r);
        ray.org = from;
        ray.dir = inside - from;
        break;
      }
      case 2:  // from inside in a random direction
        ray.org = inside;
        ray.dir = {unit(rng), unit(rng), unit(rng)};
        break;
      case 3: {  // axis-parallel, with +0 or -0 in the other components
        ray.org = inside;
        const int axis = static_cast<int>(rng() % 3);
        ray.dir = {(rng() & 1) ? 0.0f : -0.0f, (rng() & 1) ? 0.0f : -0.0f, (rng() & 1) ? 0.0f : -0.0f};
        ray.dir[axis] = (rng() & 1) ? 1.0f : -1.0f;
        break;
      }
      case 4: {  // in a coordinate plane: one zero component of either sign
        ray.org = inside;
        ray.dir = {unit(rng), unit(rng), unit(rng)};
        ray.dir[rng() % 3] = (rng() & 1) ? 0.0f : -0.0f;
        break;
      }
      case 6:  // at a random point of a random triangle (so sparse scenes are hit too), from outside
      case 7: {
        if (scene.empty()) continue;
        const Triangle& t = scene[pick(rng)];
        float a = std::fabs(unit(rng)), b = std::fabs(unit(rng));
        if (a + b > 1.0f) a = 1.0f - a, b = 1.0f - b;
        const Vec3 target = t.v0 + (t.v1 - t.v0) * a + (t.v2 - t.v0) * b;
        ray.org = c + normalize(Vec3{unit(rng), unit(rng), unit(rng)}) * (2.0f * r);
        ray.dir = target - ray.org;
        break;
      }
      default:  // a bounded segment
        ray.org = inside;
        ray.dir = {unit(rng), unit(rng), unit(rng)};
        ray.tmin = 0.01f;
        ray.tmax = r * 0.3f;
        break;
    }
  }
  return rays;
}

std::vector<Ray> coherent_rays(const std::vector<Triangle>& scene, std::size_t count, uint64_t seed,
                               std::size_t group) {
  const std::vector<Ray> leaders = random_rays(scene, (count + group - 1) / group, seed);
  Aabb box;
  for (const auto& t : scene) box.extend(t.bounds());
  const float spread = diagonal(box) * 0.01f + 1e-3f;
  std::mt19937_64 rng(seed ^ 0x9e3779b97f4a7c15ull);
  std::uniform_real_distribution<float> jitter(-1.0f, 1.0f);
  std::vector<Ray> rays;
  rays.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Ray& lead = leaders[i / group];
    Ray ray = lead;
    if (i % group != 0) {
      for (int axis = 0; axis < 3; ++axis) {
        ray.org[axis] += jitter(rng) * spread;
        const float d = lead.dir[axis];
        ray.dir[axis] = d == 0.0f ? d : std::copysign(std::fabs(d * (1.0f + 0.05f * jitter(rng))), d);
      }
    }
    rays.push_back(ray);
  }
  return rays;
}

std::vector<Ray> diverging_rays(const std::vector<Triangle>& scene, std::size_t count, uint64_t seed,
                                std::size_t group) {
  const std::vector<Ray> leaders = random_rays(scene, (count + group - 1) / group, seed);
  Aabb box;
  for (const auto& t : scene) box.extend(t.bounds());
  const float size = diagonal(box) + 1e-3f;
  // Origins spread over a tenth of the scene: far enough apart that the rays part below the root, near
  // enough that they still share its top levels, as a packet's rays do.
  constexpr float kSpread = 0.1f;
  // A later start, as a fraction of the diagonal: past the triangles next to the origin in most scenes.
  constexpr float kLateStart = 0.01f;
  std::mt19937_64 rng(seed ^ 0x2545f4914f6cdd1dull);
  // Magnitudes of direction components and shortened intervals: bounded away from 0, so that no
  // component of a nonzero sign becomes a zero one and no interval becomes empty.
  std::uniform_real_distribution<float> jitter(-1.0f, 1.0f), share(0.05f, 1.0f);
  std::vector<Ray> rays;
  rays.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Ray& lead = leaders[i / group];
    Ray ray = lead;
    if (i % group != 0) {
      for (int axis = 0; axis < 3; ++axis) {
        ray.org[axis] += jitter(rng) * kSpread * size;
        const float d = lead.dir[axis];
        ray.dir[axis] = d == 0.0f ? d : std::copysign(share(rng), d);
      }
      if (i % 3 == 1) ray.tmax = std::min(lead.tmax, share(rng) * size);
      if (i % 4 == 2) ray.tmin = std::min(ray.tmax, kLateStart * size);
    }
    rays.push_back(ray);
  }
  return rays;
}

}  // namespace sahbench::test

namespace sahbench::test {

std::vector<Ray> interleaved_rays(const std::vector<Triangle>& scene, std::size_t count, uint64_t seed,
                                  std::size_t group, std::size_t streams) {
  const std::size_t run = group * streams;
  const std::vector<Ray> leaders = random_rays(scene, (count + run - 1) / run * streams, seed);
  Aabb box;
  for (const auto& t : scene) box.extend(t.bounds());
  const float size = diagonal(box) + 1e-3f;
  std::mt19937_64 rng(seed ^ 0x6a09e667f3bcc909ull);
  std::uniform_real_distribution<float> jitter(-1.0f, 1.0f), share(0.05f, 1.0f);
  std::vector<Ray> rays;
  rays.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Ray& lead = leaders[i / run * streams + i % streams];
    Ray ray = lead;
    if (i % run >= streams) {  // not the first of its stream in this run
      for (int axis = 0; axis < 3; ++axis) {
        ray.org[axis] += jitter(rng) * 0.1f * size;
        // Up to 10% on each component, sign kept: within some ten degrees of the leader.
        const float d = lead.dir[axis];
        ray.dir[axis] = d == 0.0f ? d : std::copysign(std::fabs(d * (1.0f + 0.1f * jitter(rng))), d);
      }
      if (i % 3 == 1) ray.tmax = std::min(lead.tmax, share(rng) * size);
    }
    rays.push_back(ray);
  }
  return rays;
}

std::vector<Ray> shadow_rays(const std::vector<Triangle>& scene, std::size_t count, uint64_t seed,
                             std::size_t lights, bool level) {
  Aabb box;
  for (const auto& t : scene) box.extend(t.bounds());
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::uniform_int_distribution<std::size_t> pick(0, scene.size() - 1);
  std::vector<Vec3> light(lights);
  for (Vec3& l : light)
    l = box.min - box.extent() * 0.25f + box.extent() * 1.5f * Vec3{unit(rng), unit(rng), unit(rng)};
  light.back() = scene[pick(rng)].v1;
  std::vector<Ray> rays(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Triangle& t = scene[pick(rng)];
    float a = unit(rng), b = unit(rng);
    if (a + b > 1.0f) a = 1.0f - a, b = 1.0f - b;
    Ray& r = rays[i];
    const Vec3& l = light[i % lights];
    r.org = t.v0 + (t.v1 - t.v0) * a + (t.v2 - t.v0) * b;
    if (level && i % 5 == 0) r.org[i / 5 % 3] = l[i / 5 % 3];
    r.dir = l - r.org;
    r.tmin = i % 2 ? 0.0f : 1e-4f;
    r.tmax = 1.0f - 1e-4f;
  }
  return rays;
}

}  // namespace sahbench::test
