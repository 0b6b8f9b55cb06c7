#include "bench/bench_data.h"

#include <map>
#include <random>

#include "builders/binned_sah.h"

namespace sahbench::bench {

const std::vector<Triangle>& soup(std::size_t count) {
  static std::map<std::size_t, std::vector<Triangle>> cache;
  auto& tris = cache[count];
  if (tris.empty()) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> pos(-10.0f, 10.0f), edge(-1.0f, 1.0f);
    tris.reserve(count);
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 a{pos(rng), pos(rng), pos(rng)};
      tris.push_back(
          {a, a + Vec3{edge(rng), edge(rng), edge(rng)}, a + Vec3{edge(rng), edge(rng), edge(rng)}});
    }
  }
  return tris;
}

const std::vector<Ray>& rays(std::size_t count) {
  static std::map<std::size_t, std::vector<Ray>> cache;
  auto& out = cache[count];
  if (out.empty()) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> pos(-12.0f, 12.0f);
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 o{pos(rng), pos(rng), pos(rng)}, target{pos(rng) * 0.5f, pos(rng) * 0.5f, pos(rng) * 0.5f};
      out.push_back({o, 0.0f, target - o, 1e30f});
    }
  }
  return out;
}

const Bvh& binary_tree(std::size_t count) {
  static std::map<std::size_t, Bvh> cache;
  auto it = cache.find(count);
  if (it == cache.end())
    it = cache.emplace(count, build_binned_sah(BuildInput::from_triangles(soup(count)), {})).first;
  return it->second;
}

}  // namespace sahbench::bench
