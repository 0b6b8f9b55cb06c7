// Ray/box and ray/triangle tests of each variant and width, and one node visit of each layout.
// Each benchmark reports items/s = tests (or node visits) per second.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <bit>
#include <string>
#include <vector>

#include "bench/bench_data.h"
#include "builders/collapse.h"
#include "traversal/packed_bvh2.h"
#include "traversal/ray_box.h"
#include "traversal/triangle_lanes.h"
#include "traversal/triangle_tests.h"
#include "traversal/wide_bvh.h"

namespace sahbench::bench {
namespace {

constexpr std::size_t kRays = 256;
constexpr std::size_t kPrims = 1024;

// Scalar ray/box test (one box), as the bvh2 layouts run it on each child: one node visit of bvh2 is two.
template <class BoxTest>
void BM_ScalarRayBox(benchmark::State& state) {
  const auto& tris = soup(kPrims);
  const auto& rs = rays(kRays);
  std::vector<Aabb> boxes;
  for (const auto& t : tris) boxes.push_back(t.bounds());
  for (auto _ : state) {
    uint32_t hits = 0;
    for (const Ray& ray : rs) {
      const BoxTest test(ray);
      float t;
      for (const Aabb& box : boxes) hits += test.intersect(box, ray.tmin, ray.tmax, t);
    }
    benchmark::DoNotOptimize(hits);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kRays * boxes.size()));
}
BENCHMARK(BM_ScalarRayBox<RobustRayBox>)->Name("ray_box/scalar/robust");
BENCHMARK(BM_ScalarRayBox<FastRayBox>)->Name("ray_box/scalar/fast");
BENCHMARK(BM_ScalarRayBox<FmaRayBox>)->Name("ray_box/scalar/fma");

// Scalar ray/triangle tests.
template <class TriangleTest>
void BM_ScalarRayTriangle(benchmark::State& state) {
  const auto& tris = soup(kPrims);
  const auto& rs = rays(kRays);
  for (auto _ : state) {
    uint32_t hits = 0;
    for (const Ray& ray : rs) {
      const TriangleTest test(ray);
      float t, u, v;
      for (const Triangle& tri : tris) hits += test.intersect(tri, ray.tmin, ray.tmax, t, u, v);
    }
    benchmark::DoNotOptimize(hits);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kRays * tris.size()));
}
BENCHMARK(BM_ScalarRayTriangle<WatertightTriangleTest>)->Name("ray_triangle/scalar/watertight");
BENCHMARK(BM_ScalarRayTriangle<MollerTrumboreTest>)->Name("ray_triangle/scalar/mt");
BENCHMARK(BM_ScalarRayTriangle<MollerTrumboreNoEpsilonTest>)->Name("ray_triangle/scalar/mt0");
BENCHMARK(BM_ScalarRayTriangle<MollerTrumboreNormalTest>)->Name("ray_triangle/scalar/mtn");

#if defined(__SSE2__)
// A triangle test four consecutive triangles at a time, as bvh2_packed's walks test a leaf
// (triangle_lanes.h; closest hit: watertight hits refined). Items are triangles.
template <class TriangleTest>
void BM_TriangleLanes(benchmark::State& state) {
  const auto& tris = soup(kPrims);
  const auto& rs = rays(kRays);
  for (auto _ : state) {
    uint32_t hits = 0;
    for (const Ray& ray : rs) {
      const LeafTestOf<TriangleTest> test(ray);
      alignas(16) float t[4], u[4], v[4];
      for (std::size_t i = 0; i < tris.size(); i += 4) {
        const auto n = static_cast<uint32_t>(std::min<std::size_t>(4, tris.size() - i));
        hits += static_cast<uint32_t>(
            std::popcount(test.template intersect<true>(&tris[i], n, ray.tmin, ray.tmax, t, u, v)));
      }
    }
    benchmark::DoNotOptimize(hits);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kRays * tris.size()));
}
BENCHMARK(BM_TriangleLanes<WatertightTriangleTest>)->Name("ray_triangle/lanes4/watertight");
BENCHMARK(BM_TriangleLanes<MollerTrumboreTest>)->Name("ray_triangle/lanes4/mt");
BENCHMARK(BM_TriangleLanes<MollerTrumboreNoEpsilonTest>)->Name("ray_triangle/lanes4/mt0");
#if defined(__FMA__)
BENCHMARK(BM_TriangleLanes<MollerTrumboreNormalTest>)->Name("ray_triangle/lanes4/mtn");
#endif
#endif

// The wide kernels' node test (N boxes at once, one node visit) and block test (4 triangles at once),
// per instruction set available here. Items are node visits, or triangles.
template <uint32_t N>
const WideBvh<N>& wide_tree(BlockForm form = BlockForm::kVertices) {
  auto make = [](BlockForm f) {
    return compile_wide<N>(collapse_greedy(binary_tree(kPrims * 16), N), soup(kPrims * 16), f);
  };
  static const WideBvh<N> vertices = make(BlockForm::kVertices), edges = make(BlockForm::kEdges),
                          normals = make(BlockForm::kEdgesNormals);
  return form == BlockForm::kEdges ? edges : form == BlockForm::kEdgesNormals ? normals : vertices;
}

// The first `limit` nodes and blocks of a tree, breadth first from the root, copied into arrays for the
// test loops: the blocks as arena units, each block_units(tree.form) long.
template <uint32_t N>
struct WideParts {
  std::vector<WideNode<N>> nodes;
  std::vector<WideUnit> blocks;
  std::size_t block_count = 0;
};

template <uint32_t N>
WideParts<N> wide_parts(const WideBvh<N>& tree, std::size_t limit) {
  WideParts<N> parts;
  const uint32_t units = block_units(tree.form);
  std::vector<uint32_t> queue{0};
  for (std::size_t q = 0; q < queue.size() && (parts.nodes.size() < limit || parts.block_count < limit);
       ++q) {
    const WideNode<N>& node = tree.node(queue[q]);
    if (parts.nodes.size() < limit) parts.nodes.push_back(node);
    for (uint32_t i = 0; i < N; ++i) {
      if (node.count[i] == 0 && node.child[i] != 0) queue.push_back(node.child[i]);
      for (uint32_t b = 0; b < node.count[i] && parts.block_count < limit; ++b, ++parts.block_count) {
        const auto* first = reinterpret_cast<const WideUnit*>(&tree.block(node.child[i], b));
        parts.blocks.insert(parts.blocks.end(), first, first + units);
      }
    }
  }
  return parts;
}

std::vector<WideRay> wide_rays(BoxTestKind box = BoxTestKind::kRobust) {
  std::vector<WideRay> out;
  for (const Ray& r : rays(kRays)) out.push_back(make_wide_ray(r, true, box));
  return out;
}

template <uint32_t N>
void BM_WideNodeVisit(benchmark::State& state, KernelIsa isa, BoxTestKind box) {
  if (!kernel_isa_available(isa)) return state.SkipWithError("ISA not available on this CPU");
  const auto loops = find_wide_bench_loops(isa, N, {TriangleTestKind::kWatertight, box});
  const auto nodes = wide_parts(wide_tree<N>(), 256).nodes;  // stays in L1/L2: the test, not memory
  const auto rs = wide_rays(box);
  for (auto _ : state)
    benchmark::DoNotOptimize(loops.nodes(nodes.data(), nodes.size(), rs.data(), rs.size()));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * nodes.size() * rs.size()));
}

void BM_WideBlockTest(benchmark::State& state, KernelIsa isa, TriangleTestKind tri) {
  if (!kernel_isa_available(isa)) return state.SkipWithError("ISA not available on this CPU");
  const auto loops = find_wide_bench_loops(isa, 8, {tri, BoxTestKind::kRobust});
  const auto parts = wide_parts(wide_tree<8>(block_form_for(tri)), 256);
  const auto rs = wide_rays();
  for (auto _ : state)
    benchmark::DoNotOptimize(loops.blocks(parts.blocks.data(), parts.block_count, rs.data(), rs.size()));
  state.SetItemsProcessed(
      static_cast<int64_t>(state.iterations() * parts.block_count * kBlockWidth * rs.size()));
}

// Registers every width x box test x ISA, and every triangle test x ISA.
const bool registered = [] {
  for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kSse, KernelIsa::kAvx2, KernelIsa::kAvx512}) {
    const std::string i(to_string(isa));
    for (BoxTestKind box : {BoxTestKind::kRobust, BoxTestKind::kFast, BoxTestKind::kFma}) {
      const std::string b(to_string(box));
      benchmark::RegisterBenchmark(("node_visit/bvh4/" + i + "/" + b).c_str(), BM_WideNodeVisit<4>, isa, box);
      benchmark::RegisterBenchmark(("node_visit/bvh8/" + i + "/" + b).c_str(), BM_WideNodeVisit<8>, isa, box);
    }
    for (TriangleTestKind tri :
         {TriangleTestKind::kWatertight, TriangleTestKind::kMollerTrumbore,
          TriangleTestKind::kMollerTrumboreNoEpsilon, TriangleTestKind::kMollerTrumboreNormal})
      benchmark::RegisterBenchmark(("ray_triangle/block4/" + i + "/" + std::string(to_string(tri))).c_str(),
                                   BM_WideBlockTest, isa, tri);
  }
  return true;
}();

// The wide layouts' per-ray set-up (make_wide_rays, a block of rays at a time, as the layouts call it),
// and make_wide_ray one ray at a time for comparison: items/s = rays set up per second.
void BM_WideRaySetUp(benchmark::State& state, bool batch, bool shear, BoxTestKind box) {
  const auto& rs = rays(kRays);
  std::vector<WideRay> out(rs.size());
  for (auto _ : state) {
    if (batch) {
      benchmark::DoNotOptimize(make_wide_rays(rs, out.data(), shear, box));
    } else {
      for (std::size_t i = 0; i < rs.size(); ++i) out[i] = make_wide_ray(rs[i], shear, box);
    }
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * rs.size()));
}
BENCHMARK_CAPTURE(BM_WideRaySetUp, batch_watertight_robust, true, true, BoxTestKind::kRobust)
    ->Name("ray_setup/wide/batch/watertight,robust");
BENCHMARK_CAPTURE(BM_WideRaySetUp, one_watertight_robust, false, true, BoxTestKind::kRobust)
    ->Name("ray_setup/wide/one/watertight,robust");
BENCHMARK_CAPTURE(BM_WideRaySetUp, batch_mtn_fma, true, false, BoxTestKind::kFma)
    ->Name("ray_setup/wide/batch/mtn,fma");
BENCHMARK_CAPTURE(BM_WideRaySetUp, one_mtn_fma, false, false, BoxTestKind::kFma)
    ->Name("ray_setup/wide/one/mtn,fma");

// One bvh2 node visit: both child boxes of a common-format node in one intersect_pair, as
// BinaryWalk tests them.
void BM_Bvh2NodeVisit(benchmark::State& state) {
  const Bvh& tree = binary_tree(kPrims * 16);
  std::vector<const Node*> inner;
  for (const Node& n : tree.nodes)
    if (!n.is_leaf() && inner.size() < 256) inner.push_back(&n);
  const auto& rs = rays(kRays);
  for (auto _ : state) {
    uint32_t hits = 0;
    for (const Ray& ray : rs) {
      const RobustRayBox test(ray);
      float t_a, t_b;
      for (const Node* n : inner) {
        const unsigned mask = test.intersect_pair(
            tree.nodes[n->first].bounds, tree.nodes[n->first + 1].bounds, ray.tmin, ray.tmax, t_a, t_b);
        hits += static_cast<uint32_t>(std::popcount(mask));
      }
    }
    benchmark::DoNotOptimize(hits);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * rs.size() * inner.size()));
}
BENCHMARK(BM_Bvh2NodeVisit)->Name("node_visit/bvh2/scalar/robust");

// One bvh2_packed node visit: both child boxes of a PairNode, as traverse_packed tests them.
template <class BoxTest>
void BM_PairNodeVisit(benchmark::State& state) {
  const PackedBvh2 tree = PackedBvh2::compile(binary_tree(kPrims * 16), soup(kPrims * 16));
  const std::vector<PairNode> nodes(
      tree.nodes.begin(), tree.nodes.begin() + std::min<std::ptrdiff_t>(256, std::ssize(tree.nodes)));
  const auto& rs = rays(kRays);
  for (auto _ : state) {
    uint32_t hits = 0;
    for (const Ray& ray : rs) {
      const detail::PairSlabs<BoxTest> test(ray);
      const auto interval = detail::PairSlabs<BoxTest>::interval(ray.tmin, ray.tmax);
      float t_a, t_b, e_a, e_b;
      for (const PairNode& n : nodes)
        hits += static_cast<uint32_t>(std::popcount(test.intersect(n, interval, t_a, t_b, e_a, e_b)));
    }
    benchmark::DoNotOptimize(hits);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * rs.size() * nodes.size()));
}
BENCHMARK(BM_PairNodeVisit<RobustRayBox>)->Name("node_visit/bvh2_packed/scalar/robust");
BENCHMARK(BM_PairNodeVisit<FastRayBox>)->Name("node_visit/bvh2_packed/scalar/fast");
BENCHMARK(BM_PairNodeVisit<FmaRayBox>)->Name("node_visit/bvh2_packed/scalar/fma");

}  // namespace
}  // namespace sahbench::bench
