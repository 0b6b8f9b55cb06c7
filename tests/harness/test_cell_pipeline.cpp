// The cell pipeline (harness/run/cell_pipeline.h) on its own: tree sources timed in warm-ups and
// shuffled rounds, a broken tree refused before its statistics are computed, and cells of ours and of
// Embree traced, counted and checked against brute force.

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "builders/registry.h"
#include "harness/run/cell_pipeline.h"
#include "harness/run/round_order.h"
#include "scenes/scene.h"
#include "tests/support/test_scenes.h"

namespace sahbench {
namespace {

// A source that records which of `n` sources made a tree when, and whether it was released first.
struct Recorder {
  std::vector<int> order;  // source index of every make, warm-ups included
  std::vector<bool> released_before;
};

std::vector<TreeSource> recording_sources(Recorder& rec, int n) {
  std::vector<TreeSource> sources(static_cast<std::size_t>(n));
  auto released = std::make_shared<std::vector<bool>>(static_cast<std::size_t>(n), false);
  for (int i = 0; i < n; ++i) {
    sources[static_cast<std::size_t>(i)].release = [released, i] {
      (*released)[static_cast<std::size_t>(i)] = true;
    };
    sources[static_cast<std::size_t>(i)].make = [&rec, released, i] {
      rec.order.push_back(i);
      rec.released_before.push_back((*released)[static_cast<std::size_t>(i)]);
      (*released)[static_cast<std::size_t>(i)] = false;
      return 1.0 + i;
    };
  }
  return sources;
}

TEST(CellPipeline, SourcesAreWarmedThenTimedInAShuffledRoundEach) {
  Recorder rec;
  std::vector<TreeSource> sources = recording_sources(rec, 4);
  std::vector<TreeSource*> ptrs;
  for (auto& s : sources) ptrs.push_back(&s);
  Repetitions reps;
  reps.build_warmup = 2;
  reps.build = 5;
  int checks = 0;
  time_sources(ptrs, reps, 42, [&] { ++checks; });
  EXPECT_EQ(checks, 4 * 5);  // before every timed make, not the warm-ups
  ASSERT_EQ(rec.order.size(), 4u * 7u);
  // Warm-ups: every source in turn, twice.
  for (int w = 0; w < 8; ++w) EXPECT_EQ(rec.order[static_cast<std::size_t>(w)], w % 4);
  // Then round r in round_order(seed, 4, r), each make after freeing the last.
  for (int r = 0; r < 5; ++r) {
    const auto expected = round_order(42, 4, r);
    for (std::size_t k = 0; k < 4; ++k) {
      const std::size_t at = 8 + static_cast<std::size_t>(r) * 4 + k;
      EXPECT_EQ(rec.order[at], static_cast<int>(expected[k])) << "round " << r;
      EXPECT_TRUE(rec.released_before[at]);
    }
  }
  for (int i = 0; i < 4; ++i) {
    const TreeSource& s = sources[static_cast<std::size_t>(i)];
    ASSERT_EQ(s.ms.size(), 5u);
    EXPECT_DOUBLE_EQ(s.time().median, 1.0 + i);  // the make's own clock, not the harness's
  }
}

TEST(CellPipeline, SourcesRunBackToBackWithoutInterleaving) {
  Recorder rec;
  std::vector<TreeSource> sources = recording_sources(rec, 3);
  std::vector<TreeSource*> ptrs;
  for (auto& s : sources) ptrs.push_back(&s);
  Repetitions reps;
  reps.build_warmup = 1;
  reps.build = 2;
  reps.interleave = false;
  time_sources(ptrs, reps, 7, [] {});
  // Each source's warm-up right before its own timed makes.
  EXPECT_EQ(rec.order, (std::vector<int>{0, 0, 0, 1, 1, 1, 2, 2, 2}));
}

TEST(CellPipeline, ABrokenTreeIsRefusedBeforeItsStatistics) {
  const std::vector<Triangle> triangles = test::random_triangles(64, 3);
  const BuilderInfo& builder = find_builder("binned_sah");
  const ParamSet params = resolve_params(builder.name, builder.params, {});
  Bvh bvh = builder.build(BuildInput::from_triangles(triangles), params);
  ASSERT_TRUE(check_tree(bvh, triangles, params, false).ok());
  EXPECT_GT(check_tree(bvh, triangles, params, false).stats.sah_cost, 0.0);
  // A child index far out of range: compute_stats would read past nodes[].
  for (Node& n : bvh.nodes)
    if (!n.is_leaf()) {
      n.first = 1u << 30;
      break;
    }
  const CheckedTree broken = check_tree(bvh, triangles, params, false);
  EXPECT_FALSE(broken.ok());
  EXPECT_EQ(broken.stats.sah_cost, 0.0);
  CsvRow row;
  put_invalid_tree(row, bvh, broken.report);
  EXPECT_NE(row["notes"].find("invalid tree, not traced"), std::string::npos);
}

TEST(CellPipeline, CellsOfOursAndEmbreeAreTimedCountedAndChecked) {
  Scene scene;
  scene.name = "random";
  scene.triangles = test::random_triangles(300, 5);
  RaySet closest{"random", RayKind::kRandom, false, test::random_rays(scene.triangles, 500, 6)};
  RaySet any{"random_any", RayKind::kRandom, true, closest.rays};
  const std::vector<const RaySet*> sets = {&closest, &any};
  std::vector<Reference> refs;
  for (const RaySet* rs : sets) refs.push_back(make_reference(scene, *rs, ReferencePolicy::kBruteForce, 0));

  const BuilderInfo& builder = find_builder("binned_sah");
  auto tree = std::make_shared<Bvh>();
  TreeSource ours =
      our_build("ours", builder, resolve_params(builder.name, builder.params, {}), scene.triangles, tree);
  auto embree = std::make_shared<EmbreeBuild>(1);
  TreeSource theirs = embree_build("embree", embree, scene.triangles, EmbreeQuality::kMedium);
  std::vector<TreeSource*> sources = {&ours, &theirs};
  Repetitions reps;
  reps.build = 2;
  reps.trace = 3;
  time_sources(sources, reps, 1, [] {});
  EXPECT_EQ(ours.ms.size(), 2u);
  EXPECT_EQ(theirs.ms.size(), 2u);

  std::shared_ptr<const CompiledLayout> layout =
      compile_layout(parse_layout_spec("bvh2"), *tree, scene.triangles);
  std::vector<TraceCell> cells;
  for (std::size_t s = 0; s < sets.size(); ++s) {
    cells.push_back(our_cell({}, "ours", layout, *sets[s], s, SahCost{}));
    cells.push_back(embree_cell({}, "embree", *embree->scene, kEmbreeLayouts[0], *sets[s], s, embree));
  }
  int rounds = 0;
  time_cells(
      cells, reps, 9, [] {}, [&](int) { ++rounds; });
  EXPECT_EQ(rounds, 3);
  for (auto& cell : cells) {
    ASSERT_EQ(cell.mrays.size(), 3u) << cell.label;
    finish_cell(cell, refs[cell.set_index], 1.0f);
    EXPECT_EQ(cell.row["mismatches"], "0") << cell.label << " " << cell.set->name;
    EXPECT_EQ(cell.row["reference"], "brute_force");
    EXPECT_FALSE(cell.row["hit_fraction"].empty());
    EXPECT_EQ(cell.row["ray_set"], cell.set->name);
    // Only our kernels count nodes and primitives.
    EXPECT_EQ(cell.row["nodes_per_ray"].empty(), cell.label == "embree");
  }
}

}  // namespace
}  // namespace sahbench
