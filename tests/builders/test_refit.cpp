// Refit (core/refit.h): after the triangles move, every box contains its children and its
// triangles, boxes are tight (exactly the union of what they hold), traversal of the refitted tree
// finds the brute-force hits on the moved geometry, for arities 2, 4 and 8 (collapsed and built wide),
// and the result does not depend on the thread count.

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>

#include "builders/collapse.h"
#include "builders/registry.h"
#include "core/build_input.h"
#include "core/refit.h"
#include "core/validate.h"
#include "scenes/wave.h"
#include "tests/support/hit_check.h"
#include "tests/support/test_scenes.h"
#include "traversal/brute_force.h"
#include "traversal/bvh2_traversal.h"

namespace sahbench {
namespace {

Bvh build_binned(std::span<const Triangle> triangles) {
  const BuilderInfo& b = find_builder("binned_sah");
  return b.build(BuildInput::from_triangles(triangles), resolve_params(b.name, b.params, {}));
}

// Boxes after a refit are exactly the union of what they hold (validate checks only containment).
void expect_tight(const Bvh& bvh, std::span<const Triangle> triangles) {
  for (std::size_t i = 0; i < bvh.nodes.size(); ++i) {
    const Node& n = bvh.nodes[i];
    Aabb box;
    if (n.is_leaf()) {
      for (uint32_t k = 0; k < n.prim_count; ++k) box.extend(triangles[bvh.prim_refs[n.first + k]].bounds());
    } else {
      for (uint32_t c = 0; c < n.child_count; ++c) box.extend(bvh.nodes[n.first + c].bounds);
    }
    ASSERT_EQ(n.bounds, box) << "node " << i;
  }
}

void expect_hits_match(const Bvh& bvh, const std::vector<Triangle>& triangles, uint64_t seed) {
  const std::vector<Ray> rays = test::random_rays(triangles, 300, seed);
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const Hit got = closest_hit(bvh, triangles, rays[i]);
    const Hit ref = brute_force_closest(triangles, rays[i]);
    ASSERT_TRUE(test::same_closest_hit(got, ref, triangles, rays[i])) << "ray " << i;
    ASSERT_EQ(any_hit(bvh, triangles, rays[i]), brute_force_any(triangles, rays[i])) << "ray " << i;
  }
}

TEST(Refit, DeformingWaveOverSeveralFramesForArities2To8) {
  const WaveParams wave{3000, 5, 0.15, 4};
  const std::vector<Triangle> first = generate_wave(wave, 0.0);
  const Bvh binary = build_binned(first);
  for (uint32_t arity : {2u, 4u, 8u}) {
    Bvh bvh = arity == 2 ? binary : collapse_greedy(binary, arity);
    ASSERT_TRUE(validate(bvh, std::span<const Triangle>(first)).ok()) << "collapse to " << arity;
    uint32_t widest = 0;
    for (const Node& n : bvh.nodes) widest = std::max<uint32_t>(widest, n.child_count);
    ASSERT_EQ(widest, arity) << "the collapse must make nodes of the full arity";
    for (double t : {0.13, 0.5, 0.77}) {
      SCOPED_TRACE("arity " + std::to_string(arity) + ", t = " + std::to_string(t));
      const std::vector<Triangle> moved = generate_wave(wave, t);
      ASSERT_NE(moved, first);
      // Before the refit the old boxes miss moved triangles: the test would catch a refit that did nothing.
      if (t == 0.13) {
        EXPECT_FALSE(validate(bvh, std::span<const Triangle>(moved)).ok());
      }
      refit(bvh, moved);
      const ValidationReport report = validate(bvh, std::span<const Triangle>(moved));
      ASSERT_TRUE(report.ok()) << report.summary();
      expect_tight(bvh, moved);
      expect_hits_match(bvh, moved, 17 + arity);
    }
  }
}

TEST(Refit, WideBuiltTreeOnTheWave) {
  const WaveParams wave{3000, 8, 0.15, 4};
  const std::vector<Triangle> first = generate_wave(wave, 0.0);
  const BuilderInfo& b = find_builder("wide_binned_sah");
  const ParamSet params = resolve_params(b.name, b.params, {{"arity", "8"}});
  Bvh bvh = b.build(BuildInput::from_triangles(first), params);
  ASSERT_EQ(bvh.arity, 8u);
  const std::vector<Triangle> moved = generate_wave(wave, 0.6);
  refit(bvh, moved);
  const ValidationReport report = validate(bvh, std::span<const Triangle>(moved));
  ASSERT_TRUE(report.ok()) << report.summary();
  expect_tight(bvh, moved);
  expect_hits_match(bvh, moved, 23);
}

TEST(Refit, OnTheBuildPositionsReproducesTheBuiltBoxes) {
  const std::vector<Triangle> tris = test::random_triangles(2000, 3);
  const Bvh built = build_binned(tris);
  Bvh refitted = built;
  for (Node& n : refitted.nodes) n.bounds = Aabb{};  // forget every box
  refit(refitted, tris);
  EXPECT_EQ(refitted, built);
}

TEST(Refit, SameTreeForAnyThreadCount) {
  const WaveParams wave{20000, 2, 0.2, 6};
  const Bvh built = build_binned(generate_wave(wave, 0.0));
  const std::vector<Triangle> moved = generate_wave(wave, 0.4);
  Bvh one = built, two = built;
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    refit(one, moved);
  }
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    refit(two, moved);
  }
  EXPECT_EQ(one, two);
  expect_tight(one, moved);
}

// Spatial-split trees reference a triangle from several leaves whose built boxes hold only part of it;
// refit gives each such leaf the triangle's full box, which is conservative and keeps traversal exact.
TEST(Refit, RepeatedReferencesGetTheFullTriangleBox) {
  const std::vector<Triangle> tris = {{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}}, {{5, 5, 5}, {6, 5, 5}, {5, 6, 5}}};
  Bvh bvh;
  bvh.arity = 2;
  bvh.prim_refs = {0, 0, 1};
  // Root; a leaf with the left half of triangle 0 (clipped at x = 2); an inner node holding a leaf with
  // the right half of triangle 0 and a leaf with triangle 1.
  bvh.nodes = {{Aabb{{0, 0, 0}, {6, 6, 5}}, 1, 2, 0},
               {Aabb{{0, 0, 0}, {2, 4, 0}}, 0, 0, 1},
               {Aabb{{2, 0, 0}, {6, 6, 5}}, 3, 2, 0},
               {Aabb{{2, 0, 0}, {4, 2, 0}}, 1, 0, 1},
               {Aabb{{5, 5, 5}, {6, 6, 5}}, 2, 0, 1}};
  ASSERT_TRUE(validate(bvh, std::span<const Triangle>(tris)).ok())
      << "the hand-made tree, clipped boxes allowed";
  refit(bvh, tris);
  EXPECT_EQ(bvh.nodes[1].bounds, tris[0].bounds());
  EXPECT_EQ(bvh.nodes[3].bounds, tris[0].bounds());
  EXPECT_EQ(bvh.nodes[2].bounds, merge(tris[0].bounds(), tris[1].bounds()));
  EXPECT_EQ(bvh.nodes[0].bounds, merge(tris[0].bounds(), tris[1].bounds()));
  EXPECT_TRUE(validate(bvh, std::span<const Triangle>(tris)).ok());
}

TEST(Refit, SingleLeafAndEmptyTree) {
  const std::vector<Triangle> tris = test::random_triangles(3, 9);
  Bvh leaf;
  leaf.prim_refs = {0, 1, 2};
  leaf.nodes = {{Aabb{}, 0, 0, 3}};
  refit(leaf, tris);
  EXPECT_EQ(leaf.nodes[0].bounds, merge(merge(tris[0].bounds(), tris[1].bounds()), tris[2].bounds()));
  Bvh empty;
  refit(empty, tris);
  EXPECT_TRUE(empty.nodes.empty());
}

}  // namespace
}  // namespace sahbench
