#include <gtest/gtest.h>

#include <algorithm>

#include "builders/registry.h"
#include "core/build_input.h"
#include "core/bvh_stats.h"
#include "core/error.h"
#include "tests/support/test_scenes.h"

namespace sahbench {
namespace {

// Runs `f`, expecting sahbench::Error whose message contains every fragment.
template <class F>
void expect_error(F&& f, std::initializer_list<std::string> fragments) {
  try {
    f();
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    for (const auto& fragment : fragments)
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what() << " lacks " << fragment;
  }
}

// binned_sah's sah_block reaches its build: costed per block of four, as a wide collapse will test its
// leaves, the tree has fewer, fuller leaves and a lower SAH in those costs than the tree costed per
// primitive.
TEST(BuilderRegistry, BinnedSahCostsLeavesPerBlock) {
  const BuildInput input = BuildInput::from_triangles(test::random_triangles(4000, 21));
  const BuilderInfo& info = find_builder("binned_sah");
  const Bvh per_prim = info.build(input, resolve_params(info.name, info.params, {}));
  const Bvh per_block = info.build(input, resolve_params(info.name, info.params, {{"sah_block", "4"}}));
  auto leaves = [](const Bvh& bvh) {
    return std::count_if(bvh.nodes.begin(), bvh.nodes.end(), [](const Node& n) { return n.is_leaf(); });
  };
  EXPECT_LT(leaves(per_block), leaves(per_prim));
  SahCost block4;
  block4.block = 4;
  EXPECT_LT(sah_cost(per_block, block4), sah_cost(per_prim, block4));
  expect_error(
      [&] {
        info.check(resolve_params(info.name, info.params, {{"sah_block", "3"}}));
      },
      {"binned_sah: sah_block = 3 must be a power of two up to 16"});
}

TEST(BuilderRegistry, KnowsBinnedAndSweep) {
  EXPECT_EQ(find_builder("binned_sah").name, "binned_sah");
  EXPECT_EQ(find_builder("sweep_sah").name, "sweep_sah");
  expect_error([] { find_builder("binned"); }, {"unknown builder 'binned'", "binned_sah", "sweep_sah"});
}

TEST(BuilderRegistry, DefaultsAppearInCsvForm) {
  const auto& info = find_builder("binned_sah");
  EXPECT_EQ(resolve_params(info.name, info.params, {}).to_string(),
            "bins=32;adaptive_bins=1;min_leaf=1;max_leaf=8;c_trav=1;c_isect=1;size_split=1;sah_block=1");
  EXPECT_EQ(resolve_params(info.name, info.params, {{"bins", "16"}, {"c_trav", "0.5"}}).to_string(),
            "bins=16;adaptive_bins=1;min_leaf=1;max_leaf=8;c_trav=0.5;c_isect=1;size_split=1;sah_block=1");
}

TEST(BuilderRegistry, BottomUpAndPresplitDefaultsAppearInCsvForm) {
  auto defaults = [](const char* name) {
    const auto& info = find_builder(name);
    return resolve_params(info.name, info.params, {}).to_string();
  };
  EXPECT_EQ(defaults("lbvh"), "bits=30;hierarchy=apetrei;min_leaf=1;max_leaf=8;c_trav=1;c_isect=1");
  EXPECT_EQ(defaults("ploc"), "radius=16;bits=30;min_leaf=1;max_leaf=8;c_trav=1;c_isect=1");
  EXPECT_EQ(defaults("presplit"),
            "split_budget=0.3;bins=32;adaptive_bins=1;min_leaf=1;max_leaf=8;c_trav=1;c_isect=1;size_split=0");
  const auto& lbvh = find_builder("lbvh");
  expect_error(
      [&] {
        resolve_params(lbvh.name, lbvh.params, {{"bits", "32"}});
      },
      {"lbvh", "'bits' = '32'", "not one of 30, 63"});
  const auto& ploc = find_builder("ploc");
  expect_error(
      [&] {
        resolve_params(ploc.name, ploc.params, {{"radius", "0"}});
      },
      {"ploc", "'radius' = '0'", "outside [1, 256]"});
  const auto& presplit = find_builder("presplit");
  expect_error(
      [&] {
        resolve_params(presplit.name, presplit.params, {{"split_budget", "9"}});
      },
      {"presplit", "'split_budget' = '9'", "outside [0, 4]"});
}

TEST(BuilderRegistry, BadParametersAreErrorsThatNameThem) {
  const auto& info = find_builder("binned_sah");
  auto resolve = [&](ParamOverrides o) { return [&info, o] { resolve_params(info.name, info.params, o); }; };
  expect_error(resolve({{"binz", "8"}}), {"binned_sah", "unknown parameter 'binz'", "bins"});
  expect_error(resolve({{"bins", "abc"}}), {"'bins' = 'abc'", "not a number"});
  expect_error(resolve({{"bins", "8.5"}}), {"not an integer"});
  expect_error(resolve({{"bins", "1000"}}), {"'bins' = '1000'", "outside [4, 256]"});
  expect_error(resolve({{"bins", "3"}}), {"outside"});
  expect_error(resolve({{"bins", ""}}), {"not a number"});
  expect_error(resolve({{"bins", "8"}, {"bins", "16"}}), {"given twice"});
  expect_error(resolve({{"c_isect", "nan"}}), {"not a number"});
  expect_error(resolve({{"sweep_only", "1"}}), {"unknown parameter"});
  expect_error([] { parse_override("bins"); }, {"'bins'", "key=value"});
  EXPECT_EQ(parse_override("bins=8"), (std::pair<std::string, std::string>{"bins", "8"}));
}

TEST(BuilderRegistry, InconsistentLeafSizesAreRejectedAtBuild) {
  const auto& info = find_builder("binned_sah");
  const auto params = resolve_params(info.name, info.params, {{"min_leaf", "8"}, {"max_leaf", "4"}});
  const std::vector<Triangle> tris{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}};
  expect_error([&] { info.build(BuildInput::from_triangles(tris), params); },
               {"max_leaf = 4", "below min_leaf = 8"});
}

}  // namespace
}  // namespace sahbench

namespace sahbench {
namespace {

ParamSet resolve_named(const std::string& name, const ParamOverrides& overrides) {
  const BuilderInfo& info = find_builder(name);
  return resolve_params(info.name, info.params, overrides);
}

TEST(SourceChain, SharedSourcesKeepTheirTextAndOwnSourcesRecordTheChain) {
  // wide_collapse's sources named alone share its parameters and are written by name, as before chains.
  EXPECT_EQ(resolve_named("wide_collapse", {}).to_string(),
            "arity=8;method=sah;source=binned_sah;source_c_trav_scale=0.0625;reinsert_iterations=8;bins=32;"
            "adaptive_bins=1;min_leaf=1;max_leaf=8;c_trav=3;c_isect=1;size_split=1;sah_block=4");
  EXPECT_TRUE(resolve_named("wide_collapse", {{"source", "sbvh"}}).get_source("source").shared());
  // Any source with a parameter of its own, and any other source, is written with all of its values,
  // and the collapse without the parameters it applies only to its own binary build.
  const ParamSet chain = resolve_named("wide_collapse", {{"source", "reinsert"},
                                                         {"source.iterations", "2"},
                                                         {"source.source", "binned_sah"},
                                                         {"source.source.max_leaf", "4"}});
  EXPECT_EQ(chain.to_string(),
            "arity=8;method=sah;source=reinsert(source=binned_sah(bins=32;adaptive_bins=1;min_leaf=1;"
            "max_leaf=4;c_trav=1;c_isect=1;size_split=1;sah_block=1);iterations=2;batch=0.05;min_gain=0.001;"
            "c_trav=1;"
            "c_isect=1);max_leaf=8;c_trav=3;c_isect=1;sah_block=4");
  const SourceSpec& reinsert = chain.get_source("source");
  ASSERT_FALSE(reinsert.shared());
  EXPECT_EQ(reinsert.name(), "reinsert");
  EXPECT_EQ(reinsert.params->get_uint("iterations"), 2u);
  EXPECT_EQ(reinsert.params->get_source("source").params->get_uint("max_leaf"), 4u);
  EXPECT_FALSE(resolve_named("wide_collapse", {{"source.bins", "32"}}).get_source("source").shared());
  // A pass's default source is built with its own defaults.
  EXPECT_EQ(resolve_named("treelet", {}).to_string(),
            "source=binned_sah(bins=32;adaptive_bins=1;min_leaf=1;max_leaf=8;c_trav=1;c_isect=1;size_split=1;"
            "sah_block=1);"
            "treelet_size=7;iterations=3;c_trav=1;c_isect=1");
}

TEST(SourceChain, OwnSourceBuildsTheSourceWithItsParameters) {
  const auto tris = test::random_triangles(4000, 9);
  const BuildInput input = BuildInput::from_triangles(tris);
  const ParamSet p = resolve_named("reinsert", {{"source", "sweep_sah"}, {"source.max_leaf", "2"}});
  const BuilderInfo& sweep = find_builder("sweep_sah");
  EXPECT_TRUE(build_source(input, p) ==
              sweep.build(input, resolve_params(sweep.name, sweep.params, {{"max_leaf", "2"}})));
  expect_error([&] { build_source(input, resolve_named("wide_collapse", {})); }, {"shares"});
}

TEST(SourceChain, BadChainsAreErrorsThatNameThem) {
  auto resolve = [](ParamOverrides o) { return [o] { resolve_named("wide_collapse", o); }; };
  expect_error(resolve({{"source", "binned"}}), {"wide_collapse", "'source'", "unknown builder 'binned'"});
  expect_error(resolve({{"source", "reinsert"}, {"source.iteratons", "2"}}),
               {"wide_collapse.source=reinsert", "unknown parameter 'iteratons'", "iterations"});
  expect_error(resolve({{"source", "reinsert"}, {"source.source", "sweep"}}),
               {"wide_collapse.source=reinsert", "unknown builder 'sweep'"});
  expect_error(resolve({{"source", "reinsert"}, {"source.source.bins", "2"}}),
               {"wide_collapse.source=reinsert.source=binned_sah", "'bins' = '2'", "outside"});
  expect_error(resolve({{"bins.x", "2"}}), {"'bins' is not a tree source", "'bins.x'"});
  expect_error(resolve({{"source", "wide_binned_sah"}}),
               {"wide_collapse.source=wide_binned_sah", "8-wide", "binary"});
  expect_error(resolve({{"source", "reinsert"}, {"source.iterations", "2"}, {"source.iterations", "3"}}),
               {"'iterations' is given twice"});
  // A nested source's own combination check runs where it is resolved.
  expect_error(resolve({{"source", "binned_sah"}, {"source.min_leaf", "8"}, {"source.max_leaf", "4"}}),
               {"max_leaf = 4", "below min_leaf = 8"});
  // Parameters wide_collapse passes on to a shared source, set for a source with parameters of its own.
  const BuilderInfo& collapse = find_builder("wide_collapse");
  expect_error(
      [&] {
        collapse.check(resolve_named("wide_collapse", {{"source", "treelet"}, {"bins", "8"}}));
      },
      {"bins applies only to the collapse's own build of a source named alone (binned_sah, sbvh)",
       "source=treelet has no such parameter"});
  expect_error(
      [&] {
        collapse.check(resolve_named("wide_collapse",
                                     {{"source", "binned_sah"}, {"source.max_leaf", "8"}, {"bins", "8"}}));
      },
      {"not to source=binned_sah", "give it to the source (source.bins=...)"});
  collapse.check(resolve_named("wide_collapse", {{"source", "treelet"}, {"max_leaf", "4"}}));
  // A binary wide builder is a fine source.
  EXPECT_EQ(resolve_named("reinsert", {{"source", "wide_binned_sah"}, {"source.arity", "2"}})
                .get_source("source")
                .name(),
            "wide_binned_sah");
}

}  // namespace
}  // namespace sahbench
