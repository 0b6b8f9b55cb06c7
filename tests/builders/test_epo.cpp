// The EPO cost (core/epo.h): exact values on hand-made trees, zero where no box holds surface of another
// subtree, the definition computed by brute force (every node against every triangle outside it) on the
// trees of binary, wide and spatial-split builders, and the same value for any thread count.

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "builders/registry.h"
#include "core/bvh_stats.h"
#include "core/clip_polygon.h"
#include "core/epo.h"
#include "core/error.h"
#include "core/validate.h"
#include "scenes/generators.h"
#include "tests/support/test_scenes.h"

namespace sahbench {
namespace {

Bvh build(const std::string& builder, const std::vector<Triangle>& tris,
          const ParamOverrides& overrides = {}) {
  const BuilderInfo& info = find_builder(builder);
  return info.build(BuildInput::from_triangles(tris), resolve_params(info.name, info.params, overrides));
}

Aabb box(Vec3 lo, Vec3 hi) {
  return Aabb{lo, hi};
}

// A = (0,0)-(2,0)-(0,2) (area 2) and B = (1,0)-(3,0)-(3,1) (area 1), both in the plane z = 0, each in a
// leaf with its own bounds: B's box [1,3]x[0,1] holds the part of A with x >= 1 (area 0.5), A's box
// [0,2]x[0,2] the part of B with x <= 2 (area 0.25).
const std::vector<Triangle> kTwo = {{{0, 0, 0}, {2, 0, 0}, {0, 2, 0}}, {{1, 0, 0}, {3, 0, 0}, {3, 1, 0}}};

Bvh two_leaves() {
  Bvh bvh;
  bvh.nodes = {{box({0, 0, 0}, {3, 2, 0}), 1, 2, 0},
               {box({0, 0, 0}, {2, 2, 0}), 0, 0, 1},
               {box({1, 0, 0}, {3, 1, 0}), 1, 0, 1}};
  bvh.prim_refs = {0, 1};
  return bvh;
}

TEST(Epo, TwoTrianglesOverlappingEachOthersLeafAreExact) {
  ASSERT_TRUE(validate(two_leaves(), std::span<const Triangle>(kTwo)).ok());
  // (0.5 + 0.25) * c_isect over the scene's area 3; the root holds both and costs nothing.
  EXPECT_DOUBLE_EQ(epo_cost(two_leaves(), kTwo, SahCost{1.0f, 1.0f}), 0.75 / 3.0);
  EXPECT_DOUBLE_EQ(epo_cost(two_leaves(), kTwo, SahCost{3.0f, 2.0f}), 1.5 / 3.0);
}

// A third triangle D at z = 1 puts A under an inner node I = [0,2]x[0,2]x[0,1] with D's leaf: I's box
// holds B's part x <= 2 (0.25) at c_trav, A's leaf again 0.25 and B's leaf A's 0.5 at c_isect per
// primitive; D (area 0.125) lies in no other box. Leaves of 2 primitives in blocks of 2 cost one block.
TEST(Epo, InnerNodesCostCTravAndLeavesTheirBlocks) {
  std::vector<Triangle> tris = kTwo;
  tris.push_back({{0, 1.5f, 1}, {0.5f, 1.5f, 1}, {0, 2, 1}});
  Bvh bvh;
  bvh.nodes = {{box({0, 0, 0}, {3, 2, 1}), 1, 2, 0},
               {box({0, 0, 0}, {2, 2, 1}), 3, 2, 0},
               {box({1, 0, 0}, {3, 1, 0}), 1, 0, 1},
               {box({0, 0, 0}, {2, 2, 0}), 0, 0, 1},
               {box({0, 1.5f, 1}, {0.5f, 2, 1}), 2, 0, 1}};
  bvh.prim_refs = {0, 1, 2};
  ASSERT_TRUE(validate(bvh, std::span<const Triangle>(tris)).ok())
      << validate(bvh, std::span<const Triangle>(tris)).summary();
  EXPECT_DOUBLE_EQ(epo_cost(bvh, tris, SahCost{3.0f, 2.0f}), (0.25 * 3 + 0.25 * 2 + 0.5 * 2) / 3.125);
  // The same leaves holding a duplicate reference each (2 primitives) cost 2 c_isect, or one block of 2.
  Bvh doubled = bvh;
  doubled.prim_refs = {0, 0, 1, 1, 2, 2};
  doubled.nodes[2].first = 2, doubled.nodes[2].prim_count = 2;
  doubled.nodes[3].first = 0, doubled.nodes[3].prim_count = 2;
  doubled.nodes[4].first = 4, doubled.nodes[4].prim_count = 2;
  EXPECT_DOUBLE_EQ(epo_cost(doubled, tris, SahCost{3.0f, 2.0f}), (0.25 * 3 + 0.25 * 4 + 0.5 * 4) / 3.125);
  EXPECT_DOUBLE_EQ(epo_cost(doubled, tris, SahCost{3.0f, 2.0f, 2}), (0.25 * 3 + 0.25 * 2 + 0.5 * 2) / 3.125);
}

// Triangles apart from each other in a row: every box holds only its own subtree's surface.
TEST(Epo, ZeroWhereNoBoxHoldsAnotherSubtreesSurface) {
  std::vector<Triangle> tris;
  for (int i = 0; i < 64; ++i) {
    const float x = 3.0f * static_cast<float>(i);
    tris.push_back({{x, 0, 0}, {x + 1, 0, 0}, {x, 1, 0.5f}});
  }
  for (const char* builder : {"binned_sah", "sweep_sah", "sbvh"}) {
    const Bvh bvh = build(builder, tris, {{"max_leaf", "2"}});
    ASSERT_TRUE(validate(bvh, std::span<const Triangle>(tris)).ok()) << builder;
    EXPECT_EQ(epo_cost(bvh, tris, SahCost{}), 0.0) << builder;
  }
  EXPECT_EQ(epo_cost(Bvh{}, tris, SahCost{}), 0.0);
}

// The definition, node by node: the triangles not referenced in n's subtree, each clipped to n's box by
// all six planes.
double brute_force_epo(const Bvh& bvh, const std::vector<Triangle>& tris, const SahCost& cost) {
  auto area_of = [](const ClipPolygon& p) {
    double sx = 0, sy = 0, sz = 0;
    for (int i = 1; i + 1 < p.count; ++i) {
      const double ax = p.v[i][0] - p.v[0][0], ay = p.v[i][1] - p.v[0][1], az = p.v[i][2] - p.v[0][2];
      const double bx = p.v[i + 1][0] - p.v[0][0], by = p.v[i + 1][1] - p.v[0][1],
                   bz = p.v[i + 1][2] - p.v[0][2];
      sx += ay * bz - az * by, sy += az * bx - ax * bz, sz += ax * by - ay * bx;
    }
    return 0.5 * std::sqrt(sx * sx + sy * sy + sz * sz);
  };
  double total_area = 0.0;
  for (const Triangle& t : tris) total_area += area_of(ClipPolygon::of(t));
  double sum = 0.0;
  for (const Node& n : bvh.nodes) {
    std::set<uint32_t> inside;
    std::vector<const Node*> stack{&n};
    while (!stack.empty()) {
      const Node* m = stack.back();
      stack.pop_back();
      if (m->is_leaf())
        for (uint32_t r = 0; r < m->prim_count; ++r) inside.insert(bvh.prim_refs[m->first + r]);
      else
        for (uint32_t c = 0; c < m->child_count; ++c) stack.push_back(&bvh.nodes[m->first + c]);
    }
    const double weight = n.is_leaf() ? cost.leaf_cost(n.prim_count) : cost.c_trav;
    for (uint32_t t = 0; t < tris.size(); ++t) {
      if (inside.count(t)) continue;
      ClipPolygon p = ClipPolygon::of(tris[t]);
      for (int k = 0; k < 3; ++k) {
        p.clip(k, n.bounds.min[static_cast<std::size_t>(k)], false);
        p.clip(k, n.bounds.max[static_cast<std::size_t>(k)], true);
      }
      if (p.count >= 3) sum += weight * area_of(p);
    }
  }
  return sum / total_area;
}

TEST(Epo, MatchesTheDefinitionOnBinaryWideAndSpatialSplitTrees) {
  const std::vector<Triangle> random = test::random_triangles(400, 11, 10.0f, 6.0f);
  // Long thin triangles, which spatial splits exist for.
  const std::vector<Triangle> needles = generate_needles(300, 3, 50.0);
  struct Case {
    std::string builder;
    ParamOverrides params;
    const std::vector<Triangle>& tris;
  };
  for (const Case& c : std::vector<Case>{{"binned_sah", {}, random},
                                         {"lbvh", {}, random},
                                         {"wide_binned_sah", {{"arity", "4"}}, random},
                                         {"sbvh", {}, needles},
                                         {"sbvh", {{"max_leaf", "1"}}, needles}}) {
    const std::vector<Triangle>& tris = c.tris;
    const Bvh bvh = build(c.builder, tris, c.params);
    ASSERT_TRUE(validate(bvh, std::span<const Triangle>(tris)).ok()) << c.builder;
    if (c.builder == "sbvh") {
      EXPECT_GT(bvh.prim_refs.size(), tris.size()) << "no spatial split happened";
    }
    const SahCost cost{1.5f, 1.0f};
    const double expected = brute_force_epo(bvh, tris, cost);
    EXPECT_GT(expected, 0.0) << c.builder;
    EXPECT_NEAR(epo_cost(bvh, tris, cost), expected, 1e-9 * expected) << c.builder;
  }
}

// With spatial splits a triangle is in every subtree that references a part of it: the leaves that hold
// parts of one triangle do not count each other's parts. Counting only one of its references (the first)
// as membership would charge the others' boxes for the triangle's own surface.
TEST(Epo, SpatialSplitReferencesAllCountAsTheTrianglesOwn) {
  const std::vector<Triangle> tris = generate_needles(300, 3, 50.0);
  const Bvh sbvh = build("sbvh", tris, {{"max_leaf", "1"}});
  ASSERT_TRUE(validate(sbvh, std::span<const Triangle>(tris)).ok());
  ASSERT_GT(sbvh.prim_refs.size(), tris.size());
  const double epo = epo_cost(sbvh, tris, SahCost{});
  EXPECT_NEAR(epo, brute_force_epo(sbvh, tris, SahCost{}), 1e-9 * epo);
  // The same tree with each triangle's repeated references pointed at a triangle of zero area where it
  // was: the leaves then hold other surface, and the cost rises.
  std::vector<Triangle> with_dummy = tris;
  with_dummy.push_back({{0, 0, 0}, {0, 0, 0}, {0, 0, 0}});
  Bvh first_only = sbvh;
  std::set<uint32_t> seen;
  for (uint32_t& r : first_only.prim_refs)
    if (!seen.insert(r).second) r = static_cast<uint32_t>(tris.size());
  EXPECT_GT(epo_cost(first_only, with_dummy, SahCost{}), epo);
}

TEST(Epo, SameValueForAnyThreadCount) {
  const std::vector<Triangle> tris = test::random_triangles(20000, 5, 50.0f, 4.0f);
  const Bvh bvh = build("binned_sah", tris);
  std::vector<double> values;
  for (const std::size_t threads : {1, 2, 3, 8}) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    values.push_back(epo_cost(bvh, tris, SahCost{}));
  }
  for (const double v : values) EXPECT_EQ(v, values.front());
  EXPECT_GT(values.front(), 0.0);
}

TEST(Epo, ReferencesOutOfRangeAreAnError) {
  Bvh bvh = two_leaves();
  bvh.prim_refs[1] = 7;
  EXPECT_THROW(epo_cost(bvh, kTwo, SahCost{}), Error);
}

TEST(Epo, TheBlendIsThePapersWeight) {
  EXPECT_DOUBLE_EQ(sah_epo_cost(10.0, 0.0), 10.0 * (1.0 - kEpoWeight));
  EXPECT_DOUBLE_EQ(sah_epo_cost(0.0, 10.0), 10.0 * kEpoWeight);
}

}  // namespace
}  // namespace sahbench
