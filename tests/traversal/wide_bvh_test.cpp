// The wide layouts' memory: the arena's depth-first order (wide_bvh.h) and the huge-page allocator
// under it (core/huge_pages.h); and their node test against ray_box.h's, distance for distance. That
// the kernels find the same hits is tested with every layout in tests/harness/test_layouts.cpp.

#include "traversal/wide_bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iomanip>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/huge_pages.h"
#include "tests/support/prerequisites.h"
#include "tests/support/test_scenes.h"
#include "tests/traversal/median_builder.h"
#include "traversal/ray_box.h"

namespace sahbench {
namespace {

constexpr uint32_t kBlockUnits = sizeof(TriangleBlock) / kWideUnit;

// Marks the units of a node or block, so that overlaps show.
void take(std::vector<int>& units, uint64_t first, uint64_t count) {
  ASSERT_LE(first + count, units.size());
  for (uint64_t u = first; u < first + count; ++u) ++units[u];
}

// Walks the tree depth first, in slot order, with `next` the arena's unit where the walk expects what
// comes next, and checks the order of wide_bvh.h: on entering a node, the blocks of its leaf slots in
// slot order, then its child nodes side by side (from a 64-byte line), then each child's subtree in
// turn, the next child's only after the whole of the one before.
template <uint32_t N>
void check_subtree(const WideBvh<N>& wide, uint32_t ref, uint64_t& next, std::vector<int>& units,
                   std::vector<uint32_t>& prims, std::size_t& nodes, std::size_t& blocks) {
  constexpr uint32_t kNodeUnits = sizeof(WideNode<N>) / kWideUnit;
  const WideNode<N>& node = wide.node(ref);
  for (uint32_t i = 0; i < N; ++i) {
    if (node.count[i] == 0) continue;
    ASSERT_EQ(node.child[i], next) << "the blocks of slot " << i << " of node " << ref << " are not next";
    take(units, next, uint64_t{node.count[i]} * kBlockUnits);
    for (uint32_t b = 0; b < node.count[i]; ++b)
      for (uint32_t lane = 0; lane < kBlockWidth; ++lane)
        if (wide.block(node.child[i], b).prim[lane] != kInvalidPrim)
          prims.push_back(wide.block(node.child[i], b).prim[lane]);
    blocks += node.count[i];
    next += uint64_t{node.count[i]} * kBlockUnits;
  }
  std::vector<uint32_t> inner;
  for (uint32_t i = 0; i < N; ++i)
    if (node.count[i] == 0 && node.child[i] != 0) inner.push_back(node.child[i]);
  if (inner.empty()) return;
  next = (next + 1) & ~uint64_t{1};
  for (uint32_t c : inner) {
    ASSERT_EQ(c, next) << "the child nodes of node " << ref << " are not side by side after its blocks";
    ASSERT_GT(c, ref);
    take(units, c, kNodeUnits);
    ++nodes;
    next += kNodeUnits;
  }
  for (uint32_t c : inner) check_subtree(wide, c, next, units, prims, nodes, blocks);
}

template <uint32_t N>
void check_arena(uint32_t arity, std::size_t triangles, uint32_t max_leaf) {
  const auto scene = test::random_triangles(triangles, 7 + arity + max_leaf);
  const Bvh bvh = test::build_median_bvh(scene, arity, max_leaf);
  const WideBvh<N> wide = compile_wide<N>(bvh, scene);
  SCOPED_TRACE("N=" + std::to_string(N) + " arity=" + std::to_string(arity) +
               " max_leaf=" + std::to_string(max_leaf));
  std::vector<int> units(wide.arena.size(), 0);
  std::vector<uint32_t> prims;
  uint64_t next = sizeof(WideNode<N>) / kWideUnit;  // the root, at 0
  std::size_t nodes = 1, blocks = 0;
  take(units, 0, next);
  check_subtree(wide, 0, next, units, prims, nodes, blocks);
  EXPECT_EQ(next, wide.arena.size()) << "the arena has units past the last subtree";
  EXPECT_EQ(nodes, wide.node_count);
  EXPECT_EQ(blocks, wide.block_count);
  EXPECT_EQ(wide.bytes(), wide.arena.size() * kWideUnit);
  // No unit is used twice; the unused ones are padding before a node, at most one per node.
  EXPECT_EQ(std::count_if(units.begin(), units.end(), [](int n) { return n > 1; }), 0);
  EXPECT_LE(static_cast<std::size_t>(std::count(units.begin(), units.end(), 0)), nodes);
  // Every primitive once.
  std::sort(prims.begin(), prims.end());
  std::vector<uint32_t> expected(bvh.prim_refs.begin(), bvh.prim_refs.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(prims, expected);
}

TEST(WideBvh, ArenaIsInDepthFirstOrder) {
  for (uint32_t max_leaf : {1u, 4u, 8u}) {
    check_arena<4>(2, 2000, max_leaf);
    check_arena<4>(4, 2000, max_leaf);
    check_arena<8>(2, 3000, max_leaf);
    check_arena<8>(8, 3000, max_leaf);
  }
}

TEST(WideBvh, TreeThatIsOneLeafGetsARootWithOneLeafSlot) {
  const auto scene = test::random_triangles(3, 1);
  const WideBvh<8> wide = compile_wide<8>(test::build_median_bvh(scene, 2, 8), scene);
  ASSERT_EQ(wide.node_count, 1u);
  EXPECT_EQ(wide.node(0).count[0], 1u);
  EXPECT_EQ(wide.node(0).child[0], sizeof(WideNode<8>) / kWideUnit);
  EXPECT_EQ(wide.bytes(), sizeof(WideNode<8>) + sizeof(TriangleBlock));
}

// In edge form a block holds v0 and the edges v1 - v0, v2 - v0 as the Möller–Trumbore test computes
// them, bit for bit, at compile time and after a refit; in vertex form the vertices themselves; in the
// form of tri=mtn also the normals, as MollerTrumboreNormalTest computes them.
TEST(WideBvh, BlocksHoldVerticesOrTheEdgesTheTriangleTestReads) {
  const auto scene = test::random_triangles(300, 5);
  auto moved = scene;
  for (Triangle& t : moved) t = {t.v1 * 1.5f, t.v2 - Vec3{0.25f, 0.0f, 1.0f}, t.v0 + Vec3{3.0f, 1.0f, 0.5f}};
  auto check = [](const WideBvh<4>& wide, const std::vector<Triangle>& tris) {
    std::size_t lanes = 0;
    std::vector<uint32_t> stack{0};  // every node, and through its leaf slots every block
    while (!stack.empty()) {
      const WideNode<4>& node = wide.node(stack.back());
      stack.pop_back();
      for (uint32_t i = 0; i < 4; ++i) {
        if (node.count[i] == 0) {
          if (node.child[i] != 0) stack.push_back(node.child[i]);
          continue;
        }
        for (uint32_t b = 0; b < node.count[i]; ++b) {
          const TriangleBlock& block = wide.block(node.child[i], b);
          for (uint32_t lane = 0; lane < kBlockWidth; ++lane) {
            if (block.prim[lane] == kInvalidPrim) continue;
            const Triangle& t = tris[block.prim[lane]];
            const bool edges = wide.form != BlockForm::kVertices;
            const Vec3 normal = cross(t.v1 - t.v0, t.v2 - t.v0);
            for (uint32_t a = 0; a < 3; ++a) {
              ASSERT_EQ(block.v0[a][lane], t.v0[a]);
              ASSERT_EQ(block.v1[a][lane], edges ? t.v1[a] - t.v0[a] : t.v1[a]);
              ASSERT_EQ(block.v2[a][lane], edges ? t.v2[a] - t.v0[a] : t.v2[a]);
              if (wide.form == BlockForm::kEdgesNormals) {
                ASSERT_EQ(wide.normal_block(node.child[i], b).normal[a][lane], normal[a]);
              }
            }
            ++lanes;
          }
        }
      }
    }
    EXPECT_EQ(lanes, tris.size());
  };
  for (BlockForm form : {BlockForm::kVertices, BlockForm::kEdges, BlockForm::kEdgesNormals}) {
    SCOPED_TRACE(static_cast<int>(form));
    WideBvh<4> wide = compile_wide<4>(test::build_median_bvh(scene, 4, 4), scene, form);
    EXPECT_EQ(wide.form, form);
    // Blocks of 160 or 224 bytes; a node may wait one 32-byte unit for its 64-byte line.
    const std::size_t parts = wide.node_count * sizeof(WideNode<4>) +
                              wide.block_count * (form == BlockForm::kEdgesNormals ? 224 : 160);
    EXPECT_GE(wide.bytes(), parts);
    EXPECT_LE(wide.bytes(), parts + wide.node_count * kWideUnit);
    check(wide, scene);
    refit_wide(wide, moved);
    check(wide, moved);
  }
  EXPECT_EQ(block_form_for(TriangleTestKind::kWatertight), BlockForm::kVertices);
  EXPECT_EQ(block_form_for(TriangleTestKind::kMollerTrumbore), BlockForm::kEdges);
  EXPECT_EQ(block_form_for(TriangleTestKind::kMollerTrumboreNoEpsilon), BlockForm::kEdges);
  EXPECT_EQ(block_form_for(TriangleTestKind::kMollerTrumboreNormal), BlockForm::kEdgesNormals);
}

// The node test of every instruction set computes ray_box.h's entry distances bit for bit, for each box
// test: the micro-benchmark loop returns the sum over nodes and rays of the hit mask plus child 0's entry
// distance, which is summed here from the scalar box tests, child by child. (Hits alone would not tell a
// fused multiply-subtract from a multiply and a subtract; the distances do.)
template <class BoxTest, uint32_t N>
double reference_node_sum(const std::vector<WideNode<N>>& nodes, const std::vector<Ray>& rays) {
  double sum = 0.0;
  for (const Ray& ray : rays) {
    const BoxTest test(ray);
    for (const WideNode<N>& node : nodes) {
      uint32_t mask = 0;
      float t0 = 0.0f;
      for (uint32_t i = 0; i < N; ++i) {
        const Aabb box{{node.planes[0][i], node.planes[2][i], node.planes[4][i]},
                       {node.planes[1][i], node.planes[3][i], node.planes[5][i]}};
        float t = 0.0f;
        mask |= static_cast<uint32_t>(test.intersect(box, ray.tmin, ray.tmax, t)) << i;
        if (i == 0) t0 = t;
      }
      sum += mask + t0;
    }
  }
  return sum;
}

template <uint32_t N>
void check_node_tests() {
  test::Skips skips;
  const auto scene = test::random_triangles(2000, 11);
  const WideBvh<N> wide = compile_wide<N>(test::build_median_bvh(scene, N, 4), scene);
  // The root, its child nodes, theirs...: the first 64 nodes breadth first, boxes of every size.
  std::vector<WideNode<N>> nodes{wide.node(0)};
  for (std::size_t k = 0; k < nodes.size() && nodes.size() < 64; ++k)
    for (uint32_t i = 0; i < N; ++i)
      if (nodes[k].count[i] == 0 && nodes[k].child[i] != 0) nodes.push_back(wide.node(nodes[k].child[i]));
  auto rays = test::random_rays(scene, 300, 3);
  // Tiny and zero direction components, where FmaRayBox's reciprocal differs from 1 / d.
  for (std::size_t i = 0; i < rays.size(); i += 3) rays[i].dir[(i / 3) % 3] = (i % 2 ? 1e-20f : -0.0f);
  std::vector<WideRay> wide_rays;
  for (BoxTestKind box : {BoxTestKind::kRobust, BoxTestKind::kFast, BoxTestKind::kFma}) {
    SCOPED_TRACE(std::string(to_string(box)));
    double expected = 0.0;
    if (box == BoxTestKind::kRobust) expected = reference_node_sum<RobustRayBox>(nodes, rays);
    if (box == BoxTestKind::kFast) expected = reference_node_sum<FastRayBox>(nodes, rays);
    if (box == BoxTestKind::kFma) {
      // The rays box=fma does not take are tested with the robust box (FmaRayBox::takes).
      std::vector<Ray> fma_rays, robust_rays;
      for (const Ray& ray : rays) (FmaRayBox::takes(ray) ? fma_rays : robust_rays).push_back(ray);
      ASSERT_FALSE(robust_rays.empty());
      expected = reference_node_sum<FmaRayBox>(nodes, fma_rays) +
                 reference_node_sum<RobustRayBox>(nodes, robust_rays);
    }
    wide_rays.clear();
    for (const Ray& ray : rays) wide_rays.push_back(make_wide_ray(ray, false, box));
    for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kSse, KernelIsa::kAvx2, KernelIsa::kAvx512}) {
      if (!skips.have_isa(isa)) continue;
      SCOPED_TRACE(std::string(to_string(isa)));
      const WideBenchLoops loops = find_wide_bench_loops(isa, N, {TriangleTestKind::kWatertight, box});
      ASSERT_NE(loops.nodes, nullptr);
      EXPECT_EQ(loops.nodes(nodes.data(), nodes.size(), wide_rays.data(), wide_rays.size()), expected);
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

TEST(WideBvh, NodeTestsOfEveryIsaComputeTheScalarBoxTestsDistances) {
  check_node_tests<4>();
  check_node_tests<8>();
}

// Nodes and rays where the AVX2 and AVX-512 kernels' integer min and max for box=fma (wide_kernels.inl:
// kIntOrder) would part from the float compares if one of its conditions were missed: planes at +0 and
// -0, rays from +-0 with zero and tiny direction components, tmin of +0, -0 and below zero, tmax of -0,
// origins so far out that org * inv overflows, and slab distances that round to -0 from below (planes
// and reciprocals at the bottom of the denormals, with a ray that starts on the box's far face). Each
// node against each ray alone: the hit mask and every slot's entry distance, against ray_box.h's.
template <uint32_t N>
void check_node_tests_on_signed_zeros() {
  test::Skips skips;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr float kDenormMin = std::numeric_limits<float>::denorm_min();
  std::mt19937 rng(5);
  auto pick = [&](const auto& values) { return values[rng() % std::size(values)]; };
  const float planes[] = {-2.0f, -1.0f, -0.5f, -kDenormMin, -0.0f, 0.0f, kDenormMin, 0.5f, 1.0f, 2.0f};
  std::vector<Aabb> boxes(40);
  for (Aabb& box : boxes)
    for (int axis = 0; axis < 3; ++axis) {
      float lo = pick(planes), hi = pick(planes);
      if (hi < lo) std::swap(lo, hi);  // +0 and -0 compare equal: either may be the minimum
      box.min[axis] = lo;
      box.max[axis] = hi;
    }
  // Boxes with a face at +-denorm_min or 0.5 on x, for rays from 0 and 0.5 along x (below): a far
  // distance of denorm_min * inv with |inv| < 1 is below 2^-150, or 0.5 * inv - round(0.5 * inv) with a
  // denormal inv.
  for (const auto& [lo, hi] : {std::pair{-1.0f, -kDenormMin},
                               {kDenormMin, 1.0f},
                               {0.0f, 0.5f},
                               {-0.5f, 0.0f},
                               {-1.0f, 0.5f},
                               {-0.5f, 1.0f}})
    boxes.push_back(Aabb{{lo, -1.0f, -1.0f}, {hi, 1.0f, 1.0f}});
  std::vector<WideNode<N>> nodes;
  for (std::size_t k = 0; k < 2 * boxes.size(); ++k) {
    WideNode<N> node{};
    for (uint32_t i = 0; i < N; ++i) {
      const Aabb box = (k % 3 == 0 && i == N - 1) ? Aabb::empty() : boxes[(k * 5 + i) % boxes.size()];
      for (int axis = 0; axis < 3; ++axis) {
        node.planes[2 * axis][i] = box.min[axis];
        node.planes[2 * axis + 1][i] = box.max[axis];
      }
    }
    nodes.push_back(node);
  }
  const float origins[] = {-0.0f, 0.0f, 1.0f, -1.0f, 0.5f, -0.5f, -1.5f};
  const float directions[] = {1.0f, -1.0f, 0.5f, 2.0f, -2.0f, -0.0f, 0.0f, 1e-20f, -1e-20f, 2.7e38f, -3e38f};
  const float tmins[] = {0.0f, 0.0f, -0.0f, -1.0f, 0.25f};
  const float tmaxs[] = {kInf, -0.0f, 0.0f, 1.5f};
  std::vector<Ray> rays;
  for (int i = 0; i < 400; ++i) {
    Ray ray;
    for (int axis = 0; axis < 3; ++axis) {
      ray.org[axis] = pick(origins);
      ray.dir[axis] = pick(directions);
    }
    ray.tmin = pick(tmins);
    ray.tmax = pick(tmaxs);
    rays.push_back(ray);
  }
  for (float far : {1e30f, -3e38f}) rays.push_back(Ray{{far, 0.5f, -0.0f}, 0.0f, {1e-20f, 1.0f, -0.0f}});
  // Along x from 0 and +-0.5, at +0, with direction components from 2 to near the top of the floats,
  // whose reciprocals reach the denormals: the rays of the far-face cases above.
  for (float x : {0.0f, 0.5f, -0.5f})
    for (float d : {2.0f, 3.0f, 1.7e38f, 2.3e38f, 2.7e38f, 2.9e38f, 3.1e38f, 3.3e38f})
      for (float sign : {1.0f, -1.0f}) rays.push_back(Ray{{x, 0.25f, -0.25f}, 0.0f, {sign * d, 0.0f, -0.0f}});
  rays.push_back(Ray{{0.5f, -0.0f, 1.0f}, 0.0f, {3e38f, -1.0f, 0.0f}});
  auto same = [](float a, float b) { return a == b || (std::isnan(a) && std::isnan(b)); };
  int kinds[3] = {};
  for (BoxTestKind box : {BoxTestKind::kRobust, BoxTestKind::kFast, BoxTestKind::kFma}) {
    SCOPED_TRACE(std::string(to_string(box)));
    for (const Ray& ray : rays) {
      const WideRay wide_ray = make_wide_ray(ray, false, box);
      if (box == BoxTestKind::kFma) ++kinds[static_cast<int>(wide_ray.int_order)];
      for (const WideNode<N>& node : nodes) {
        uint32_t expected_mask = 0;
        float expected_t[N];
        for (uint32_t i = 0; i < N; ++i) {
          const Aabb slot{{node.planes[0][i], node.planes[2][i], node.planes[4][i]},
                          {node.planes[1][i], node.planes[3][i], node.planes[5][i]}};
          bool hit = false;
          if (box == BoxTestKind::kRobust)
            hit = RobustRayBox(ray).intersect(slot, ray.tmin, ray.tmax, expected_t[i]);
          if (box == BoxTestKind::kFast)
            hit = FastRayBox(ray).intersect(slot, ray.tmin, ray.tmax, expected_t[i]);
          if (box == BoxTestKind::kFma)
            hit = FmaRayBox::takes(ray)
                      ? FmaRayBox(ray).intersect(slot, ray.tmin, ray.tmax, expected_t[i])
                      : RobustRayBox(ray).intersect(slot, ray.tmin, ray.tmax, expected_t[i]);
          expected_mask |= static_cast<uint32_t>(hit) << i;
        }
        for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kSse, KernelIsa::kAvx2, KernelIsa::kAvx512}) {
          if (!skips.have_isa(isa)) continue;
          alignas(32) float t[N];
          const uint32_t mask =
              find_wide_bench_loops(isa, N, {TriangleTestKind::kWatertight, box}).node(&node, wide_ray, t);
          auto where = [&] {
            std::ostringstream out;
            out << std::setprecision(9) << to_string(isa)
                << (wide_ray.int_order == IntOrder::kFree      ? " (integer order)"
                    : wide_ray.int_order == IntOrder::kGuarded ? " (guarded integer order)"
                                                               : "")
                << ": ray from (" << ray.org.x << ", " << ray.org.y << ", " << ray.org.z << ") along ("
                << ray.dir.x << ", " << ray.dir.y << ", " << ray.dir.z << ") in [" << ray.tmin << ", "
                << ray.tmax << "]";
            return out.str();
          };
          ASSERT_EQ(mask, expected_mask) << where();
          for (uint32_t i = 0; i < N; ++i)
            ASSERT_TRUE(same(t[i], expected_t[i]))
                << where() << ", slot " << i << ": entry " << t[i] << ", expected " << expected_t[i];
        }
      }
    }
  }
  // Every path of the kernels was taken.
  EXPECT_GT(kinds[static_cast<int>(IntOrder::kNone)], 20);
  EXPECT_GT(kinds[static_cast<int>(IntOrder::kGuarded)], 20);
  EXPECT_GT(kinds[static_cast<int>(IntOrder::kFree)], 20);
  SAHBENCH_REPORT_SKIPS(skips);
}

// The ray set-up's sorting for the integer path (wide_bvh.h: IntOrder), at the edges of each condition,
// and a batch's answer is the lowest of its rays'.
TEST(WideBvh, RaySetUpSortsRaysForTheIntegerPathAtTheEdgesOfItsConditions) {
  auto kind = [](Vec3 org, Vec3 dir, float tmin = 0.0f, float tmax = std::numeric_limits<float>::infinity()) {
    return make_wide_ray(Ray{org, tmin, dir, tmax}, false, BoxTestKind::kFma).int_order;
  };
  const float low = 0x1p-100f, below = std::nextafter(low, 0.0f);
  EXPECT_EQ(kind({1, 2, 3}, {1, -1, 0.5f}), IntOrder::kFree);
  EXPECT_EQ(kind({low, -low, low}, {1, -1, 1}), IntOrder::kFree);
  EXPECT_EQ(kind({1, below, 1}, {1, 1, 1}), IntOrder::kGuarded);
  EXPECT_EQ(kind({1, 1, -0.0f}, {1, 1, 1}), IntOrder::kGuarded);
  EXPECT_EQ(kind({0, 0, 0}, {1, 1, 1}), IntOrder::kGuarded);
  // A zero direction component is outside box=fma's domain: the robust box test, no integer path.
  EXPECT_EQ(kind({1, 1, 1}, {0, 1, 1}), IntOrder::kNone);
  EXPECT_EQ(kind({1, 1, 1}, {1, 1, 1}, -0.0f), IntOrder::kNone);
  EXPECT_EQ(kind({1, 1, 1}, {1, 1, 1}, -1.0f), IntOrder::kNone);
  EXPECT_EQ(kind({1, 1, 1}, {1, 1, 1}, 0.0f, -1.0f), IntOrder::kNone);
  EXPECT_EQ(kind({1, 1, 1}, {1, 1, 1}, 0.0f, -0.0f), IntOrder::kFree);
  EXPECT_EQ(kind({1e30f, 1, 1}, {0, 1, 1}), IntOrder::kNone);
  EXPECT_EQ(kind({0, 1, 1}, {1, 1, 1}, -1.0f), IntOrder::kNone);
  // The other box tests never take the integer path.
  EXPECT_EQ(make_wide_ray(Ray{{1, 2, 3}, 0.0f, {1, 1, 1}}, false, BoxTestKind::kFast).int_order,
            IntOrder::kNone);
  const std::vector<Ray> batch{Ray{{1, 2, 3}, 0.0f, {1, 1, 1}}, Ray{{0, 2, 3}, 0.0f, {1, 1, 1}},
                               Ray{{1, 2, 3}, -1.0f, {1, 1, 1}}};
  std::vector<WideRay> out(batch.size());
  EXPECT_EQ(make_wide_rays(std::span(batch).first(1), out.data(), false, BoxTestKind::kFma).int_order,
            IntOrder::kFree);
  EXPECT_EQ(make_wide_rays(std::span(batch).first(2), out.data(), false, BoxTestKind::kFma).int_order,
            IntOrder::kGuarded);
  EXPECT_EQ(make_wide_rays(batch, out.data(), false, BoxTestKind::kFma).int_order, IntOrder::kNone);
}

// The batch set-up (computed a block of rays at a time) gives every ray the single-ray set-up's bits,
// field by field, in blocks cut anywhere: random rays with +0 and -0 components, and rays at the edges
// of every condition (untraceable, out of box=fma's domain or the float triangle test's range, an
// infinite or negative interval, a NaN with the largest direction component after it).
TEST(WideBvh, BatchSetUpGivesEachRayTheSingleRaySetUp) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<Ray> rays = test::random_rays(test::random_triangles(200, 5), 300, 6);
  const std::vector<Ray> edges{Ray{{1, 2, 3}, 0.0f, {nan, 1, 2}},
                               Ray{{1, 2, 3}, 0.0f, {1e-30f, nan, 1}},
                               Ray{{nan, 2, 3}, 0.0f, {1, 1, 1}},
                               Ray{{1, 2, 3}, nan, {1, 1, 1}},
                               Ray{{1, 2, 3}, 0.0f, {1, 1, 1}, nan},
                               Ray{{inf, 2, 3}, 0.0f, {1, 1, 1}},
                               Ray{{1, 2, 3}, 0.0f, {0, -inf, 1}},
                               Ray{{1, 2, 3}, -1.0f, {1, 1, 1}, -2.0f},
                               Ray{{1, 2, 3}, -0.0f, {-0.0f, -0.0f, -1}},
                               Ray{{1e30f, -1e30f, 1}, 0.0f, {1e-45f, -1e-38f, 1e-30f}},
                               Ray{{0x1p41f, 0, 0}, 0.0f, {1, 1, 1}},
                               Ray{{1, 1, 1}, 0.0f, {0x1p-41f, -0x1p-41f, 0}},
                               Ray{{1, 1, 1}, 0.0f, {0x1p41f, 1, 1}},
                               Ray{{0x1p-100f, 1, 1}, 0.0f, {1, -1, 1}, inf},
                               Ray{{1, 1, 1}, 0.0f, {0, 0, 0}},
                               Ray{{-1, -1, -1}, 0.0f, {2, 2, -2}},
                               Ray{{1, 2, 3}, -0.0f, {1, 1, 1}},
                               Ray{{1, 2, 3}, 0.0f, {1, 1, 1}, -1.0f},
                               Ray{{1, 2, 3}, 0.0f, {1, 1, 1}, -0.0f},
                               Ray{{1, std::nextafter(0x1p-100f, 0.0f), 1}, 0.0f, {1, 1, 1}},
                               Ray{{0, 0, 0}, 0.0f, {0, 1, 1}},
                               Ray{{1, 2, 3}, 0.0f, {1, 1, -1}, nan}};
  // Directions whose components tie in magnitude, with either sign and either zero: the shear's choice
  // of axes at its edges.
  for (const float x : {-1.0f, -0.0f, 0.0f, 1.0f})
    for (const float y : {-1.0f, -0.0f, 0.0f, 1.0f, 2.0f})
      for (const float z : {-2.0f, -1.0f, -0.0f, 0.0f, 1.0f})
        rays.push_back(Ray{{0.5f, 0.25f, 0.125f}, 0.0f, {x, y, z}});
  for (int copy = 0; copy < 3; ++copy) rays.insert(rays.end(), edges.begin(), edges.end());
  auto same = [](const WideRay& a, const WideRay& b) {
    auto bits = [](float x) { return std::bit_cast<uint32_t>(x); };
    for (int axis = 0; axis < 3; ++axis)
      if (bits(a.org[axis]) != bits(b.org[axis]) || bits(a.dir[axis]) != bits(b.dir[axis]) ||
          bits(a.inv_dir[axis]) != bits(b.inv_dir[axis]) || bits(a.org_inv[axis]) != bits(b.org_inv[axis]) ||
          a.near_plane[axis] != b.near_plane[axis] || a.far_plane[axis] != b.far_plane[axis])
        return false;
    return bits(a.tmin) == bits(b.tmin) && bits(a.tmax) == bits(b.tmax) && a.kx == b.kx && a.ky == b.ky &&
           a.kz == b.kz && bits(a.sx) == bits(b.sx) && bits(a.sy) == bits(b.sy) && bits(a.sz) == bits(b.sz) &&
           a.int_order == b.int_order && a.robust_box == b.robust_box && a.mtn_in_double == b.mtn_in_double;
  };
  for (const bool shear : {false, true}) {
    for (const BoxTestKind box : {BoxTestKind::kRobust, BoxTestKind::kFast, BoxTestKind::kFma}) {
      // Batches of 1, then 15, 16, 17, ... rays, growing by one: whole and partial blocks cut anywhere.
      for (std::size_t first = 0, size = 1; first < rays.size();
           first += size, size = size == 1 ? 15 : size + 1) {
        const std::size_t n = std::min(size, rays.size() - first);
        // Every byte set, so that a field the batch set-up leaves unwritten shows.
        std::vector<WideRay> batch(n);
        std::memset(static_cast<void*>(batch.data()), 0xFF, n * sizeof(WideRay));
        const WideRaysInfo info = make_wide_rays(std::span(rays).subspan(first, n), batch.data(), shear, box);
        WideRaysInfo expected{IntOrder::kFree, false};
        for (std::size_t i = 0; i < n; ++i) {
          const WideRay one = make_wide_ray(rays[first + i], shear, box);
          ASSERT_TRUE(same(batch[i], one))
              << "ray " << first + i << " shear " << shear << " box " << static_cast<int>(box);
          if (one.robust_box)
            expected.robust_box = true;
          else
            expected.int_order = std::min(expected.int_order, one.int_order);
        }
        EXPECT_EQ(info.int_order, expected.int_order);
        EXPECT_EQ(info.robust_box, expected.robust_box);
      }
    }
  }
}

// box=fma's domain (ray_box.h: FmaRayBox::takes) at both edges: direction components from the smallest
// normal float up, and org * (1 / d) up to the largest float. The rays outside it are marked for the
// robust box test and leave the batch's integer order as the others make it.
TEST(WideBvh, RaySetUpSendsRaysOutsideTheFmaDomainToTheRobustBoxTest) {
  auto robust = [](Vec3 org, Vec3 dir) {
    const Ray ray{org, 0.0f, dir, std::numeric_limits<float>::infinity()};
    const bool wide = make_wide_ray(ray, false, BoxTestKind::kFma).robust_box;
    EXPECT_EQ(wide, !FmaRayBox::takes(ray));
    return wide;
  };
  const float min = std::numeric_limits<float>::min(), below = std::nextafter(min, 0.0f);
  EXPECT_FALSE(robust({1, 2, 3}, {1, -1, 0.5f}));
  EXPECT_FALSE(robust({1, 2, 3}, {min, -min, 1}));
  EXPECT_TRUE(robust({1, 2, 3}, {below, 1, 1}));
  EXPECT_TRUE(robust({1, 2, 3}, {1, -0.0f, 1}));
  EXPECT_TRUE(robust({1, 2, 3}, {1, 1, 0.0f}));
  // org * (1 / d): 1.7e38 * 2 is finite, 1.8e38 * 2 is not.
  EXPECT_FALSE(robust({1.7e38f, 2, 3}, {0.5f, 1, 1}));
  EXPECT_TRUE(robust({1.8e38f, 2, 3}, {0.5f, 1, 1}));
  EXPECT_FALSE(make_wide_ray(Ray{{1, 2, 3}, 0.0f, {0, 1, 1}}, false, BoxTestKind::kRobust).robust_box);
  const std::vector<Ray> batch{Ray{{1, 2, 3}, 0.0f, {1, 1, 1}}, Ray{{1, 2, 3}, 0.0f, {0, 1, 1}}};
  std::vector<WideRay> out(batch.size());
  const WideRaysInfo info = make_wide_rays(batch, out.data(), false, BoxTestKind::kFma);
  EXPECT_TRUE(info.robust_box);
  EXPECT_EQ(info.int_order, IntOrder::kFree);
}

TEST(WideBvh, NodeTestsOfEveryIsaAgreeOnSignedZerosNegativeTminAndOverflowingOrigins) {
  check_node_tests_on_signed_zeros<4>();
  check_node_tests_on_signed_zeros<8>();
}

// A box with NaN planes (a hand-made tree: the builders make none from finite triangles) is stored with
// an infinity in place of each NaN, which every box test reads as no bound, as it reads the NaN; so the
// layout's node test answers as ray_box.h does on the NaN box.
TEST(WideBvh, NanPlanesAreStoredAsInfinitiesThatTestTheSame) {
  test::Skips skips;
  constexpr float kNan = std::numeric_limits<float>::quiet_NaN(),
                  kInf = std::numeric_limits<float>::infinity();
  const auto scene = test::random_triangles(200, 13);
  Bvh bvh = test::build_median_bvh(scene, 8, 4);
  ASSERT_FALSE(bvh.root().is_leaf());
  const uint32_t slot = bvh.root().first;
  bvh.nodes[slot].bounds.min.y = kNan;
  bvh.nodes[slot].bounds.max.z = kNan;
  const WideBvh<8> wide = compile_wide<8>(bvh, scene);
  const WideNode<8>& root = wide.node(0);
  EXPECT_EQ(root.planes[2][0], -kInf);
  EXPECT_EQ(root.planes[5][0], kInf);
  EXPECT_EQ(root.planes[0][0], bvh.nodes[slot].bounds.min.x);
  auto rays = test::random_rays(scene, 300, 9);
  for (std::size_t i = 0; i < rays.size(); i += 4) rays[i].dir[i % 3] = i % 8 ? 0.0f : -0.0f;
  // The root's slots are the root's children, slot 0 the NaN box: the loop returns the mask plus slot
  // 0's entry distance, computed here by ray_box.h on the boxes of the common format.
  auto expected_sum = [&]<class BoxTest>(const Ray& ray) {
    const BoxTest test(ray);
    uint32_t mask = 0;
    float t0 = 0.0f;
    for (uint32_t i = 0; i < bvh.root().child_count; ++i) {
      float t = 0.0f;
      mask |= static_cast<uint32_t>(test.intersect(bvh.nodes[slot + i].bounds, ray.tmin, far_limit(ray), t))
              << i;
      if (i == 0) t0 = t;
    }
    return static_cast<double>(mask + t0);  // summed in float, as the loop sums them
  };
  for (BoxTestKind box : {BoxTestKind::kRobust, BoxTestKind::kFast, BoxTestKind::kFma}) {
    SCOPED_TRACE(std::string(to_string(box)));
    for (const Ray& ray : rays) {
      double expected = 0.0;
      if (box == BoxTestKind::kRobust) expected = expected_sum.operator()<RobustRayBox>(ray);
      if (box == BoxTestKind::kFast) expected = expected_sum.operator()<FastRayBox>(ray);
      if (box == BoxTestKind::kFma)
        expected = FmaRayBox::takes(ray) ? expected_sum.operator()<FmaRayBox>(ray)
                                         : expected_sum.operator()<RobustRayBox>(ray);
      const WideRay wide_ray = make_wide_ray(ray, false, box);
      for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kSse, KernelIsa::kAvx2, KernelIsa::kAvx512}) {
        if (!skips.have_isa(isa)) continue;
        EXPECT_EQ(
            find_wide_bench_loops(isa, 8, {TriangleTestKind::kWatertight, box}).nodes(&root, 1, &wide_ray, 1),
            expected)
            << to_string(isa);
      }
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

TEST(HugePages, LargeArraysStartOnAHugePageAndSmallOnesOnALine) {
  std::vector<WideUnit, HugePageAllocator<WideUnit>> small(10), large(kHugePageBytes / kWideUnit + 5);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(small.data()) % 64, 0u);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(large.data()) % kHugePageBytes, 0u);
  // All of it can be written and read back, across a resize that moves it.
  for (std::size_t i = 0; i < large.size(); ++i)
    large[i].bytes[i % kWideUnit] = static_cast<unsigned char>(i);
  large.resize(large.size() * 2);
  for (std::size_t i = 0; i < large.size() / 2; ++i)
    ASSERT_EQ(large[i].bytes[i % kWideUnit], static_cast<unsigned char>(i)) << "unit " << i;
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(large.data()) % kHugePageBytes, 0u);
  large.clear();
  large.shrink_to_fit();
  std::vector<double, HugePageAllocator<double>> copy(1000, 2.5);
  const auto other = copy;
  EXPECT_EQ(other, copy);
}

}  // namespace
}  // namespace sahbench
