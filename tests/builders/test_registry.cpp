#include <gtest/gtest.h>

#include "builders/registry.h"
#include "core/error.h"

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

TEST(BuilderRegistry, KnowsBinnedAndSweep) {
  EXPECT_EQ(find_builder("binned_sah").name, "binned_sah");
  EXPECT_EQ(find_builder("sweep_sah").name, "sweep_sah");
  expect_error([] { find_builder("binned"); }, {"unknown builder 'binned'", "binned_sah", "sweep_sah"});
}

TEST(BuilderRegistry, DefaultsAppearInCsvForm) {
  const auto& info = find_builder("binned_sah");
  EXPECT_EQ(resolve_params(info.name, info.params, {}).to_string(),
            "bins=32;adaptive_bins=1;min_leaf=1;max_leaf=8;c_trav=1;c_isect=1");
  EXPECT_EQ(resolve_params(info.name, info.params, {{"bins", "16"}, {"c_trav", "0.5"}}).to_string(),
            "bins=16;adaptive_bins=1;min_leaf=1;max_leaf=8;c_trav=0.5;c_isect=1");
}

TEST(BuilderRegistry, BottomUpAndPresplitDefaultsAppearInCsvForm) {
  auto defaults = [](const char* name) {
    const auto& info = find_builder(name);
    return resolve_params(info.name, info.params, {}).to_string();
  };
  EXPECT_EQ(defaults("lbvh"), "bits=30;hierarchy=karras;min_leaf=1;max_leaf=8;c_trav=1;c_isect=1");
  EXPECT_EQ(defaults("ploc"), "radius=16;bits=30;min_leaf=1;max_leaf=8;c_trav=1;c_isect=1");
  EXPECT_EQ(defaults("presplit"),
            "split_budget=0.3;bins=32;adaptive_bins=1;min_leaf=1;max_leaf=8;c_trav=1;c_isect=1");
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
