// Every layout, every kernel variant and every instruction set available here, against two references:
// the scalar common-format kernel (bvh2_traversal.h) on the same tree, which must give bit-identical
// hits and visit exactly the same nodes (the SIMD kernels compute each lane with the scalar operations),
// and brute force, which the default variant (watertight, robust) must match.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <deque>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "builders/registry.h"
#include "cli/list_command.h"
#include "core/error.h"
#include "core/refit.h"
#include "core/validate.h"
#include "tests/builders/builder_cases.h"
#include "tests/support/hit_check.h"
#include "tests/support/prerequisites.h"
#include "tests/support/test_scenes.h"
#include "traversal/brute_force.h"
#include "traversal/bvh2_traversal.h"
#include "traversal/layout.h"
#include "traversal/triangle_tests.h"
#include "traversal/variant_dispatch.h"
#include "traversal/wide_bvh.h"

namespace sahbench {
namespace {

// Builders whose trees each layout arity is tested on.
std::vector<std::pair<std::string, ParamOverrides>> builders_for(uint32_t arity) {
  if (arity == 2) return {{"binned_sah", {}}, {"sweep_sah", {{"max_leaf", "1"}}}};
  const std::string a = std::to_string(arity);
  return {{"wide_binned_sah", {{"arity", a}}},
          {"wide_collapse", {{"arity", a}}},
          {"wide_collapse", {{"arity", a}, {"method", "greedy"}, {"max_leaf", "13"}}}};
}

// The specs a layout is tested with: its 4 triangle tests x 3 box tests, for SIMD layouts with the scalar
// kernels and with every SIMD set available here (the SIMD sets share one source, so the variants are
// crossed with the widest and the default variant with the others, to keep the suite quick). The sets
// left out for want of kernels go into `skips`.
std::vector<std::string> specs_for(const LayoutInfo& layout, test::Skips& skips) {
  std::vector<std::string> out;
  auto add_variants = [&](const std::string& isa) {
    for (const char* tri : {"watertight", "mt", "mt0", "mtn"})
      for (const char* box : {"robust", "fast", "fma"})
        out.push_back(layout.name + ":tri=" + tri + ",box=" + box + isa);
  };
  const KernelIsa best = best_kernel_isa();
  if (!layout.has_isa) {
    add_variants("");
    for (const char* order : {"nearest", "stored", "nearest_stored", "farthest_stored"})
      out.push_back(layout.name + ":anyhit=" + order);
    // The binary layouts' packet kernels: every variant and any-hit order in packets of 8 with the
    // instruction set isa=auto picks, and in AVX2's packets of 8 and AVX-512's of 16 where that is
    // another build.
    if (layout.has_packet && skips.have_isa(KernelIsa::kAvx2)) {
      std::vector<std::string> packets{",packet=8"};
      if (skips.have_isa(KernelIsa::kAvx512))
        packets.insert(packets.end(), {",packet=16", ",packet=8,isa=avx2"});
      for (const std::string& packet : packets) {
        add_variants(packet);
        for (const char* order : {"nearest", "stored", "nearest_stored", "farthest_stored"})
          out.push_back(layout.name + ":anyhit=" + order + packet);
      }
    }
    return out;
  }
  add_variants(",isa=scalar");
  if (best != KernelIsa::kScalar) add_variants(",isa=" + std::string(to_string(best)));
  // Every any-hit order, whichever the tree's arity picks by default.
  for (const char* order : {"nearest", "stored", "nearest_stored", "farthest_stored"}) {
    out.push_back(layout.name + ":anyhit=" + order + ",isa=scalar");
    out.push_back(layout.name + ":tri=mt0,box=fast,anyhit=" + order + ",isa=" + std::string(to_string(best)));
    out.push_back(layout.name + ":tri=mtn,box=fma,anyhit=" + order + ",isa=" + std::string(to_string(best)));
  }
  // The packet kernels (AVX2 and AVX-512 only) with every variant on the widest set, and the default
  // variant on the other; 16-ray packets on AVX-512.
  if (best == KernelIsa::kAvx2 || best == KernelIsa::kAvx512) {
    add_variants(",isa=" + std::string(to_string(best)) + ",packet=8");
    for (const char* order : {"nearest", "stored", "nearest_stored", "farthest_stored"})
      out.push_back(layout.name + ":anyhit=" + order + ",packet=8,isa=" + std::string(to_string(best)));
    if (best == KernelIsa::kAvx512) {
      out.push_back(layout.name + ":isa=avx2,packet=8");
      // Sixteen-ray packets (AVX-512 only), every variant and any-hit order.
      add_variants(",isa=avx512,packet=16");
      for (const char* order : {"nearest", "stored", "nearest_stored", "farthest_stored"})
        out.push_back(layout.name + ":anyhit=" + order + ",packet=16,isa=avx512");
    }
  } else {
    (void)skips.have_isa(KernelIsa::kAvx2);  // records why the packet kernels were not tested
  }
  // The other sets with the default variant, and with tri=mtn and box=fma, the two tests written with
  // FMA instructions (fmaf on SSE).
  for (KernelIsa isa : {KernelIsa::kSse, KernelIsa::kAvx2, KernelIsa::kAvx512}) {
    if (isa == best || !skips.have_isa(isa)) continue;
    out.push_back(layout.name + ":isa=" + std::string(to_string(isa)));
    out.push_back(layout.name + ":tri=mtn,box=fma,isa=" + std::string(to_string(isa)));
  }
  return out;
}

struct Case {
  std::string name;
  std::vector<Triangle> triangles;
};

std::vector<Case> cases() {
  std::vector<Case> out;
  out.push_back({"random3000", test::random_triangles(3000, 21)});
  out.push_back({"one_triangle", test::random_triangles(1, 3)});
  out.push_back({"cube_grid", test::cube_grid(10, 2.0f)});
  // Float products overflow on the huge half and underflow on the tiny one: those lanes are decided in
  // double (triangle_tests.h), by the SIMD kernels as by the scalar test.
  std::vector<Triangle> huge_and_tiny;
  for (float scale : {0x1p66f, 0x1p-66f})
    for (Triangle t : test::random_triangles(300, scale > 1 ? 31 : 32))
      huge_and_tiny.push_back({t.v0 * scale, t.v1 * scale, t.v2 * scale});
  out.push_back({"huge_and_tiny", huge_and_tiny});
  for (auto& scene : test::scene_cases())
    if (scene.name == "needles" || scene.name == "identical" || scene.name == "planar")
      out.push_back({scene.name, scene.triangles});
  return out;
}

// Whether the triangle test Tri hits any of `triangles` within the ray's interval.
template <class Tri>
bool test_hits_any(const std::vector<Triangle>& triangles, const Ray& ray) {
  float t, u, v;
  return std::any_of(triangles.begin(), triangles.end(), [&](const Triangle& tri) {
    return Tri(ray).intersect(tri, ray.tmin, ray.tmax, t, u, v);
  });
}

class LayoutVsReference : public ::testing::TestWithParam<std::string> {};

TEST_P(LayoutVsReference, EveryVariantMatchesTheScalarKernelOnTheSameTreeAndBruteForce) {
  test::Skips skips;
  const LayoutInfo& layout = find_layout(GetParam());
  for (const Case& scene : cases()) {
    SCOPED_TRACE(scene.name);
    const BuildInput input = BuildInput::from_triangles(scene.triangles);
    // Random rays, and rays in groups of kMaxWidePacket that the packet kernels trace as packets (packets are
    // cut from the start of each chunk, a multiple of kMaxWidePacket rays): near each other, and each in a
    // direction and interval of its own within one octant; then four such streams interleaved ray by ray,
    // as a shadow ray set interleaves its lights (the wide layouts trace packets of mixed octants ray by
    // ray, the binary ones as packets with per-lane planes).
    auto rays = test::random_rays(scene.triangles, 800, 5);
    ASSERT_EQ(rays.size() % kMaxWidePacket, 0u);
    for (const Ray& r : test::coherent_rays(scene.triangles, 400, 6, kMaxWidePacket)) rays.push_back(r);
    ASSERT_EQ(rays.size() % kMaxWidePacket, 0u);
    for (const Ray& r : test::diverging_rays(scene.triangles, 400, 8, kMaxWidePacket)) rays.push_back(r);
    for (const Ray& r : test::interleaved_rays(scene.triangles, 6 * 4 * kMaxWidePacket, 9, kMaxWidePacket, 4))
      rays.push_back(r);
    // Shadow rays to four points, ray i to point i % 4, which the wide kernels trace through their shadow
    // cache: the first half with some axis-parallel to a light (box=fma traces a batch with such a ray
    // without the cache), the second without, so that the batch of 256 rays from 2304 on is all theirs.
    for (const bool level : {true, false})
      for (const Ray& r : test::shadow_rays(scene.triangles, 18 * kMaxWidePacket, 10, 4, level))
        rays.push_back(r);
    // An odd count: the binary layouts trace rays in groups of eight walks, the last group partial; and the
    // packet layouts' last packet holds 7 rays, its other lanes unused.
    for (const Ray& r : test::coherent_rays(scene.triangles, 7, 7, 7)) rays.push_back(r);
    ASSERT_EQ(rays.size() % kMaxWidePacket, 7u);
    std::vector<Hit> reference(rays.size());
    std::vector<uint8_t> reference_any(rays.size());
    for (std::size_t i = 0; i < rays.size(); ++i) {
      reference[i] = brute_force_closest(scene.triangles, rays[i]);
      reference_any[i] = brute_force_any(scene.triangles, rays[i]);
    }
    // A case whose rays all miss (as they did on the huge scene while the generators overflowed) would
    // test only the miss path.
    EXPECT_GT(std::count_if(reference.begin(), reference.end(), [](const Hit& h) { return h.found(); }), 100)
        << "too few rays hit";
    {
      for (const auto& [builder, overrides] : builders_for(layout.arity)) {
        const BuilderInfo& info = find_builder(builder);
        const Bvh bvh = info.build(input, resolve_params(builder, info.params, overrides));
        // The scalar kernel's answers and counts on this tree, once per variant: the specs of other
        // instruction sets and packet widths with the same variant compare against the same answers.
        struct ScalarAnswers {
          KernelVariant variant;
          detail::ClosestTies ties;
          std::vector<Hit> closest;
          std::vector<uint8_t> any;
          TraversalCounters closest_counts, any_counts;
        };
        std::deque<ScalarAnswers> scalar_answers;  // references stay valid as it grows
        auto scalar_for = [&](const KernelVariant& variant,
                              detail::ClosestTies ties) -> const ScalarAnswers& {
          for (const ScalarAnswers& a : scalar_answers)
            if (a.variant == variant && a.ties == ties) return a;
          ScalarAnswers a{variant, ties, std::vector<Hit>(rays.size()), std::vector<uint8_t>(rays.size()),
                          {},      {}};
          // The general loop, one triangle at a time (kBinaryLoop off): not the binary walks' own leaf
          // loop, which tests watertight triangles four at a time, so that the binary layouts are held
          // to one-at-a-time answers.
          with_test_types(variant, [&]<class Tri, class Box>() {
            for (std::size_t i = 0; i < rays.size(); ++i) {
              a.any[i] = detail::traverse<Tri, Box, true, true, false>(bvh, scene.triangles, rays[i],
                                                                       &a.any_counts, variant.any_hit)
                             .found();
              a.closest[i] = detail::traverse<Tri, Box, false, true, false>(
                  bvh, scene.triangles, rays[i], &a.closest_counts, AnyHitOrder::kAuto, ties);
            }
          });
          scalar_answers.push_back(std::move(a));
          return scalar_answers.back();
        };
        for (const std::string& text : specs_for(layout, skips)) {
          SCOPED_TRACE(builder + " " + text);
          const LayoutSpec spec = parse_layout_spec(text);
          const auto compiled = compile_layout(spec, bvh, scene.triangles);
          std::vector<Hit> hits(rays.size());
          std::vector<uint8_t> occluded(rays.size());
          compiled->trace_closest(rays, hits);
          compiled->trace_any(rays, occluded);
          const TraceCounts closest_counts = compiled->count_closest(rays);
          const TraceCounts any_counts = compiled->count_any(rays);

          // The scalar kernel with the same tests, on the same tree, ray by ray.
          // bvh2_packed orders closest hit's ties by exit (packed_bvh2.h), and so do its packets' counts.
          const ScalarAnswers& scalar =
              scalar_for(spec.variant, spec.name == "bvh2_packed" ? detail::ClosestTies::kExitFirst
                                                                  : detail::ClosestTies::kLaterSlot);
          const TraversalCounters& scalar_closest = scalar.closest_counts;
          const TraversalCounters& scalar_any = scalar.any_counts;
          bool tie_broken_differently = false;
          const bool cache_may_see_more =
              layout.has_isa && spec.shadow_cache && spec.variant.box != BoxTestKind::kRobust;
          with_test_types(spec.variant, [&]<class Tri, class Box>() {
            for (std::size_t i = 0; i < rays.size(); ++i) {
              if (occluded[i] && !scalar.any[i] && cache_may_see_more) {
                // The shadow cache tests a leaf without the walk's box tests: it may find the hit of a
                // triangle whose box a non-robust box test culled, a hit of this triangle test.
                ASSERT_TRUE(test_hits_any<Tri>(scene.triangles, rays[i])) << "ray " << i;
              } else {
                ASSERT_EQ(occluded[i] != 0, scalar.any[i] != 0) << "ray " << i;
              }
              const Hit& expected = scalar.closest[i];
              // The wide layouts test a block's triangles four at a time against one tmax. (The binary
              // walks' four-lane leaves re-test after a hit that lowered tmax, so they are held to the
              // one-at-a-time answers.)
              const bool in_fours = layout.arity > 2;
              if ((in_fours || spec.packet > 1) && hits[i].prim != expected.prim && hits[i].found() &&
                  expected.found() && hits[i].t == expected.t) {
                // An exact tie, broken differently: four triangles tested at once meet the same tmax
                // where the scalar kernel lowers tmax after each hit (the watertight test compares t *
                // det with tmax * det, so a second hit at exactly tmax may or may not pass), and a
                // packet meets the two triangles in another order than the ray alone. Both answers hit
                // at that very t. The binary layouts, one ray at a time, answer as one triangle at a
                // time in the scalar kernel's order and are held to its tie rule.
                float t, u, v;
                ASSERT_TRUE(Tri(rays[i]).intersect(scene.triangles[hits[i].prim], rays[i].tmin, rays[i].tmax,
                                                   t, u, v));
                ASSERT_EQ(t, expected.t) << "ray " << i;
                tie_broken_differently = true;  // and so may cull other nodes: the counts may differ too
                continue;
              }
              if (spec.packet > 1 && spec.variant != KernelVariant{} && hits[i].prim != expected.prim &&
                  hits[i].found() && expected.found()) {
                // A packet visits leaves in another order, and the fast variants' distances may put a
                // triangle's hit a rounding before its box's entry: a leaf culled in one order is
                // tested in the other. Both answers are hits of this test within a few ulps of each
                // other; the default variant is held to brute force below. On the huge half of
                // huge_and_tiny the binary layouts' scalar Möller–Trumbore products overflow (the SIMD
                // kernels decide those lanes in double), so there its hits are hits of the test but
                // their t may be far from the truth.
                float t, u, v;
                ASSERT_TRUE(Tri(rays[i]).intersect(scene.triangles[hits[i].prim], rays[i].tmin, rays[i].tmax,
                                                   t, u, v));
                ASSERT_EQ(t, hits[i].t) << "ray " << i;
                if (!(layout.arity == 2 && scene.name == "huge_and_tiny")) {
                  ASSERT_LE(std::fabs(t - expected.t), 1e-5f * std::fabs(expected.t)) << "ray " << i;
                }
                tie_broken_differently = true;
                continue;
              }
              ASSERT_EQ(hits[i].prim, expected.prim)
                  << "ray " << i << ": t " << hits[i].t << ", expected " << expected.t;
              if (expected.found()) {
                ASSERT_EQ(hits[i].t, expected.t) << "ray " << i;
                ASSERT_EQ(hits[i].u, expected.u) << "ray " << i;
                ASSERT_EQ(hits[i].v, expected.v) << "ray " << i;
              }
            }
          });
          if (HasFatalFailure()) return;
          EXPECT_EQ(closest_counts.rays, rays.size());
          if (!tie_broken_differently) {
            EXPECT_EQ(closest_counts.prims_tested, scalar_closest.prim_tests);
          }
          // Any hit: the scalar kernel counts a leaf's whole size when it enters it, a SIMD layout only
          // the blocks it tests before the first hit; so only the binary layouts count exactly as many.
          if (layout.arity == 2) {
            EXPECT_EQ(any_counts.prims_tested, scalar_any.prim_tests);
          } else {
            EXPECT_LE(any_counts.prims_tested, scalar_any.prim_tests);
          }
          // A tree that is one leaf has no inner node in the common format but one root node in a wide
          // layout; otherwise both visit exactly the same nodes.
          if (!(layout.arity > 2 && bvh.root().is_leaf()) && !tie_broken_differently) {
            EXPECT_EQ(closest_counts.nodes_visited, scalar_closest.nodes_visited());
            EXPECT_EQ(any_counts.nodes_visited, scalar_any.nodes_visited());
            EXPECT_EQ(closest_counts.leaves_visited, scalar_closest.leaf_visits);
            EXPECT_EQ(any_counts.leaves_visited, scalar_any.leaf_visits);
          }

          // The default variant is exact: the brute-force answer (ties aside).
          if (spec.variant == KernelVariant{}) {
            for (std::size_t i = 0; i < rays.size(); ++i) {
              ASSERT_TRUE(test::same_closest_hit(hits[i], reference[i], scene.triangles, rays[i]))
                  << "ray " << i;
              ASSERT_EQ(occluded[i], reference_any[i]) << "ray " << i;
            }
          }
        }
      }
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

std::vector<std::string> layout_names() {
  std::vector<std::string> out;
  for (const auto& l : layouts()) out.push_back(l.name);
  return out;
}

INSTANTIATE_TEST_SUITE_P(AllLayouts, LayoutVsReference, ::testing::ValuesIn(layout_names()),
                         [](const auto& info) { return info.param; });

// Moves every vertex by a smooth field (so neighbours stay neighbours, as in an animation) plus a
// per-vertex jitter: boxes grow, shrink and move.
std::vector<Triangle> deformed(std::vector<Triangle> tris, float time) {
  auto move = [&](Vec3 p) {
    return Vec3{p.x + std::sin(p.y * 0.7f + time) * 1.5f, p.y * (1.0f + 0.3f * time),
                p.z + std::cos(p.x * 0.5f) * time};
  };
  for (auto& t : tris) t = {move(t.v0), move(t.v1), move(t.v2)};
  return tris;
}

TEST(Layouts, RefitLayoutsMatchBruteForceOnDeformedGeometry) {
  const auto original = test::random_triangles(4000, 17);
  for (uint32_t arity : {2u, 4u, 8u}) {
    const BuilderInfo& info = find_builder("wide_binned_sah");
    const Bvh bvh = info.build(BuildInput::from_triangles(original),
                               resolve_params(info.name, info.params, {{"arity", std::to_string(arity)}}));
    std::vector<std::string> specs{"bvh2", "bvh2_packed"};
    if (kernel_isa_available(KernelIsa::kAvx2)) {
      specs.push_back("bvh2:packet=8");
      specs.push_back("bvh2_packed:packet=8");
    }
    if (arity > 2) {
      specs.clear();
      // The robust default (blocks of vertices) and Möller–Trumbore (blocks of edges, and of edges and
      // normals: wide_bvh.h).
      for (KernelIsa isa : {KernelIsa::kScalar, best_kernel_isa()})
        for (const char* tri : {"watertight", "mt0", "mtn"})
          specs.push_back("bvh" + std::to_string(arity) + ":tri=" + tri +
                          ",isa=" + std::string(to_string(isa)));
    }
    for (const std::string& spec : specs) {
      SCOPED_TRACE(spec);
      auto layout = compile_layout(spec, bvh, original);
      std::vector<std::vector<Triangle>> frames;  // bvh2 borrows each frame's triangles
      for (float time : {0.5f, 2.0f, 0.0f}) {
        const auto& moved = frames.emplace_back(deformed(original, time));
        layout->refit(moved);
        const auto rays = test::random_rays(moved, 600, 11);
        std::vector<Hit> hits(rays.size());
        std::vector<uint8_t> occluded(rays.size());
        layout->trace_closest(rays, hits);
        layout->trace_any(rays, occluded);
        std::size_t found = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
          const Hit ref = brute_force_closest(moved, rays[i]);
          found += ref.found();
          ASSERT_TRUE(test::same_closest_hit(hits[i], ref, moved, rays[i])) << "t=" << time << " ray " << i;
          ASSERT_EQ(occluded[i] != 0, brute_force_any(moved, rays[i])) << "t=" << time << " ray " << i;
        }
        EXPECT_GT(found, rays.size() / 10);
      }
    }
  }
}

// tri=mtn's SIMD kernels (FMA instructions, the comparisons scaled by |det|, the division only for hits)
// against its scalar test, bit for bit, on every instruction set here, for bvh4 and bvh8: closest hits
// (primitive, t, u, v) equal the brute force of MollerTrumboreNormalTest, and so do any hits. The scene
// mixes random triangles with specks of edge 2^-66 (subnormal det: 1 / |det| once made hits at t = inf),
// triangles of edge 1e15, lines (zero normal) and triangles seen edge-on; rays aim at specks and have
// +0 and -0 components.
TEST(Layouts, StoredNormalKernelsComputeTheScalarTestsHits) {
  test::Skips skips;
  auto tris = test::random_triangles(1500, 31);
  std::vector<Ray> rays = test::random_rays(tris, 1500, 9);
  const float tiny = 0x1p-66f;
  for (int i = 0; i < 40; ++i) {
    const Vec3 at = tris[static_cast<std::size_t>(i) * 37].v0;
    const Vec3 speck{static_cast<float>(i) * 0x1p-60f, 0.0f,
                     static_cast<float>(i) * 0.25f};  // near the z axis
    tris.push_back({speck, speck + Vec3{tiny, 0.0f, 0.0f}, speck + Vec3{0.0f, tiny, 0.0f}});
    rays.push_back(Ray{speck + Vec3{tiny / 4, tiny / 4, -0.125f}, 0.0f, {0.0f, -0.0f, 1.0f}});
    tris.push_back({at, at + Vec3{1.0f, 1.0f, 1.0f}, at + Vec3{2.0f, 2.0f, 2.0f}});  // a line
    tris.push_back(
        {at, at + Vec3{1e15f, 0.0f, 0.0f}, at + Vec3{0.0f, 0.0f, 1e15f}});  // huge, in the plane y = at.y
    rays.push_back(Ray{at + Vec3{-1.0f, 0.0f, 0.5f}, 0.0f, {1.0f, 0.0f, 0.0f}});  // edge-on to it
  }
  for (std::size_t i = 0; i < rays.size(); i += 5) rays[i].dir[i % 3] = i % 2 ? 0.0f : -0.0f;
  std::size_t found = 0;
  for (uint32_t arity : {4u, 8u}) {
    const BuilderInfo& info = find_builder("wide_binned_sah");
    const Bvh bvh = info.build(BuildInput::from_triangles(tris),
                               resolve_params(info.name, info.params, {{"arity", std::to_string(arity)}}));
    for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kSse, KernelIsa::kAvx2, KernelIsa::kAvx512}) {
      if (!skips.have_isa(isa)) continue;
      const std::string spec =
          "bvh" + std::to_string(arity) + ":tri=mtn,box=fast,isa=" + std::string(to_string(isa));
      SCOPED_TRACE(spec);
      const auto layout = compile_layout(spec, bvh, tris);
      std::vector<Hit> hits(rays.size());
      std::vector<uint8_t> occluded(rays.size());
      layout->trace_closest(rays, hits);
      layout->trace_any(rays, occluded);
      for (std::size_t i = 0; i < rays.size(); ++i) {
        const Hit ref = brute_force_closest<MollerTrumboreNormalTest>(tris, rays[i]);
        found += ref.found();
        ASSERT_EQ(hits[i].prim, ref.prim) << "ray " << i;
        if (ref.found()) {
          ASSERT_EQ(std::bit_cast<uint32_t>(hits[i].t), std::bit_cast<uint32_t>(ref.t)) << "ray " << i;
          ASSERT_EQ(std::bit_cast<uint32_t>(hits[i].u), std::bit_cast<uint32_t>(ref.u)) << "ray " << i;
          ASSERT_EQ(std::bit_cast<uint32_t>(hits[i].v), std::bit_cast<uint32_t>(ref.v)) << "ray " << i;
          ASSERT_TRUE(std::isfinite(hits[i].t)) << "ray " << i;
        }
        ASSERT_EQ(occluded[i] != 0, brute_force_any<MollerTrumboreNormalTest>(tris, rays[i])) << "ray " << i;
      }
    }
  }
  EXPECT_GT(found, rays.size());  // over all the layouts: most rays hit
  SAHBENCH_REPORT_SKIPS(skips);
}

// A layout refitted in place is the layout compiled afresh from the refitted tree: layouts depend only on
// the tree's topology and the triangles, and both refits recompute every box from the triangles (min and
// max are exact, so the order of the unions does not matter). So the hits must be bit-identical and the
// counting kernels must visit the same nodes and test the same primitives, whatever frames came before
// (the animation runner refits each layout once per frame, repeating it on one frame for its timings).
TEST(Layouts, RefitEqualsAFreshCompileOfTheRefittedTree) {
  const auto original = test::random_triangles(3000, 23);
  struct TreeCase {
    std::string builder;
    ParamOverrides overrides;
    std::vector<std::string> specs;
  };
  const std::vector<TreeCase> trees = {
      {"binned_sah", {}, {"bvh2", "bvh2_packed"}},
      {"sbvh", {}, {"bvh2"}},  // repeated references: a leaf's refitted box covers whole triangles
      {"wide_binned_sah", {{"arity", "4"}}, {"bvh4"}},
      {"wide_binned_sah", {{"arity", "8"}}, {"bvh8", "bvh8:isa=scalar"}},
  };
  for (const TreeCase& tree_case : trees) {
    const BuilderInfo& info = find_builder(tree_case.builder);
    const Bvh built = info.build(BuildInput::from_triangles(original),
                                 resolve_params(info.name, info.params, tree_case.overrides));
    for (const std::string& spec : tree_case.specs) {
      SCOPED_TRACE(tree_case.builder + " " + spec);
      auto refitted = compile_layout(spec, built, original);
      std::vector<std::vector<Triangle>> frames;  // bvh2 borrows each frame's triangles
      // A frame twice in a row (the timing repetitions), and a return to an earlier pose.
      for (float time : {1.5f, 1.5f, 0.25f, 1.5f}) {
        const auto& moved = frames.emplace_back(deformed(original, time));
        refitted->refit(moved);
        Bvh tree = built;
        refit(tree, moved);
        const auto fresh = compile_layout(spec, tree, moved);
        EXPECT_EQ(refitted->bytes(), fresh->bytes());

        const auto rays = test::random_rays(moved, 500, 7);
        std::vector<Hit> got(rays.size()), want(rays.size());
        std::vector<uint8_t> got_any(rays.size()), want_any(rays.size());
        refitted->trace_closest(rays, got);
        fresh->trace_closest(rays, want);
        refitted->trace_any(rays, got_any);
        fresh->trace_any(rays, want_any);
        std::size_t found = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
          found += want[i].found();
          ASSERT_EQ(got[i].prim, want[i].prim) << "t=" << time << " ray " << i;
          ASSERT_EQ(got[i].t, want[i].t) << "t=" << time << " ray " << i;
          ASSERT_EQ(got[i].u, want[i].u) << "t=" << time << " ray " << i;
          ASSERT_EQ(got[i].v, want[i].v) << "t=" << time << " ray " << i;
          ASSERT_EQ(got_any[i], want_any[i]) << "t=" << time << " ray " << i;
        }
        EXPECT_GT(found, rays.size() / 10) << "rays must hit for the check to mean anything";
        for (bool any : {false, true}) {
          const TraceCounts a = any ? refitted->count_any(rays) : refitted->count_closest(rays);
          const TraceCounts b = any ? fresh->count_any(rays) : fresh->count_closest(rays);
          EXPECT_EQ(a.nodes_visited, b.nodes_visited) << "t=" << time << (any ? " any" : " closest");
          EXPECT_EQ(a.prims_tested, b.prims_tested) << "t=" << time << (any ? " any" : " closest");
        }
      }
    }
  }
}

// A tree that is one leaf compiles to a wide root with a single leaf slot: its refit must move that slot
// and the root's box (the kernels test the root box first), or the moved triangles are missed.
TEST(Layouts, RefitMovesATreeThatIsOneLeaf) {
  const auto original = test::random_triangles(1, 9);
  const BuilderInfo& info = find_builder("binned_sah");
  const Bvh bvh =
      info.build(BuildInput::from_triangles(original), resolve_params(info.name, info.params, {}));
  ASSERT_TRUE(bvh.root().is_leaf());
  std::vector<Triangle> moved = original;
  for (Triangle& t : moved)
    t = {t.v0 + Vec3{40.0f, -25.0f, 7.0f}, t.v1 + Vec3{40.0f, -25.0f, 7.0f},
         t.v2 + Vec3{40.0f, -25.0f, 7.0f}};
  std::vector<std::string> specs{"bvh4", "bvh8", "bvh8:isa=scalar"};
  // A packet layout over a tree that is one leaf traces its rays one at a time, eight walks in turn.
  if (kernel_isa_available(KernelIsa::kAvx2)) {
    specs.push_back("bvh2:packet=8");
    specs.push_back("bvh2_packed:packet=8");
  }
  for (const std::string& spec : specs) {
    SCOPED_TRACE(spec);
    auto layout = compile_layout(spec, bvh, original);
    layout->refit(moved);
    const auto rays = test::random_rays(moved, 200, 3);
    std::vector<Hit> hits(rays.size());
    layout->trace_closest(rays, hits);
    std::size_t found = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const Hit ref = brute_force_closest(moved, rays[i]);
      found += ref.found();
      ASSERT_TRUE(test::same_closest_hit(hits[i], ref, moved, rays[i])) << "ray " << i;
    }
    EXPECT_GT(found, 0u) << "rays must hit the moved triangles for the check to mean anything";
  }
}

// Packets of one ray repeated, so that the wide packets' interval test of the whole packet
// (wide_packets.inl: packet_cull) computes exactly that ray's own slab test: rays from integer points
// through the vertices of a closed cube grid, in directions of components 3, 5 and 7, whose reciprocals
// are not floats, so that each corner of the flat leaf boxes at a vertex is met an ulp early or late on
// some axis. The robust box test enters those boxes by its scaled far distance; an interval test
// without that scale culls them, and the ray would leak through the vertex. (Bounds taken at the wrong
// extreme are no error here, the extremes being equal: LayoutVsReference's packets of distinct rays
// catch those.) Every packet spec is held to its own variant's single-ray answers: whether it hits and
// at which distance, the same for every variant, as identical lanes visit the nodes in the single-ray
// kernel's order; which of the triangles at the vertex it reports is left to the tie rules. The default
// variant must hit every ray through an inner vertex (a ray through a vertex on the cube's edge may
// leave it there).
TEST(Layouts, PacketsOfOneRayEnterTheBoxesItGrazesAtAVertex) {
  test::Skips skips;
  if (!skips.have_isa(KernelIsa::kAvx2)) GTEST_SKIP() << "no packet kernels on this CPU";
  const std::vector<Triangle> grid = test::cube_grid(8, 4.0f);  // vertices at integer points
  std::vector<Ray> rays;
  std::vector<bool> inner;  // through a vertex inside the top face, not on the cube's edge
  const float components[3] = {3.0f, 5.0f, 7.0f};
  for (int x = -4; x <= 4; ++x)
    for (int y = -4; y <= 4; ++y)
      for (int k = 0; k < 6; ++k) {
        // Into the cube through the vertex (x, y, 4) of its top face: z falls, x and y of either sign.
        const Vec3 vertex{static_cast<float>(x), static_cast<float>(y), 4.0f};
        const Vec3 dir{(k & 1 ? -1.0f : 1.0f) * components[k % 3],
                       (k & 2 ? -1.0f : 1.0f) * components[(k + 1) % 3], -components[(k + 2) % 3]};
        const float steps = static_cast<float>(1 + (x + y + 8) % 3);
        Ray ray;
        ray.org = vertex - dir * steps;
        ray.dir = dir;
        for (std::size_t copy = 0; copy < kMaxWidePacket; ++copy) {
          rays.push_back(ray);
          inner.push_back(std::abs(x) < 4 && std::abs(y) < 4);
        }
      }
  std::vector<std::string> packets{"packet=8"};
  if (skips.have_isa(KernelIsa::kAvx512)) packets.insert(packets.end(), {"packet=16", "packet=8,isa=avx2"});
  for (const char* name : {"bvh4", "bvh8"}) {
    const LayoutInfo& layout = find_layout(name);
    const BuilderInfo& builder = find_builder("wide_collapse");
    const Bvh bvh = builder.build(
        BuildInput::from_triangles(grid),
        resolve_params(builder.name, builder.params, {{"arity", std::to_string(layout.arity)}}));
    std::vector<std::string> variants{""};
    for (const char* tri : {"watertight", "mtn"})
      for (const char* box : {"robust", "fast", "fma"})
        variants.push_back(std::string("tri=") + tri + ",box=" + box);
    for (const std::string& variant : variants) {
      const auto alone = compile_layout(layout.name + (variant.empty() ? "" : ":" + variant), bvh, grid);
      std::vector<Hit> expected(rays.size());
      std::vector<uint8_t> expected_any(rays.size());
      alone->trace_closest(rays, expected);
      alone->trace_any(rays, expected_any);
      for (const std::string& packet : packets) {
        const std::string spec = layout.name + ":" + (variant.empty() ? "" : variant + ",") + packet;
        SCOPED_TRACE(spec);
        const auto compiled = compile_layout(spec, bvh, grid);
        std::vector<Hit> hits(rays.size());
        std::vector<uint8_t> occluded(rays.size());
        compiled->trace_closest(rays, hits);
        compiled->trace_any(rays, occluded);
        for (std::size_t i = 0; i < rays.size(); ++i) {
          ASSERT_EQ(occluded[i], expected_any[i]) << "ray " << i;
          ASSERT_EQ(hits[i].found(), expected[i].found()) << "ray " << i;
          if (hits[i].found()) {
            ASSERT_EQ(hits[i].t, expected[i].t) << "ray " << i;
          }
          if (variant.empty() && inner[i]) {
            ASSERT_TRUE(hits[i].found()) << "ray " << i << " leaked through its vertex";
          }
        }
      }
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

// The shadow cache (wide_kernels.inl: ShadowCache) changes how an any-hit answer is found, not the answer
// (with the robust box test; a non-robust one may cull a leaf whose triangle the cache then finds): on
// rays to one, two, four and nine points (more than it has slots: it gives up), rays to points that change
// within a batch, rays without an end (tmax infinite), with and without rays axis-parallel to a light
// (box=fma traces a batch holding one without the cache), every answer is the walk's alone and, for the
// default variant, brute force's; for the single-ray kernels and the packets (a packet settled whole by its
// rays' leaves, or walking and filling the slots; the rays of a packet that cannot go down together each
// through the cache), each compared with its own kind with the cache off.
TEST(Layouts, ShadowCacheAnswersAsTheWalkAlone) {
  test::Skips skips;
  const std::string best(to_string(best_kernel_isa()));
  const BuilderInfo& builder = find_builder("wide_collapse");
  for (const auto& [name, triangles] :
       {std::pair<std::string, std::vector<Triangle>>{"cube_grid", test::cube_grid(12, 2.0f)},
        {"random2000", test::random_triangles(2000, 41)}}) {
    SCOPED_TRACE(name);
    std::vector<Ray> rays;
    for (const bool level : {true, false})
      for (std::size_t lights : {1, 4, 9, 4})
        for (const Ray& r : test::shadow_rays(triangles, 700, 50 + lights, lights, level)) rays.push_back(r);
    // Rays to other points and rays without an end in the middle of a batch, then shadow rays again.
    std::vector<Ray> others = test::random_rays(triangles, 300, 51);
    for (std::size_t i = 0; i < others.size(); i += 3)
      others[i].tmax = std::numeric_limits<float>::infinity();
    rays.insert(rays.begin() + 1000, others.begin(), others.end());
    for (const Ray& r : test::shadow_rays(triangles, 300, 52, 2, false)) rays.push_back(r);
    std::vector<uint8_t> reference(rays.size());
    for (std::size_t i = 0; i < rays.size(); ++i) reference[i] = brute_force_any(triangles, rays[i]);
    const auto blocked = std::count(reference.begin(), reference.end(), 1);
    ASSERT_GT(blocked, 1000);
    ASSERT_LT(blocked, static_cast<long>(rays.size()) - 1000);

    for (const std::string arity : {"4", "8"}) {
      const Bvh bvh = builder.build(BuildInput::from_triangles(triangles),
                                    resolve_params("wide_collapse", builder.params, {{"arity", arity}}));
      std::vector<std::string> isas{"scalar", best};
      if (best == "avx2" || best == "avx512") isas.push_back(best + ",packet=8");
      if (best == "avx512") isas.push_back("avx512,packet=16");
      for (const std::string variant : {"", "tri=mtn,box=fma,", "tri=mt0,box=fast,anyhit=nearest,"})
        for (const std::string& isa : isas) {
          const std::string spec = "bvh" + arity + ":" + variant + "isa=" + isa;
          SCOPED_TRACE(spec);
          const LayoutSpec on = parse_layout_spec(spec), off = parse_layout_spec(spec + ",shadow_cache=off");
          ASSERT_TRUE(on.shadow_cache);
          ASSERT_FALSE(off.shadow_cache);
          std::vector<uint8_t> cached(rays.size()), walked(rays.size());
          compile_layout(on, bvh, triangles)->trace_any(rays, cached);
          compile_layout(off, bvh, triangles)->trace_any(rays, walked);
          with_test_types(on.variant, [&]<class Tri, class Box>() {
            for (std::size_t i = 0; i < rays.size(); ++i) {
              if (cached[i] && !walked[i] && on.variant.box != BoxTestKind::kRobust) {
                ASSERT_TRUE(test_hits_any<Tri>(triangles, rays[i])) << "ray " << i;
                continue;
              }
              ASSERT_EQ(cached[i], walked[i]) << "ray " << i;
              if (variant.empty()) {
                ASSERT_EQ(cached[i], reference[i]) << "ray " << i;
              }
            }
          });
        }
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

// The kernels' shadow cache settles rays, so the test above compares two ways of answering: a good share of
// shadow rays to four points, by the leaf and by its subtree (the walks behind them must have filled the
// slots), and none of the rays that end each at a point of its own (AO-like: the batch never runs the cache)
// or have no finite end. For the single-ray kernel and, where this machine runs them, the packets (whose
// walks fill the slots for the next packets).
TEST(Layouts, ShadowCacheSettlesShadowRaysAndNoOthers) {
  const auto triangles = test::cube_grid(12, 2.0f);
  const BuilderInfo& builder = find_builder("wide_collapse");
  const Bvh bvh = builder.build(BuildInput::from_triangles(triangles),
                                resolve_params("wide_collapse", builder.params, {{"arity", "8"}}));
  const WideBvh<8> wide = compile_wide<8>(bvh, triangles, block_form_for(KernelVariant{}.triangle));
  std::vector<std::pair<std::string, WideKernel>> kernels{
      {"scalar", find_wide_kernel(KernelIsa::kScalar, 8, KernelVariant{}, true, false)}};
  const KernelIsa best = best_kernel_isa();
  if (best == KernelIsa::kAvx2 || best == KernelIsa::kAvx512)
    kernels.emplace_back("packet=8", find_wide_packet_kernel(best, 8, KernelVariant{}, true, 8));
  if (best == KernelIsa::kAvx512)
    kernels.emplace_back("packet=16", find_wide_packet_kernel(best, 8, KernelVariant{}, true, 16));
  for (const auto& [name, kernel] : kernels) {
    SCOPED_TRACE(name);
    ASSERT_NE(kernel, nullptr);
    auto settled_by_cache = [&](const std::vector<Ray>& rays) {
      std::array<std::size_t, 2> settled{};  // by the leaf, by its subtree
      std::vector<WideRay> setup(rays.size());
      std::vector<uint8_t> occluded(rays.size(), 2);  // neither answer: a ray left unanswered fails
      for (std::size_t first = 0; first < rays.size(); first += 256) {
        const std::size_t n = std::min<std::size_t>(256, rays.size() - first);
        const WideRaysInfo info =
            make_wide_rays(std::span(rays).subspan(first, n), setup.data(), true, BoxTestKind::kRobust);
        kernel(WideBatch{wide.root_planes, wide.arena.data(), setup.data(), n, nullptr,
                         occluded.data() + first, nullptr, resolve_any_hit_order(bvh), info.int_order,
                         info.robust_box, true, settled.data()});
      }
      for (std::size_t i = 0; i < rays.size(); ++i)
        EXPECT_EQ(occluded[i], brute_force_any(triangles, rays[i])) << "ray " << i;
      return settled;
    };
    // From the cube's faces to four points in and around it: the rays towards a point behind another face
    // are blocked, those of neighbouring origins mostly by the same quad or its neighbours.
    const std::vector<Ray> shadow = test::shadow_rays(triangles, 2048, 60, 4, false);
    const auto blocked = static_cast<std::size_t>(std::count_if(
        shadow.begin(), shadow.end(), [&](const Ray& r) { return brute_force_any(triangles, r); }));
    ASSERT_GT(blocked, shadow.size() / 4);
    const auto settled = settled_by_cache(shadow);
    // 265 of the 1221 blocked rays with the standard library's generators on Debian 12.
    EXPECT_GT(settled[0] + settled[1], blocked / 8) << "of " << blocked << " blocked";
    EXPECT_GT(settled[0], 0u);
    EXPECT_GT(settled[1], 0u);
    // Rays from a patch of neighbouring points below the cube to one point beyond its far corner, in
    // rows: every packet goes down together (all directions positive), and its rays are blocked by one or
    // two quads of the bottom face, so the leaf that blocked one packet settles the next whole (not where
    // a packet's rays straddle two leaves: 16-ray packets settled 1264 of the 2048 rays).
    std::vector<Ray> patch(2048);
    for (std::size_t i = 0; i < patch.size(); ++i) {
      patch[i].org = {-1.5f + 0.002f * static_cast<float>(i % 64), -3.0f,
                      -1.5f + 0.002f * static_cast<float>(i / 64)};
      patch[i].dir = Vec3{3.0f, 3.0f, 3.0f} - patch[i].org;
      patch[i].tmax = 1.0f - 1e-4f;
    }
    const auto from_patch = settled_by_cache(patch);
    EXPECT_GT(from_patch[0], patch.size() / 2);
    // The same with every eighth ray from a point off to the side, whose ray passes by the cube in the
    // same octant: every packet goes down together, its first seven rays are blocked where the packet
    // before them was, and its eighth is not. A packet is settled only where all its rays are blocked: one
    // that marked the passing ray would fail brute force above.
    std::vector<Ray> mixed = patch;
    for (std::size_t i = 7; i < mixed.size(); i += 8) {
      mixed[i].org = {-9.0f, -3.0f, 2.9f};
      mixed[i].dir = Vec3{3.0f, 3.0f, 3.0f} - mixed[i].org;
    }
    const auto mixed_blocked = static_cast<std::size_t>(std::count_if(
        mixed.begin(), mixed.end(), [&](const Ray& r) { return brute_force_any(triangles, r); }));
    ASSERT_EQ(mixed_blocked, mixed.size() / 8 * 7);
    settled_by_cache(mixed);
    // Random rays, each ending at a point of its own, and the same without an end.
    std::vector<Ray> own_ends = test::random_rays(triangles, 2048, 61);
    for (Ray& r : own_ends) r.tmax = std::min(r.tmax, 3.0f);
    const auto own = settled_by_cache(own_ends);
    EXPECT_EQ(own[0] + own[1], 0u);
    std::vector<Ray> unbounded = own_ends;
    for (Ray& r : unbounded) r.tmax = std::numeric_limits<float>::infinity();
    const auto none = settled_by_cache(unbounded);
    EXPECT_EQ(none[0] + none[1], 0u);
  }
}

TEST(Layouts, RefitRejectsADifferentTriangleCount) {
  const auto tris = test::random_triangles(100, 2);
  const Bvh binary = find_builder("binned_sah")
                         .build(BuildInput::from_triangles(tris),
                                resolve_params("binned_sah", find_builder("binned_sah").params, {}));
  for (const char* spec : {"bvh2", "bvh2_packed", "bvh8"})  // a binary tree in 8-wide nodes is legal
    EXPECT_THROW(compile_layout(spec, binary, tris)->refit(std::span(tris).first(50)), Error) << spec;
}

TEST(Layouts, EmptyTreeMissesEverything) {
  const std::vector<Triangle> none;
  const auto rays = test::random_rays(test::random_triangles(10, 1), 50, 2);
  for (const LayoutInfo& layout : layouts()) {
    std::vector<std::string> specs{layout.name};
    if (layout.has_packet && kernel_isa_available(KernelIsa::kAvx2))
      specs.push_back(layout.name + ":packet=8");
    for (const std::string& spec : specs) {
      const Bvh empty{{}, {}, layout.arity};  // bvh2 borrows the tree: it must outlive the layout
      const auto compiled = compile_layout(spec, empty, none);
      std::vector<Hit> hits(rays.size(), Hit{7, 1.0f, 0, 0});
      std::vector<uint8_t> occluded(rays.size(), 1);
      compiled->trace_closest(rays, hits);
      compiled->trace_any(rays, occluded);
      for (std::size_t i = 0; i < rays.size(); ++i) {
        EXPECT_FALSE(hits[i].found()) << spec;
        EXPECT_EQ(occluded[i], 0) << spec;
      }
    }
  }
}

// A direction so short that t overflows: 5 / 1e-40 is no float, so no kernel, variant, ISA or reference
// may report the crossing (before, every one answered t = inf within tmax = inf). The same ray with a
// direction of 1e-10 has its hit at t = 5e10, which all must find.
TEST(Layouts, NoHitAtAnInfiniteT) {
  test::Skips skips;
  const std::vector<Triangle> tris = {{{-1, -1, 0}, {3, -1, 0}, {-1, 3, 0}},
                                      {{5, 5, 1}, {6, 5, 1}, {5, 6, 1}}};
  Ray overflow;
  overflow.org = {0.2f, 0.2f, 5.0f};
  overflow.dir = {0.0f, 0.0f, -1e-40f};
  Ray far = overflow;
  far.dir.z = -1e-10f;
  const std::vector<Ray> rays = {overflow, far};
  EXPECT_FALSE(brute_force_closest(tris, overflow).found());
  EXPECT_FALSE(brute_force_any(tris, overflow));
  ASSERT_TRUE(brute_force_closest(tris, far).found());
  EXPECT_FLOAT_EQ(brute_force_closest(tris, far).t, 5e10f);
  for (const LayoutInfo& layout : layouts()) {
    const auto [builder_name, overrides] = builders_for(layout.arity).front();
    const BuilderInfo& builder = find_builder(builder_name);
    const Bvh bvh = builder.build(BuildInput::from_triangles(tris),
                                  resolve_params(builder.name, builder.params, overrides));
    for (const std::string& spec : specs_for(layout, skips)) {
      SCOPED_TRACE(spec);
      const auto compiled = compile_layout(spec, bvh, tris);
      std::vector<Hit> hits(rays.size());
      std::vector<uint8_t> occluded(rays.size(), 1);
      compiled->trace_closest(rays, hits);
      compiled->trace_any(rays, occluded);
      EXPECT_FALSE(hits[0].found()) << "t = " << hits[0].t;
      EXPECT_EQ(occluded[0], 0);
      // tri=mt's epsilon on the determinant is absolute, so it scales with the direction's length and
      // refuses the 1e-10 one as parallel: its documented miss, not this test's subject.
      if (spec.find("tri=mt,") != std::string::npos) continue;
      EXPECT_TRUE(hits[1].found());
      EXPECT_EQ(occluded[1], 1);
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

TEST(Layouts, SpecsParseToCanonicalTextAndRejectBadOptionsByName) {
  EXPECT_EQ(parse_layout_spec("bvh2").text(), "bvh2");
  EXPECT_EQ(parse_layout_spec("bvh2:tri=watertight,box=robust").text(), "bvh2");
  EXPECT_EQ(parse_layout_spec("bvh8:box=fast,tri=mt0").text(), "bvh8:tri=mt0,box=fast");
  EXPECT_EQ(parse_layout_spec("bvh8:anyhit=nearest,box=fast").text(), "bvh8:box=fast,anyhit=nearest");
  EXPECT_EQ(parse_layout_spec("bvh2:anyhit=auto").text(), "bvh2");
  EXPECT_EQ(parse_layout_spec("bvh2_packed:anyhit=stored").variant.any_hit, AnyHitOrder::kStored);
  EXPECT_EQ(parse_layout_spec("bvh4:isa=scalar").isa, KernelIsa::kScalar);
  EXPECT_EQ(parse_layout_spec("bvh8:packet=8,isa=avx2").text(), "bvh8:isa=avx2,packet=8");
  EXPECT_EQ(parse_layout_spec("bvh8:packet=1").text(), "bvh8");
  auto error_of = [](const std::string& text) {
    try {
      parse_layout_spec(text);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("bvh9").find("unknown layout 'bvh9'"), std::string::npos);
  EXPECT_NE(
      error_of("bvh8:anyhit=first")
          .find("anyhit = 'first' is not one of auto, nearest, stored, nearest_stored, farthest_stored"),
      std::string::npos);
  EXPECT_NE(error_of("bvh2:tri=exact").find("tri = 'exact' is not one of watertight, mt, mt0, mtn"),
            std::string::npos);
  // The binary layouts take packets, and isa only with them: it picks the packet kernels' build.
  EXPECT_EQ(parse_layout_spec("bvh2_packed:packet=16,tri=mt").text(), "bvh2_packed:tri=mt,packet=16");
  EXPECT_EQ(parse_layout_spec("bvh2:isa=avx2,packet=8").text(), "bvh2:isa=avx2,packet=8");
  EXPECT_EQ(parse_layout_spec("bvh2_packed:packet=8,isa=avx2").isa, KernelIsa::kAvx2);
  for (const char* spec : {"bvh2:isa=avx2", "bvh2_packed:isa=scalar", "bvh2:isa=avx512,packet=1"})
    EXPECT_NE(error_of(spec).find("isa picks the build of bvh2"), std::string::npos) << spec;
  EXPECT_NE(error_of("bvh2_packed:isa=avx2,packet=16").find("no avx2 kernels for packet=16"),
            std::string::npos);
  EXPECT_NE(error_of("bvh2:isa=sse,packet=8").find("no sse kernels for packet=8"), std::string::npos);
  EXPECT_NE(error_of("bvh2_packed:packet=4").find("packet = '4' is not one of 1, 8, 16"), std::string::npos);
  EXPECT_NE(error_of("bvh2:packet").find("(keys: tri, box, anyhit, isa, packet)"), std::string::npos);
  EXPECT_NE(error_of("bvh8:isa=neon").find("isa = 'neon'"), std::string::npos);
  EXPECT_NE(error_of("bvh8:packet=4").find("packet = '4' is not one of 1, 8, 16"), std::string::npos);
  EXPECT_EQ(parse_layout_spec("bvh2:packet=8").packet, 8u);
  // The shadow cache: on by default, off by name, for the wide layouts' kernels only (packets too).
  EXPECT_EQ(parse_layout_spec("bvh8:shadow_cache=on").text(), "bvh8");
  EXPECT_EQ(parse_layout_spec("bvh4:shadow_cache=off,tri=mt").text(), "bvh4:tri=mt,shadow_cache=off");
  EXPECT_EQ(parse_layout_spec("bvh8:shadow_cache=off,packet=8").text(), "bvh8:packet=8,shadow_cache=off");
  EXPECT_NE(error_of("bvh8:shadow_cache=no").find("shadow_cache = 'no' is not on or off"), std::string::npos);
  EXPECT_NE(error_of("bvh2:shadow_cache=off").find("unknown option 'shadow_cache'"), std::string::npos);
  EXPECT_NE(error_of("bvh2_packed:packet=8,shadow_cache=off").find("unknown option 'shadow_cache'"),
            std::string::npos);
  EXPECT_NE(error_of("bvh8:packet").find("(keys: tri, box, anyhit, isa, packet, shadow_cache)"),
            std::string::npos);
  EXPECT_NE(error_of("bvh8:box").find("'box' is not of the form key=value"), std::string::npos);
  EXPECT_NE(error_of("bvh8:box=fast,box=robust").find("'box' is given twice"), std::string::npos);
}

TEST(Layouts, WideLayoutsRejectWiderTreesAndReportTheirIsa) {
  const auto tris = test::random_triangles(500, 9);
  const BuilderInfo& info = find_builder("wide_binned_sah");
  const Bvh wide8 = info.build(BuildInput::from_triangles(tris), resolve_params(info.name, info.params, {}));
  // Every layout narrower than the tree refuses it, naming itself and both arities.
  for (const char* spec : {"bvh4", "bvh2", "bvh2_packed", "bvh2:anyhit=stored", "bvh2_packed:tri=mt"}) {
    try {
      compile_layout(spec, wide8, tris);
      ADD_FAILURE() << spec << " compiled an 8-wide tree";
    } catch (const Error& e) {
      const std::string text = e.what();
      EXPECT_NE(text.find(std::string("layout '") + spec + "' takes trees of arity"), std::string::npos)
          << text;
      EXPECT_NE(text.find("the builder gave arity 8"), std::string::npos) << text;
    }
  }
  const auto compiled = compile_layout("bvh8", wide8, tris);
  EXPECT_EQ(compiled->isa(), std::string(to_string(preferred_kernel_isa())));
  EXPECT_EQ(compile_layout("bvh8:isa=scalar", wide8, tris)->isa(), "scalar");
  EXPECT_GT(compiled->bytes(), 0u);
  // Packets have AVX2 and AVX-512 kernels only, 16-ray packets AVX-512 ones: other pairs are refused
  // where the spec is read, on any CPU.
  for (const char* spec : {"bvh8:isa=scalar,packet=8", "bvh8:packet=8,isa=sse", "bvh4:isa=avx2,packet=16"}) {
    try {
      parse_layout_spec(spec);
      ADD_FAILURE() << spec << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("layout '") + spec + "': no "), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("(packet=8: isa avx2 or avx512; packet=16: isa avx512)"),
                std::string::npos)
          << e.what();
    }
  }
}

// A layout the CPU cannot run is named with the reason, so that a run can skip it (as Embree's packets
// that the CPU lacks): AVX-512 layouts and 16-ray packets where AVX-512 is missing.
TEST(Layouts, UnavailableLayoutsSayWhy) {
  EXPECT_EQ(layout_unavailable(parse_layout_spec("bvh2")), std::nullopt);
  EXPECT_EQ(layout_unavailable(parse_layout_spec("bvh8:isa=scalar")), std::nullopt);
  EXPECT_EQ(layout_unavailable(parse_layout_spec("bvh8")), std::nullopt);
  // As a CPU without AVX-512 (or without AVX2) would answer, on any CPU.
  const auto capped = [](const char* spec, KernelIsa widest) {
    return layout_unavailable(parse_layout_spec(spec), widest).value_or("");
  };
  EXPECT_EQ(capped("bvh8", KernelIsa::kAvx2), "");
  EXPECT_EQ(capped("bvh8:isa=scalar", KernelIsa::kScalar), "");
  EXPECT_NE(capped("bvh8:packet=16", KernelIsa::kAvx2).find("16-ray packets need AVX-512"),
            std::string::npos);
  EXPECT_NE(capped("bvh4:isa=avx512", KernelIsa::kAvx2).find("isa avx512 is not available"),
            std::string::npos);
  EXPECT_NE(capped("bvh8:packet=8", KernelIsa::kSse).find("8-ray packets need AVX2 or AVX-512"),
            std::string::npos);
  EXPECT_NE(capped("bvh2_packed:packet=16", KernelIsa::kAvx2).find("16-ray packets need AVX-512"),
            std::string::npos);
  EXPECT_NE(capped("bvh2_packed:packet=8", KernelIsa::kSse).find("8-ray packets need AVX2 or AVX-512"),
            std::string::npos);
  EXPECT_EQ(capped("bvh2_packed", KernelIsa::kScalar), "");
  if (kernel_isa_available(KernelIsa::kAvx2)) {
    EXPECT_EQ(capped("bvh8:packet=8", KernelIsa::kAvx2), "");
    // The reason names what isa=auto takes under the cap: the widest the capped CPU has, on any vendor.
    EXPECT_NE(capped("bvh8:packet=16", KernelIsa::kAvx2).find("(auto would pick avx2)"), std::string::npos);
  }
  // isa=auto is the widest instruction set available, whoever made the CPU.
  KernelIsa widest = KernelIsa::kScalar;
  for (KernelIsa isa : {KernelIsa::kSse, KernelIsa::kAvx2, KernelIsa::kAvx512})
    if (kernel_isa_available(isa)) widest = isa;
  EXPECT_EQ(preferred_kernel_isa(), widest);
  // Only packets and instruction sets above scalar depend on the CPU.
  EXPECT_FALSE(layout_depends_on_cpu(parse_layout_spec("bvh2")));
  EXPECT_FALSE(layout_depends_on_cpu(parse_layout_spec("bvh8")));
  EXPECT_FALSE(layout_depends_on_cpu(parse_layout_spec("bvh8:isa=scalar")));
  EXPECT_TRUE(layout_depends_on_cpu(parse_layout_spec("bvh8:packet=8")));
  EXPECT_TRUE(layout_depends_on_cpu(parse_layout_spec("bvh2_packed:packet=8")));
  EXPECT_FALSE(layout_depends_on_cpu(parse_layout_spec("bvh2_packed")));
  EXPECT_TRUE(layout_depends_on_cpu(parse_layout_spec("bvh4:isa=sse")));
  const auto packets16 = layout_unavailable(parse_layout_spec("bvh8:packet=16"));
  const auto avx512 = layout_unavailable(parse_layout_spec("bvh4:isa=avx512"));
  if (kernel_isa_available(KernelIsa::kAvx512)) {
    EXPECT_EQ(packets16, std::nullopt);
    EXPECT_EQ(avx512, std::nullopt);
  } else {
    ASSERT_TRUE(packets16.has_value());
    EXPECT_NE(packets16->find("16-ray packets need AVX-512"), std::string::npos) << *packets16;
    ASSERT_TRUE(avx512.has_value());
    EXPECT_NE(avx512->find("isa avx512 is not available on this CPU or build"), std::string::npos) << *avx512;
    const auto tris = test::random_triangles(100, 3);
    const BuilderInfo& info = find_builder("wide_binned_sah");
    const Bvh wide8 =
        info.build(BuildInput::from_triangles(tris), resolve_params(info.name, info.params, {}));
    EXPECT_THROW(compile_layout("bvh8:packet=16", wide8, tris), Error);
  }
}

// Rays no kernel can trace (a NaN or infinite origin or direction, a NaN tmin or tmax) and degenerate
// ones (a zero direction, an empty or reversed interval, -0 components) among good rays: one in each
// packet of eight of random rays (every octant) and of coherent ones (one octant), a packet of sixteen
// with one good ray, and a last packet of 7 rays. Every layout, one ray at a time and in packets of both
// widths and ISAs, writes an answer for each ray, the one brute force gives (the default variant) or its
// own single-ray layout (tri=mtn,box=fma, whose box test leaves some rays to the single-ray kernel; up to
// another hit within 1e-5 where a packet's order of leaves meets it first, as in LayoutVsReference): a
// packet neither takes up a ray it cannot trace nor loses the others because of it.
TEST(Layouts, PacketsWithUntraceableRaysAnswerEachRayAsAlone) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  const auto tris = test::random_triangles(600, 31);
  std::vector<Ray> rays = test::random_rays(tris, 20 * kMaxWidePacket, 32);
  for (const Ray& r : test::coherent_rays(tris, 4 * kMaxWidePacket, 33, kMaxWidePacket)) rays.push_back(r);
  const std::size_t lone = rays.size();  // the packet of sixteen with one good ray
  for (const Ray& r : test::random_rays(tris, kMaxWidePacket, 34)) rays.push_back(r);
  for (const Ray& r : test::coherent_rays(tris, 7, 35, 7)) rays.push_back(r);
  const std::vector<Ray> odd{Ray{{nan, 0, 0}, 0.0f, {1, 0, 0}},       Ray{{0, 0, 0}, 0.0f, {nan, 1, 0}},
                             Ray{{0, inf, 0}, 0.0f, {0, 0, 1}},       Ray{{0, 0, 0}, 0.0f, {-inf, 1, 1}},
                             Ray{{0, 0, 0}, nan, {1, 1, 1}},          Ray{{0, 0, 0}, 0.0f, {1, -1, 1}, nan},
                             Ray{{0, 0, 0}, 0.0f, {0, 0, 0}},         Ray{{0, 0, 0}, 5.0f, {1, 1, -1}, 1.0f},
                             Ray{{0, 0, 0}, 0.0f, {-0.0f, 1, -0.0f}}, Ray{{0, 0, 0}, 2.0f, {1, 0, 0}, 2.0f}};
  std::size_t next = 0;
  auto make_odd = [&](Ray& r) {  // keeps the good ray's origin where the odd one's is finite
    const Ray& o = odd[next++ % odd.size()];
    r = Ray{std::isfinite(o.org.x) && std::isfinite(o.org.y) && std::isfinite(o.org.z) ? r.org : o.org,
            o.tmin, o.dir, o.tmax};
  };
  for (std::size_t p = 0; p < lone / 8; ++p) make_odd(rays[p * 8 + (p * 3) % 8]);
  for (std::size_t i = lone + 1; i < lone + kMaxWidePacket; ++i) make_odd(rays[i]);
  make_odd(rays[rays.size() - 3]);

  const Bvh binary = find_builder("binned_sah")
                         .build(BuildInput::from_triangles(tris),
                                resolve_params("binned_sah", find_builder("binned_sah").params, {}));
  test::Skips skips;
  for (const LayoutInfo& layout : layouts()) {
    const Bvh bvh = layout.arity == 2
                        ? binary
                        : find_builder("wide_collapse")
                              .build(BuildInput::from_triangles(tris),
                                     resolve_params("wide_collapse", find_builder("wide_collapse").params,
                                                    {{"arity", std::to_string(layout.arity)}}));
    std::vector<std::string> packets;
    if (layout.has_packet && skips.have_isa(KernelIsa::kAvx2)) packets.push_back(",packet=8,isa=avx2");
    if (layout.has_packet && skips.have_isa(KernelIsa::kAvx512))
      packets.insert(packets.end(), {",packet=8,isa=avx512", ",packet=16"});
    for (const std::string variant : {"tri=watertight", "tri=mtn,box=fma"}) {
      const bool exact = variant == "tri=watertight";
      const std::string alone = layout.name + ":" + variant;
      std::vector<Hit> expected(rays.size());
      std::vector<uint8_t> expected_any(rays.size());
      if (exact) {
        for (std::size_t i = 0; i < rays.size(); ++i) {
          expected[i] = brute_force_closest(tris, rays[i]);
          expected_any[i] = brute_force_any(tris, rays[i]);
        }
      } else {
        const auto single = compile_layout(alone, bvh, tris);
        single->trace_closest(rays, expected);
        single->trace_any(rays, expected_any);
      }
      std::vector<std::string> specs{alone};
      for (const std::string& packet : packets) specs.push_back(alone + packet);
      for (const std::string& spec : specs) {
        SCOPED_TRACE(spec);
        const auto compiled = compile_layout(spec, bvh, tris);
        std::vector<Hit> hits(rays.size(), Hit{7, 1.0f, 0.5f, 0.5f});  // an answer no ray here gets
        std::vector<uint8_t> occluded(rays.size(), 2);
        compiled->trace_closest(rays, hits);
        compiled->trace_any(rays, occluded);
        for (std::size_t i = 0; i < rays.size(); ++i) {
          ASSERT_EQ(occluded[i], expected_any[i]) << "ray " << i;
          ASSERT_EQ(hits[i].found(), expected[i].found()) << "ray " << i;
          if (!expected[i].found()) continue;
          if (!exact && hits[i].prim != expected[i].prim) {
            ASSERT_LE(std::fabs(hits[i].t - expected[i].t), 1e-5f * std::fabs(expected[i].t)) << "ray " << i;
            continue;
          }
          ASSERT_EQ(hits[i].prim, expected[i].prim) << "ray " << i;
          ASSERT_EQ(hits[i].t, expected[i].t) << "ray " << i;
        }
      }
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

// The CSV's isa column: the binary layouts' single-ray kernels are scalar code, their packet kernels run
// with the instruction set isa=auto picks, or the one `isa` names.
TEST(Layouts, BinaryLayoutsNameTheInstructionSetOfTheirKernels) {
  const auto tris = test::random_triangles(200, 4);
  const BuilderInfo& info = find_builder("binned_sah");
  const Bvh bvh = info.build(BuildInput::from_triangles(tris), resolve_params(info.name, info.params, {}));
  test::Skips skips;
  for (const std::string name : {"bvh2", "bvh2_packed"}) {
    EXPECT_EQ(compile_layout(name, bvh, tris)->isa(), "scalar");
    if (skips.have_isa(KernelIsa::kAvx2)) {
      EXPECT_EQ(compile_layout(name + ":packet=8", bvh, tris)->isa(),
                to_string(layout_kernel_isa(parse_layout_spec(name + ":packet=8"))));
      EXPECT_EQ(compile_layout(name + ":packet=8,isa=avx2", bvh, tris)->isa(), "avx2");
    }
    if (skips.have_isa(KernelIsa::kAvx512)) {
      EXPECT_EQ(compile_layout(name + ":packet=16", bvh, tris)->isa(), "avx512");
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

// On a binary tree the wide kernels take the binary kernel's path: the same nodes in the same order
// (nearest first, ties to the higher slot), so the same counts, for every box and triangle test. A
// change to the order of one kernel (descend()'s shortcuts) and not the other fails here.
TEST(Layouts, WideKernelsVisitTheBinaryKernelsNodesOnABinaryTree) {
  const auto tris = test::random_triangles(3000, 21);
  const BuilderInfo& info = find_builder("binned_sah");
  const Bvh binary = info.build(BuildInput::from_triangles(tris), resolve_params(info.name, info.params, {}));
  auto rays = test::random_rays(tris, 2000, 5);
  for (std::size_t i = 0; i < rays.size(); i += 7) rays[i].dir[i % 3] = -0.0f;  // ties between boxes
  for (const char* variant :
       {"tri=watertight,box=robust", "tri=mt0,box=fma", "tri=mt,box=fast", "tri=mtn,box=fma"}) {
    SCOPED_TRACE(variant);
    const auto reference = compile_layout(std::string("bvh2:") + variant, binary, tris);
    const TraceCounts closest = reference->count_closest(rays), any = reference->count_any(rays);
    ASSERT_GT(closest.nodes_visited, 2 * rays.size());
    for (const char* width : {"bvh4:", "bvh8:"}) {
      SCOPED_TRACE(width);
      const auto wide = compile_layout(std::string(width) + variant + ",anyhit=nearest", binary, tris);
      const TraceCounts c = wide->count_closest(rays), a = wide->count_any(rays);
      EXPECT_EQ(c.nodes_visited, closest.nodes_visited);
      EXPECT_EQ(c.prims_tested, closest.prims_tested);
      EXPECT_EQ(a.nodes_visited, any.nodes_visited);
      EXPECT_EQ(a.prims_tested, any.prims_tested);
    }
  }
}

// bvh2_packed's closest hit takes first, of two children that a ray starts inside (both entered at
// tmin), the one it leaves first, whichever slot holds it; bvh2's the later slot. Here the root's
// children are a leaf around the origin holding the hit at t = 0.5 and an inner node reaching to x = 10,
// whose two leaves (x in [5, 6] and [7, 8]) are then entered beyond the hit and never tested by
// bvh2_packed, nor by the general loop in that order: one triangle with the leaf in either slot. bvh2
// tests two with the leaf in the first slot (the near far leaf's, then the leaf's).
TEST(Layouts, PackedClosestHitTakesTheChildLeftFirstAmongThoseEnteredTogether) {
  const std::vector<Triangle> tris = {{{0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, -0.5f}, {0.5f, 0.0f, 0.5f}},
                                      {{5.5f, -0.5f, -0.5f}, {5.5f, 0.5f, -0.5f}, {5.5f, 0.0f, 0.5f}},
                                      {{7.5f, -0.5f, -0.5f}, {7.5f, 0.5f, -0.5f}, {7.5f, 0.0f, 0.5f}}};
  // The second ray, axis-parallel, is outside box=fma's domain and takes the robust test.
  const std::vector<Ray> rays = {Ray{{0, 0, 0}, 0.0f, {1.0f, 0.01f, 0.02f}},
                                 Ray{{0, 0, 0}, 0.0f, {1.0f, 0.0f, 0.0f}}};
  for (const bool leaf_first : {true, false}) {
    SCOPED_TRACE(leaf_first ? "the leaf in the first slot" : "the leaf in the second slot");
    Bvh bvh;
    bvh.nodes.push_back({Aabb{{-1, -1, -1}, {10, 1, 1}}, 1, 2, 0});
    const Node leaf{Aabb{{-1, -1, -1}, {1, 1, 1}}, 0, 0, 1}, inner{Aabb{{-1, -1, -1}, {10, 1, 1}}, 3, 2, 0};
    bvh.nodes.push_back(leaf_first ? leaf : inner);
    bvh.nodes.push_back(leaf_first ? inner : leaf);
    bvh.nodes.push_back({Aabb{{5, -1, -1}, {6, 1, 1}}, 1, 0, 1});
    bvh.nodes.push_back({Aabb{{7, -1, -1}, {8, 1, 1}}, 2, 0, 1});
    bvh.prim_refs = {0, 1, 2};
    ASSERT_TRUE(validate(bvh, std::span<const Triangle>(tris)).ok());
    for (std::size_t i = 0; i < rays.size(); ++i) {
      SCOPED_TRACE("ray " + std::to_string(i));
      for (const detail::ClosestTies ties :
           {detail::ClosestTies::kExitFirst, detail::ClosestTies::kLaterSlot}) {
        TraversalCounters general;
        const Hit hit =
            detail::traverse<WatertightTriangleTest, RobustRayBox, false, true, /*kBinaryLoop=*/false>(
                bvh, tris, rays[i], &general, AnyHitOrder::kAuto, ties);
        EXPECT_EQ(hit.prim, 0u);
        const bool exit_first = ties == detail::ClosestTies::kExitFirst;
        EXPECT_EQ(general.prim_tests, exit_first || !leaf_first ? 1u : 2u) << "the general loop";
      }
      for (const char* name : {"bvh2_packed", "bvh2_packed:tri=mt,box=fast", "bvh2_packed:tri=mtn,box=fma",
                               "bvh2", "bvh2:tri=mtn,box=fma"}) {
        SCOPED_TRACE(name);
        const auto layout = compile_layout(name, bvh, tris);
        const std::span<const Ray> one(&rays[i], 1);
        std::vector<Hit> hits(1);
        layout->trace_closest(one, hits);
        EXPECT_EQ(hits[0].prim, 0u);
        const bool packed = std::string_view(name).starts_with("bvh2_packed");
        EXPECT_EQ(layout->count_closest(one).prims_tested, packed || !leaf_first ? 1u : 2u);
      }
    }
  }
}

// On a wide tree, the wide kernels' any hit visits the nodes that bvh2_traversal.h's visits, in every
// child order: the two implement each order the same way, and a change to one alone fails here (the
// order decides which nodes are visited before the first hit).
TEST(Layouts, WideAnyHitVisitsTheReferenceTraversalsNodesInEveryOrder) {
  const auto tris = test::random_triangles(3000, 23);
  const BuilderInfo& info = find_builder("wide_binned_sah");
  auto rays = test::random_rays(tris, 2000, 6);
  for (std::size_t i = 0; i < rays.size(); i += 7) rays[i].dir[i % 3] = -0.0f;
  for (uint32_t arity : {4u, 8u}) {
    const Bvh wide = info.build(BuildInput::from_triangles(tris),
                                resolve_params(info.name, info.params, {{"arity", std::to_string(arity)}}));
    for (AnyHitOrder order : {AnyHitOrder::kAuto, AnyHitOrder::kNearest, AnyHitOrder::kStored,
                              AnyHitOrder::kNearestStored, AnyHitOrder::kFarthestStored}) {
      const std::string spec =
          "bvh" + std::to_string(arity) + ":anyhit=" + std::string(to_string(order)) + ",isa=scalar";
      SCOPED_TRACE(spec);
      TraversalCounters reference;
      std::size_t occluded = 0;
      for (const Ray& ray : rays) occluded += any_hit_counted(wide, tris, ray, reference, order);
      ASSERT_GT(occluded, rays.size() / 10);
      const TraceCounts counts = compile_layout(spec, wide, tris)->count_any(rays);
      // Nodes only: the reference counts a leaf's primitives whole, the kernels the blocks they tested
      // before the first hit.
      EXPECT_EQ(counts.nodes_visited, reference.inner_visits + reference.leaf_visits);
    }
  }
}

// The orders differ where they should: a ray enters a near leaf whose triangle it misses and a far one
// whose triangle it hits. Nearest first visits both leaves, farthest first the far one alone; storage
// order enters the leaf in the first slot first, and nearest_stored the near leaf. Every layout, on both
// slot orders of the same two leaves.
TEST(Layouts, AnyHitOrdersVisitTheLeavesTheyName) {
  // Near (z = 1): its box covers the ray along the z axis, the triangle does not (the axis passes
  // beyond its long edge). Far (z = 5): covers it.
  const std::vector<Triangle> tris{{{-1.0f, 1.0f, 1.0f}, {1.0f, 1.0f, 1.0f}, {1.0f, -0.5f, 1.0f}},
                                   {{-1.0f, -1.0f, 5.0f}, {3.0f, -1.0f, 5.0f}, {-1.0f, 3.0f, 5.0f}}};
  std::vector<Ray> rays(1);
  rays[0].org = {0.0f, 0.0f, 0.0f};
  rays[0].dir = {0.0f, 0.0f, 1.0f};
  for (const bool far_first_in_slots : {true, false}) {
    Bvh bvh;
    const uint32_t slot_of_near = far_first_in_slots ? 2 : 1;
    bvh.nodes.resize(3);
    bvh.nodes[0] = {merge(tris[0].bounds(), tris[1].bounds()), 1, 2, 0};
    bvh.nodes[slot_of_near] = {tris[0].bounds(), 0, 0, 1};
    bvh.nodes[3 - slot_of_near] = {tris[1].bounds(), 1, 0, 1};
    bvh.prim_refs = {0, 1};
    ASSERT_TRUE(validate(bvh, std::span<const Triangle>(tris)).ok());
    for (const auto& [order, leaves] :
         std::vector<std::pair<std::string, uint64_t>>{{"nearest", 2},
                                                       {"nearest_stored", 2},
                                                       {"farthest_stored", 1},
                                                       {"stored", far_first_in_slots ? 1u : 2u}}) {
      const AnyHitOrder parsed = *parse_any_hit_order(order);
      TraversalCounters reference;
      ASSERT_TRUE(any_hit_counted(bvh, tris, rays[0], reference, parsed));
      EXPECT_EQ(reference.leaf_visits, leaves) << order;
      for (const char* layout : {"bvh2", "bvh2_packed", "bvh4:isa=scalar", "bvh8:isa=scalar", "bvh8"}) {
        const std::string spec = std::string(layout) +
                                 (std::string(layout).find(':') == std::string::npos ? ":" : ",") +
                                 "anyhit=" + order;
        SCOPED_TRACE(spec);
        const auto compiled = compile_layout(spec, bvh, tris);
        const TraceCounts counts = compiled->count_any(rays);
        EXPECT_EQ(counts.leaves_visited, leaves);
        std::vector<uint8_t> occluded(1);
        compiled->trace_any(rays, occluded);
        EXPECT_EQ(occluded[0], 1);
      }
    }
  }
}

// `sahbench list` names every any-hit order a layout takes, from the same table the parser reads.
TEST(Layouts, ListNamesEveryAnyHitOrder) {
  std::ostringstream out;
  print_catalogue(out);
  EXPECT_NE(out.str().find("anyhit=auto|nearest|stored|nearest_stored|farthest_stored,"), std::string::npos)
      << out.str();
}

TEST(Layouts, WideRaySetupHasTheScalarWatertightShear) {
  // make_wide_ray picks the shear axes without branches; it must agree with watertight_shear bit for bit
  // (the kernels' hits are compared with the scalar test's), ties and signed zeros included.
  const float values[] = {-2.0f, -1.0f, -0.5f, -0.0f, 0.0f, 0.5f, 1.0f, 2.0f, 1e-30f, -3e30f};
  int checked = 0;
  for (float x : values)
    for (float y : values)
      for (float z : values) {
        if (x == 0.0f && y == 0.0f && z == 0.0f) continue;
        Ray ray;
        ray.org = {0.0f, 0.0f, 0.0f};
        ray.dir = {x, y, z};
        const WideRay wide = make_wide_ray(ray);
        const WatertightShear shear = watertight_shear(ray.dir);
        SCOPED_TRACE(std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(z));
        EXPECT_EQ(wide.kx, shear.kx);
        EXPECT_EQ(wide.ky, shear.ky);
        EXPECT_EQ(wide.kz, shear.kz);
        EXPECT_EQ(std::bit_cast<uint32_t>(wide.sx), std::bit_cast<uint32_t>(shear.sx));
        EXPECT_EQ(std::bit_cast<uint32_t>(wide.sy), std::bit_cast<uint32_t>(shear.sy));
        EXPECT_EQ(std::bit_cast<uint32_t>(wide.sz), std::bit_cast<uint32_t>(shear.sz));
        ++checked;
      }
  EXPECT_EQ(checked, 1000 - 8);  // all but the eight zero vectors (+-0 per component)
}

}  // namespace
}  // namespace sahbench
