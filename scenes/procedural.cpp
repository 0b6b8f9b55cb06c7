#include "scenes/procedural.h"

#include <string>
#include <vector>

#include "scenes/generators.h"
#include "scenes/triangle_filter.h"
#include "scenes/wave.h"

namespace sahbench {

namespace {

// Largest `tris` accepted: 2^30 triangles are 36 GiB, beyond any machine this runs on; the bound keeps a
// typo ("tris=1e12") from being an allocation failure deep inside a generator.
constexpr double kMaxTris = 1073741824.0;
constexpr double kMaxSeed = 18446744073709551615.0;  // any uint64

constexpr ProcParamInfo kTris{"tris", ProcParamType::kCount, 100000, 1, kMaxTris, "target triangle count"};
constexpr ProcParamInfo kSeed{"seed", ProcParamType::kInteger, 1, 0, kMaxSeed, "random seed"};

const std::vector<ProcKindInfo>& kinds() {
  static const std::vector<ProcKindInfo> table{
      {"sphere", "UV sphere of radius 1, randomly oriented", {kTris, kSeed}},
      {"terrain",
       "noise heightfield over [-1,1]^2",
       {kTris, kSeed, {"octaves", ProcParamType::kInteger, 8, 1, 24, "noise octaves"}}},
      {"soup", "independent random triangles of random sizes in [-1,1]^3", {kTris, kSeed}},
      {"needles",
       "long thin triangles with random orientations in [-1,1]^3",
       {kTris, kSeed, {"aspect", ProcParamType::kReal, 1000, 1, 1e6, "length / width"}}},
      {"multiscale",
       "tiny spheres (edges ~1e-3) in [-1,1]^3 inside a huge enclosing cube",
       {kTris, kSeed, {"outer", ProcParamType::kReal, 1000, 2, 1e30, "half-size of the enclosing cube"}}},
      {"wave",
       "animated: Gerstner-wave sheet over [-1,1]^2, looping over t in [0, 1] s (the static scene is t = 0)",
       {kTris,
        kSeed,
        {"amplitude", ProcParamType::kReal, 0.1, 0, 10, "height of a wave of wavelength 1"},
        {"waves", ProcParamType::kInteger, 4, 1, 64, "Gerstner waves summed"}}},
  };
  return table;
}

std::vector<Triangle> generate(const ProcSpec& spec) {
  const uint64_t tris = spec.integer("tris");
  const uint64_t seed = spec.integer("seed");
  const std::string_view kind = spec.kind();
  if (kind == "sphere") return generate_sphere(tris, seed);
  if (kind == "terrain") return generate_terrain(tris, seed, static_cast<int>(spec.integer("octaves")));
  if (kind == "soup") return generate_soup(tris, seed);
  if (kind == "needles") return generate_needles(tris, seed, spec.real("aspect"));
  if (kind == "wave") return generate_wave(wave_params(spec), 0.0);
  return generate_multiscale(tris, seed, spec.real("outer"));  // the parser admits only table kinds
}

}  // namespace

bool is_procedural_spec(std::string_view spec) {
  return spec.starts_with("proc:");
}

std::span<const ProcKindInfo> procedural_kinds() {
  return kinds();
}

bool is_animated_kind(std::string_view kind) {
  return kind == "wave";
}

WaveParams wave_params(const ProcSpec& spec) {
  return {spec.integer("tris"), spec.integer("seed"), spec.real("amplitude"),
          static_cast<int>(spec.integer("waves"))};
}

Scene generate_procedural(std::string_view spec) {
  const ProcSpec parsed = parse_proc_spec(spec, kinds());
  Scene scene;
  scene.name = std::string(spec);
  scene.source = parsed.normalised();
  TriangleFilter(scene).add_all(generate(parsed));
  scene.animated = is_animated_kind(parsed.kind());
  return scene;
}

}  // namespace sahbench
