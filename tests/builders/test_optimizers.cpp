// The passes that lower a built tree's SAH (reinsert, treelet): never above the source's SAH, on random,
// adversarial, extreme-scale and real scenes and over every kind of source; the same leaves as the
// source (they change only the topology above them); lower SAH where there is room; and refit of their
// trees. Their hits against brute force, validity and thread-count determinism are in the shared suites.

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "builders/registry.h"
#include "builders/reinsert.h"
#include "builders/treelet.h"
#include "core/bvh_stats.h"
#include "core/error.h"
#include "core/refit.h"
#include "core/validate.h"
#include "scenes/load.h"
#include "scenes/wave.h"
#include "tests/builders/builder_cases.h"
#include "tests/support/prerequisites.h"

namespace sahbench {
namespace {

struct PassCase {
  std::string label;
  ParamOverrides overrides;  // of the pass; its source's under "source."
};

// Each pass over each kind of source: binned and full-sweep SAH, spatial splits, single-primitive leaves,
// and wider treelets.
std::vector<PassCase> pass_cases() {
  std::vector<PassCase> out;
  for (const char* pass : {"reinsert", "treelet"}) {
    for (const char* source : {"binned_sah", "sweep_sah", "sbvh"})
      out.push_back({std::string(pass) + " over " + source, {{"source", source}}});
    out.push_back({std::string(pass) + " over binned_sah max_leaf=1", {{"source.max_leaf", "1"}}});
  }
  out.push_back({"reinsert batch=1", {{"batch", "1"}, {"iterations", "3"}}});
  out.push_back({"treelet treelet_size=9", {{"treelet_size", "9"}, {"iterations", "2"}}});
  return out;
}

std::string pass_of(const PassCase& c) {
  return c.label.substr(0, c.label.find(' '));
}

// The source's tree and the pass's, with the pass's SAH constants for both.
struct Trees {
  Bvh source, pass;
  SahCost cost;
};

Trees build_both(const PassCase& c, std::span<const Triangle> triangles) {
  const BuilderInfo& info = find_builder(pass_of(c));
  const ParamSet params = resolve_params(info.name, info.params, c.overrides);
  const BuildInput input = BuildInput::from_triangles(triangles);
  return {build_source(input, params), info.build(input, params), sah_cost_of(params)};
}

// Each leaf's references, sorted, counted: the same for two trees with the same leaves in any topology.
std::map<std::vector<uint32_t>, int> leaf_sets(const Bvh& bvh) {
  std::map<std::vector<uint32_t>, int> out;
  for (const Node& n : bvh.nodes) {
    if (!n.is_leaf()) continue;
    std::vector<uint32_t> refs(bvh.prim_refs.begin() + n.first,
                               bvh.prim_refs.begin() + n.first + n.prim_count);
    std::sort(refs.begin(), refs.end());
    ++out[refs];
  }
  return out;
}

void expect_never_above_source(const PassCase& c, const std::string& scene, std::span<const Triangle> tris) {
  SCOPED_TRACE(c.label + " on " + scene);
  const Trees t = build_both(c, tris);
  ASSERT_TRUE(validate(t.pass, tris).ok());
  EXPECT_LE(sah_cost(t.pass, t.cost), sah_cost(t.source, t.cost));
  EXPECT_EQ(leaf_sets(t.pass), leaf_sets(t.source));
  EXPECT_LE(compute_stats(t.pass, tris.size(), t.cost).max_depth, kMaxDepth);
}

TEST(Optimizers, SahNeverRisesOnRandomAndAdversarialScenes) {
  for (const test::SceneCase& scene : test::scene_cases())
    for (const PassCase& c : pass_cases()) {
      // The SBVH clips every reference of the largest soup at every node: most of the suite's time for
      // nothing the smaller soups do not show.
      if (c.label.ends_with("sbvh") && scene.triangles.size() > 50000) continue;
      expect_never_above_source(c, scene.name, scene.triangles);
    }
}

TEST(Optimizers, SahNeverRisesAtExtremeScales) {
  // Areas of 1e60 and 1e-50: beyond float, within the double sums the passes and statistics use.
  for (float scale : {1e30f, 1e-25f}) {
    auto tris = test::random_triangles(5000, 8);
    for (auto& t : tris) t = {t.v0 * scale, t.v1 * scale, t.v2 * scale};
    const std::string scene = "random at scale " + std::to_string(scale);
    for (const PassCase& c : pass_cases()) expect_never_above_source(c, scene, tris);
    // The sources' float areas overflow or vanish there, so they split by count; the passes, in double,
    // still find gains (reinsert below the largest nodes, which a split by count leaves no better place).
    for (const PassCase& c : {PassCase{"treelet", {}}, PassCase{"reinsert batch=1", {{"batch", "1"}}}}) {
      const Trees t = build_both(c, tris);
      EXPECT_LT(sah_cost(t.pass, t.cost), sah_cost(t.source, t.cost)) << c.label << " on " << scene;
    }
  }
}

TEST(Optimizers, SahDropsOnRandomScenes) {
  const auto tris = test::random_triangles(20000, 21);
  for (const PassCase& c : pass_cases()) {
    const Trees t = build_both(c, tris);
    EXPECT_LT(sah_cost(t.pass, t.cost), sah_cost(t.source, t.cost)) << c.label;
  }
}

TEST(Optimizers, SahNeverRisesOnRealScenes) {
  test::Skips skips;
  for (const char* name : {"stanford_bunny", "crytek_sponza"}) {
    if (!skips.have_scene(name)) continue;
    const Scene scene = load_scene(name);
    for (const char* pass : {"reinsert", "treelet"}) {
      const PassCase c{std::string(pass) + " over binned_sah", {}};
      SCOPED_TRACE(c.label + " on " + name);
      const Trees t = build_both(c, scene.triangles);
      ASSERT_TRUE(validate(t.pass, std::span<const Triangle>(scene.triangles)).ok());
      const double before = sah_cost(t.source, t.cost), after = sah_cost(t.pass, t.cost);
      EXPECT_LT(after, before) << before << " -> " << after;
      EXPECT_EQ(leaf_sets(t.pass), leaf_sets(t.source));
    }
  }
  SAHBENCH_REPORT_SKIPS(skips);
}

TEST(Optimizers, NoIterationsGiveTheSourceTree) {
  const auto tris = test::random_triangles(3000, 4);
  for (const char* pass : {"reinsert", "treelet"}) {
    const Trees t = build_both({pass, {{"iterations", "0"}}}, tris);
    EXPECT_TRUE(t.pass == t.source) << pass;
  }
}

TEST(Optimizers, ReinsertStopsOnceARoundGainsLittle) {
  // min_gain ends the search after the first round whose moves, found, would lower the inner area by less
  // than that share: at 0.5 a round of this scene's search qualifies (it finds a fraction of a percent),
  // so the first is the last; at 0 every round that gains at all is run. Long thin triangles in every
  // orientation leave the binned tree overlap that later rounds still find.
  const Scene scene = load_scene("proc:needles:tris=20000");
  const BuilderInfo& binned = find_builder("binned_sah");
  const Bvh source = binned.build(BuildInput::from_triangles(scene.triangles),
                                  resolve_params(binned.name, binned.params, {}));
  const SahCost cost;
  ReinsertParams one, converged, exhaustive;
  one.iterations = 1;
  one.min_gain = 0.0;
  converged.iterations = 8;
  converged.min_gain = 0.5;
  exhaustive.iterations = 8;
  exhaustive.min_gain = 0.0;
  const Bvh after_one = reinsert(source, one);
  EXPECT_LT(sah_cost(after_one, cost), sah_cost(source, cost));
  EXPECT_TRUE(reinsert(source, converged) == after_one);
  EXPECT_LT(sah_cost(reinsert(source, exhaustive), cost), sah_cost(after_one, cost));
  for (double bad : {-0.1, 0.6}) {
    ReinsertParams p;
    p.min_gain = bad;
    EXPECT_THROW(reinsert(source, p), Error) << bad;
  }
}

TEST(Optimizers, RefuseWideTreesAndBadSizes) {
  const auto tris = test::random_triangles(500, 4);
  const BuilderInfo& wide = find_builder("wide_binned_sah");
  const Bvh tree = wide.build(BuildInput::from_triangles(tris), resolve_params(wide.name, wide.params, {}));
  EXPECT_THROW(reinsert(tree, {}), Error);
  EXPECT_THROW(restructure_treelets(tree, {}), Error);
  const BuilderInfo& binned = find_builder("binned_sah");
  const Bvh binary =
      binned.build(BuildInput::from_triangles(tris), resolve_params(binned.name, binned.params, {}));
  TreeletParams wide_treelets;
  wide_treelets.treelet_size = kMaxTreeletSize + 1;
  EXPECT_THROW(restructure_treelets(binary, wide_treelets), Error);
  ReinsertParams no_batch;
  no_batch.batch = 0.0;
  EXPECT_THROW(reinsert(binary, no_batch), Error);
}

TEST(Optimizers, RefitKeepsThePassesTreesExactAndValid) {
  const WaveParams wave{3000, 5, 0.15, 4};
  const std::vector<Triangle> first = generate_wave(wave, 0.0), moved = generate_wave(wave, 0.6);
  for (const ParamOverrides& o : std::vector<ParamOverrides>{
           {}, {{"source", "reinsert"}}, {{"source", "treelet"}, {"source.source", "reinsert"}}}) {
    const BuilderInfo& info = find_builder("wide_collapse");
    const ParamSet params = resolve_params(info.name, info.params, o);
    Bvh bvh = info.build(BuildInput::from_triangles(first), params);
    SCOPED_TRACE(params.to_string());
    ASSERT_FALSE(validate(bvh, std::span<const Triangle>(moved)).ok());
    refit(bvh, moved);
    const ValidationReport report = validate(bvh, std::span<const Triangle>(moved));
    EXPECT_TRUE(report.ok()) << report.summary();
    // Every box the exact union of what it holds, as refit promises for any tree without repeats.
    for (const Node& n : bvh.nodes) {
      Aabb box;
      if (n.is_leaf())
        for (uint32_t k = 0; k < n.prim_count; ++k) box.extend(moved[bvh.prim_refs[n.first + k]].bounds());
      else
        for (uint32_t c = 0; c < n.child_count; ++c) box.extend(bvh.nodes[n.first + c].bounds);
      ASSERT_EQ(n.bounds, box);
    }
  }
}

}  // namespace
}  // namespace sahbench
