// The builders' passes: one binning split search, one full-sweep split search, the EPO cost, the collapse
// to 8-wide (greedy and SAH-optimal), the wide layout compile and refit, the LBVH's Morton sort and
// whole build, and the PLOC build. Items are primitives per second.

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <numeric>

#include "bench/bench_data.h"
#include "builders/binned_sah.h"
#include "builders/collapse.h"
#include "builders/lbvh.h"
#include "builders/morton.h"
#include "builders/ploc.h"
#include "builders/sweep_sah.h"
#include "core/epo.h"
#include "core/refit.h"
#include "scenes/generators.h"
#include "traversal/wide_bvh.h"

namespace sahbench::bench {
namespace {

std::vector<uint32_t> all_prims(std::size_t n) {
  std::vector<uint32_t> ids(n);
  std::iota(ids.begin(), ids.end(), 0u);
  return ids;
}

// One root split search of binned SAH (bins per axis from the argument), on a 100k soup.
void BM_BinningPass(benchmark::State& state) {
  const std::size_t n = 100'000;
  const BuildInput input = BuildInput::from_triangles(soup(n));
  const auto prims = all_prims(n);
  BinnedSahParams params;
  params.bins = static_cast<uint32_t>(state.range(0));
  params.adaptive_bins = false;
  params.top_down.size_split = false;  // the planes' binning alone, as before size splits
  for (auto _ : state) benchmark::DoNotOptimize(find_binned_split(input, prims, params));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}
BENCHMARK(BM_BinningPass)->Name("binning_pass")->Arg(8)->Arg(32)->Unit(benchmark::kMicrosecond);

// One root split search of the full sweep (sorts, then sweeps all n - 1 planes per axis).
void BM_SweepPass(benchmark::State& state) {
  const std::size_t n = 100'000;
  const BuildInput input = BuildInput::from_triangles(soup(n));
  const auto prims = all_prims(n);
  for (auto _ : state) benchmark::DoNotOptimize(find_sweep_split(input, prims, {}));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}
BENCHMARK(BM_SweepPass)->Name("sweep_pass")->Unit(benchmark::kMillisecond);

// The EPO cost (core/epo.h) of a binned SAH tree over a 100k soup: a walk of the tree per triangle.
void BM_Epo(benchmark::State& state) {
  const Bvh& tree = binary_tree(100'000);
  const auto& triangles = soup(100'000);
  for (auto _ : state) benchmark::DoNotOptimize(epo_cost(tree, triangles, SahCost{}));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * 100'000));
}
BENCHMARK(BM_Epo)->Name("epo")->Unit(benchmark::kMillisecond);

void BM_CollapseGreedy(benchmark::State& state) {
  const Bvh& tree = binary_tree(100'000);
  for (auto _ : state) benchmark::DoNotOptimize(collapse_greedy(tree, 8));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * 100'000));
}
BENCHMARK(BM_CollapseGreedy)->Name("collapse/greedy/8")->Unit(benchmark::kMillisecond);

void BM_CollapseSah(benchmark::State& state) {
  const Bvh& tree = binary_tree(100'000);
  for (auto _ : state) benchmark::DoNotOptimize(collapse_sah(tree, 8, {}, 8));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * 100'000));
}
BENCHMARK(BM_CollapseSah)->Name("collapse/sah/8")->Unit(benchmark::kMillisecond);

void BM_CompileWide8(benchmark::State& state) {
  const Bvh wide = collapse_greedy(binary_tree(100'000), 8);
  for (auto _ : state) benchmark::DoNotOptimize(compile_wide<8>(wide, soup(100'000)));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * 100'000));
}
BENCHMARK(BM_CompileWide8)->Name("layout_compile/bvh8")->Unit(benchmark::kMillisecond);

void BM_RefitWide8(benchmark::State& state) {
  auto layout = compile_wide<8>(collapse_greedy(binary_tree(100'000), 8), soup(100'000));
  for (auto _ : state) {
    refit_wide(layout, soup(100'000));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * 100'000));
}
BENCHMARK(BM_RefitWide8)->Name("refit/bvh8")->Unit(benchmark::kMillisecond);

// The common-format refit of the same 8-wide tree, which the bvh8 layout refit above follows in a run.
void BM_RefitTree8(benchmark::State& state) {
  Bvh tree = collapse_greedy(binary_tree(100'000), 8);
  for (auto _ : state) {
    refit(tree, soup(100'000));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * 100'000));
}
BENCHMARK(BM_RefitTree8)->Name("refit/tree8")->Unit(benchmark::kMillisecond);

// A mesh's triangles in their file order, as the LBVH meets them: a 100k-triangle terrain, whose
// neighbouring triangles are neighbours in space (a soup's codes would come in random order).
const BuildInput& terrain_input() {
  static const std::vector<Triangle> tris = generate_terrain(100'000, 1, 6);
  static const BuildInput input = BuildInput::from_triangles(tris);
  return input;
}

// Times `step` on the terrain's boxes with the benchmark's argument as the number of threads.
template <class Step>
void on_terrain(benchmark::State& state, Step step) {
  const tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(state.range(0)));
  const BuildInput& input = terrain_input();
  for (auto _ : state) benchmark::DoNotOptimize(step(input));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * input.size()));
}

// The Morton codes of the terrain's centres, sorted with their primitives (builders/morton.h).
void BM_MortonSort(benchmark::State& state) {
  on_terrain(state, [](const BuildInput& input) { return sort_by_morton<uint32_t>(input.bounds.span()); });
}
BENCHMARK(BM_MortonSort)->Name("morton_sort/30")->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

// The whole LBVH build of the terrain at its defaults, from the primitives' boxes.
void BM_Lbvh(benchmark::State& state) {
  on_terrain(state, [](const BuildInput& input) { return build_lbvh(input, {}); });
}
BENCHMARK(BM_Lbvh)->Name("lbvh")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// The whole PLOC build of the same terrain at its defaults (radius 16).
void BM_Ploc(benchmark::State& state) {
  on_terrain(state, [](const BuildInput& input) { return build_ploc(input, {}); });
}
BENCHMARK(BM_Ploc)->Name("ploc")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace sahbench::bench
