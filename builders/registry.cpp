#include "builders/registry.h"

#include <algorithm>

#include "builders/binned_sah.h"
#include "builders/collapse.h"
#include "builders/sweep_sah.h"
#include "core/error.h"

namespace sahbench {
namespace {

// Parameters every top-down SAH builder takes. Defaults: leaves of up to 8 primitives where the SAH
// prefers them (the usual choice for BVH2 with triangle leaves, e.g. Embree's and pbrt's defaults of 8
// and 255 bound it from above; 8 keeps leaves cheap to test); SAH constants from core/sah.h.
std::vector<ParamSpec> top_down_params() {
  const SahCost defaults;
  const TopDownConfig config;
  return {
      {"min_leaf", ParamType::kInt, double(config.min_leaf), 1, kMaxLeafPrims,
       "nodes with this many primitives or fewer become leaves"},
      {"max_leaf", ParamType::kInt, double(config.max_leaf), 1, kMaxLeafPrims,
       "nodes with more primitives are always split"},
      {"c_trav", ParamType::kFloat, defaults.c_trav, 0, 1e6, "SAH cost of visiting an inner node"},
      {"c_isect", ParamType::kFloat, defaults.c_isect, 1e-6, 1e6, "SAH cost of one ray/triangle test"},
  };
}

TopDownConfig top_down_config(const ParamSet& p) {
  return {p.get_uint("min_leaf"), p.get_uint("max_leaf"), sah_cost_of(p)};
}

std::vector<ParamSpec> binned_params() {
  auto params = top_down_params();
  const BinnedSahParams defaults;
  params.insert(params.begin(), {{"bins", ParamType::kInt, double(defaults.bins), kMinBins, kMaxBins,
                                  "centroid bins per axis"},
                                 {"adaptive_bins", ParamType::kInt, double(defaults.adaptive_bins), 0, 1,
                                  "1: min(bins, 4 + n/20) bins on a node of n primitives (Embree's rule)"}});
  return params;
}

BinnedSahParams binned_config(const ParamSet& p) {
  return {p.get_uint("bins"), p.get_uint("adaptive_bins") != 0, top_down_config(p)};
}

// Wide trees: 8 children by default, the width of an AVX2 node (Embree's BVH8).
constexpr uint32_t kDefaultWideArity = 8;

ParamSpec arity_param() {
  return {"arity", ParamType::kInt, double(kDefaultWideArity), 2, kMaxArity, "children per inner node: 2, 4 or 8"};
}

uint32_t arity_of(const ParamSet& p) { return p.get_uint("arity"); }

BuilderInfo binned_sah_info() {
  return {"binned_sah", "binned SAH (Wald 2007), parallel binning and partitioning", binned_params(),
          [](const BuildInput& input, const ParamSet& p) { return build_binned_sah(input, binned_config(p)); },
          [](const ParamSet& p) { check_config(top_down_config(p), "binned_sah"); }};
}

BuilderInfo wide_binned_sah_info() {
  auto params = binned_params();
  params.insert(params.begin(), arity_param());
  auto config = [](const ParamSet& p) {
    BinnedSahParams c = binned_config(p);
    c.top_down.arity = arity_of(p);
    return c;
  };
  return {"wide_binned_sah",
          "binned SAH building wide nodes directly: the child of largest area is split until `arity` "
          "children (Wald et al. 2008; Embree's BVHN builder)",
          std::move(params), [config](const BuildInput& input, const ParamSet& p) { return build_binned_sah(input, config(p)); },
          [config](const ParamSet& p) { check_config(config(p).top_down, "wide_binned_sah"); }, arity_of};
}

BuilderInfo wide_collapse_info() {
  auto params = binned_params();
  params.insert(params.begin(),
                {arity_param(),
                 choice_param("method", {"sah", "greedy"}, 0,
                              "sah: SAH-optimal collapse (Ylitie et al. 2017); greedy: open the largest child"),
                 choice_param("source", {"binned_sah", "sweep_sah"}, 0,
                              "the binary builder whose tree is collapsed (with the bins and leaf parameters here); "
                              "method=sah may merge a subtree of up to max_leaf references into one leaf")});
  return {"wide_collapse",
          "a binary SAH tree collapsed to `arity` children per node; build time includes the binary build",
          std::move(params),
          [](const BuildInput& input, const ParamSet& p) {
            const BinnedSahParams binary = binned_config(p);
            const Bvh tree = p.get_choice("source") == "sweep_sah" ? build_sweep_sah(input, {binary.top_down})
                                                                   : build_binned_sah(input, binary);
            if (p.get_choice("method") == "greedy") return collapse_greedy(tree, arity_of(p));
            return collapse_sah(tree, arity_of(p), sah_cost_of(p), p.get_uint("max_leaf"));
          },
          [](const ParamSet& p) {
            TopDownConfig config = top_down_config(p);
            config.arity = arity_of(p);
            check_config(config, "wide_collapse");
          },
          arity_of};
}

BuilderInfo sweep_sah_info() {
  return {"sweep_sah", "full-sweep SAH over presorted centroids (MacDonald and Booth 1990)", top_down_params(),
          [](const BuildInput& input, const ParamSet& p) { return build_sweep_sah(input, {top_down_config(p)}); },
          [](const ParamSet& p) { check_config(top_down_config(p), "sweep_sah"); }};
}

std::vector<BuilderInfo>& registry() {
  // One line per builder.
  static std::vector<BuilderInfo> all = {
      binned_sah_info(),
      sweep_sah_info(),
      wide_binned_sah_info(),
      wide_collapse_info(),
  };
  return all;
}

}  // namespace

std::span<const BuilderInfo> builders() { return registry(); }

void register_builder(BuilderInfo info) {
  auto& all = registry();
  for (const auto& b : all)
    if (b.name == info.name) throw Error("builder '" + info.name + "' is registered twice");
  all.push_back(std::move(info));
}

const BuilderInfo& find_builder(std::string_view name) {
  const auto& all = registry();
  const auto it = std::find_if(all.begin(), all.end(), [&](const BuilderInfo& b) { return b.name == name; });
  if (it != all.end()) return *it;
  std::string known;
  for (const auto& b : all) known += (known.empty() ? "" : ", ") + b.name;
  throw Error("unknown builder '" + std::string(name) + "' (known: " + known + ")");
}

SahCost sah_cost_of(const ParamSet& params) { return {params.get_float("c_trav"), params.get_float("c_isect")}; }

}  // namespace sahbench
