#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/aabb.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "tests/scenes/temp_dir.h"

namespace sahbench {
namespace {

using test::error_message;

const char* const kKinds[] = {"sphere", "terrain", "soup", "needles", "multiscale", "wave"};

std::string spec(const std::string& kind, const std::string& params) {
  return "proc:" + kind + ":" + params;
}

// Grid-based kinds round to whole rows, spheres or bands; 5% is loose enough for tris >= 1000.
constexpr double kCountTolerance = 0.05;

TEST(SceneProcedural, CountsAreNearTheTarget) {
  for (const char* kind : kKinds) {
    for (uint64_t tris : {1000u, 12345u, 200000u}) {
      const Scene s = load_scene(spec(kind, "tris=" + std::to_string(tris)));
      const auto got = static_cast<double>(s.triangles.size() + s.removed.total());
      EXPECT_NEAR(got, static_cast<double>(tris), kCountTolerance * static_cast<double>(tris)) << kind;
      EXPECT_EQ(s.removed.total(), 0u) << kind << " " << tris;
    }
  }
  // Kinds made of independent triangles hit the count exactly.
  EXPECT_EQ(load_scene("proc:soup:tris=777").triangles.size(), 777u);
  EXPECT_EQ(load_scene("proc:needles:tris=777").triangles.size(), 777u);
}

TEST(SceneProcedural, TinyCountsStillGiveAScene) {
  for (const char* kind : kKinds) EXPECT_GT(load_scene(spec(kind, "tris=1")).triangles.size(), 0u) << kind;
}

TEST(SceneProcedural, SameSeedSameTrianglesDifferentSeedDifferent) {
  for (const char* kind : kKinds) {
    const Scene a = load_scene(spec(kind, "tris=5000,seed=7"));
    const Scene b = load_scene(spec(kind, "tris=5000,seed=7"));
    const Scene c = load_scene(spec(kind, "tris=5000,seed=8"));
    EXPECT_EQ(a.triangles, b.triangles) << kind;
    EXPECT_NE(a.triangles, c.triangles) << kind;
  }
}

TEST(SceneProcedural, ThreadCountDoesNotChangeTheResult) {
  for (const char* kind : kKinds) {
    const std::string s = spec(kind, "tris=50000,seed=3");
    std::vector<Triangle> serial;
    {
      tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
      serial = load_scene(s).triangles;
    }
    EXPECT_EQ(load_scene(s).triangles, serial) << kind;
  }
}

TEST(SceneProcedural, SourceIsTheNormalisedSpec) {
  const Scene s = load_scene("proc:soup:tris=1M");
  EXPECT_EQ(s.name, "proc:soup:tris=1M");
  EXPECT_EQ(s.source, "proc:soup:tris=1000000,seed=1");
  EXPECT_EQ(s.triangles.size(), 1000000u);
  EXPECT_EQ(load_scene("proc:sphere:tris=1000").source, "proc:sphere:tris=1000,seed=1");
  EXPECT_EQ(load_scene("proc:terrain:seed=2,tris=2k").source, "proc:terrain:tris=2000,seed=2,octaves=8");
  EXPECT_EQ(load_scene("proc:needles:tris=10,aspect=50.5").source, "proc:needles:tris=10,seed=1,aspect=50.5");
  EXPECT_EQ(load_scene("proc:multiscale:tris=100").source, "proc:multiscale:tris=100,seed=1,outer=1000");
  EXPECT_EQ(load_scene("proc:multiscale").source, "proc:multiscale:tris=100000,seed=1,outer=1000");
}

TEST(SceneProcedural, ParseCount) {
  EXPECT_EQ(parse_count("1000"), 1000u);
  EXPECT_EQ(parse_count("100k"), 100000u);
  EXPECT_EQ(parse_count("100K"), 100000u);
  EXPECT_EQ(parse_count("1M"), 1000000u);
  EXPECT_EQ(parse_count("1.5M"), 1500000u);
  for (const char* bad : {"", "0", "-5", "1.5", "1.2345k", "k", "1m", "1e3", "abc", "10 ", "1MM"})
    EXPECT_FALSE(parse_count(bad).has_value()) << bad;
}

TEST(SceneProcedural, BadSpecsNameTheProblem) {
  const std::pair<const char*, const char*> cases[] = {
      {"proc:cube",
       "unknown procedural kind 'cube' (known: sphere, terrain, soup, needles, multiscale, wave)"},
      {"proc:soup:size=3", "unknown parameter 'size' for 'soup' (known: tris, seed)"},
      {"proc:soup:tris=abc", "bad value 'abc' for 'tris'"},
      {"proc:soup:tris=0", "bad value '0' for 'tris'"},
      {"proc:soup:tris=2000M", "bad value '2000M' for 'tris'"},
      {"proc:soup:seed=-1", "bad value '-1' for 'seed'"},
      {"proc:needles:aspect=nan", "bad value 'nan' for 'aspect'"},
      {"proc:needles:aspect=0.5", "bad value '0.5' for 'aspect'"},
      {"proc:terrain:octaves=2.5", "bad value '2.5' for 'octaves'"},
      {"proc:soup:tris=10,tris=20", "'tris' given twice"},
      {"proc:soup:tris", "expected key=value, got 'tris'"},
      {"proc:soup:tris=10,", "expected key=value, got ''"},
  };
  for (const auto& [s, expected] : cases) {
    const std::string msg = error_message([&] { load_scene(s); });
    EXPECT_NE(msg.find(s), std::string::npos) << msg;
    EXPECT_NE(msg.find(expected), std::string::npos) << "expected '" << expected << "' in: " << msg;
  }
}

Aabb bounds_of(const std::vector<Triangle>& tris) {
  Aabb box;
  for (const Triangle& t : tris) box.extend(t.bounds());
  return box;
}

float longest_edge(const Triangle& t) {
  return std::max({length(t.v1 - t.v0), length(t.v2 - t.v1), length(t.v0 - t.v2)});
}

TEST(SceneProcedural, ShapesHaveTheirDocumentedGeometry) {
  // Sphere: every vertex on the unit sphere.
  for (const Triangle& t : load_scene("proc:sphere:tris=20000").triangles)
    for (Vec3 v : {t.v0, t.v1, t.v2}) ASSERT_NEAR(length(v), 1.0f, 1e-5f);

  // Terrain: x spans [-1, 1], heights within the noise amplitude.
  const Aabb terrain = bounds_of(load_scene("proc:terrain:tris=20000").triangles);
  EXPECT_FLOAT_EQ(terrain.min.x, -1.0f);
  EXPECT_FLOAT_EQ(terrain.max.x, 1.0f);
  EXPECT_LT(terrain.max.y, 0.5f);
  EXPECT_GT(terrain.min.y, -0.5f);
  EXPECT_GT(terrain.max.y - terrain.min.y, 0.05f);  // not flat

  // Needles: longest edge / height is about the aspect ratio.
  for (const Triangle& t : load_scene("proc:needles:tris=1000,aspect=1000").triangles) {
    const float height = 2.0f * t.area() / longest_edge(t);
    ASSERT_NEAR(longest_edge(t) / height, 1000.0f, 50.0f);
  }

  // Multiscale: the enclosing box is 1e3, everything else is tiny and near the centre.
  const Scene m = load_scene("proc:multiscale:tris=10000");
  const Aabb box = bounds_of(m.triangles);
  EXPECT_EQ(box.max, Vec3(1000.0f));
  EXPECT_EQ(box.min, Vec3(-1000.0f));
  const auto small = std::count_if(m.triangles.begin(), m.triangles.end(),
                                   [](const Triangle& t) { return longest_edge(t) < 3e-3f; });
  EXPECT_EQ(static_cast<std::size_t>(small), m.triangles.size() - 12);

  // Soup: inside the unit box grown by the largest triangle size.
  const Aabb soup = bounds_of(load_scene("proc:soup:tris=20000").triangles);
  EXPECT_GE(soup.min.x, -1.21f);
  EXPECT_LE(soup.max.x, 1.21f);
}

}  // namespace
}  // namespace sahbench
