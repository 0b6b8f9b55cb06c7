#include "builders/registry.h"

#include <algorithm>

#include "builders/binned_sah.h"
#include "builders/child_order.h"
#include "builders/collapse.h"
#include "builders/lbvh.h"
#include "builders/ploc.h"
#include "builders/presplit.h"
#include "builders/reinsert.h"
#include "builders/sbvh.h"
#include "builders/sweep_sah.h"
#include "builders/treelet.h"
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

// The builders that search centroid planes (binned, sweep and spatial-split) also offer a size split,
// by default where their parameter structs say (off for the builders that split references: sbvh,
// wide_sbvh, presplit).
ParamSpec size_split_param(bool default_on) {
  return {"size_split",
          ParamType::kInt,
          double(default_on),
          0,
          1,
          "1: also split a node's large primitives from the rest, where the SAH prefers it"};
}

// top_down_config of a builder that declares size_split.
TopDownConfig plane_search_config(const ParamSet& p) {
  TopDownConfig config = top_down_config(p);
  config.size_split = p.get_uint("size_split") != 0;
  return config;
}

// Wide trees are traced by the bvh4/bvh8 layouts, which test 4 triangles at once (traversal/wide_bvh.h).
constexpr uint32_t kWideSahBlock = 4;

ParamSpec sah_block_param(uint32_t default_block) {
  return {"sah_block",
          ParamType::kInt,
          double(default_block),
          1,
          16,
          "primitives per leaf block in the SAH: a leaf costs c_isect per started block (power of two)"};
}

// sah_block is declared by the wide builders, and by binned_sah (default 1, every primitive costed) so
// that a binary tree meant for a wide collapse can be built with the wide leaves' costs, e.g. as the
// source of a pass the collapse then reads (wide_collapse over reinsert over binned_sah with
// sah_block=4): built per primitive, its smaller leaves survive the pass and the collapse.
std::vector<ParamSpec> binned_params(uint32_t default_block = 0, const BinnedSahParams& defaults = {}) {
  auto params = top_down_params();
  params.push_back(size_split_param(defaults.top_down.size_split));
  if (default_block != 0) params.push_back(sah_block_param(default_block));
  params.insert(params.begin(), {{"bins", ParamType::kInt, double(defaults.bins), kMinBins, kMaxBins,
                                  "centroid bins per axis"},
                                 {"adaptive_bins", ParamType::kInt, double(defaults.adaptive_bins), 0, 1,
                                  "1: min(bins, 4 + n/20) bins on a node of n primitives (Embree's rule)"}});
  return params;
}

BinnedSahParams binned_config(const ParamSet& p) {
  return {p.get_uint("bins"), p.get_uint("adaptive_bins") != 0, plane_search_config(p)};
}

// Wide trees: 8 children by default, the width of an AVX2 node (Embree's BVH8).
constexpr uint32_t kDefaultWideArity = 8;

ParamSpec arity_param() {
  return {"arity", ParamType::kInt, double(kDefaultWideArity),
          2,       kMaxArity,       "children per inner node: 2, 4 or 8"};
}

uint32_t arity_of(const ParamSet& p) {
  return p.get_uint("arity");
}

BuilderInfo binned_sah_info() {
  return {
      "binned_sah", "binned SAH (Wald 2007), parallel binning and partitioning", binned_params(1),
      [](const BuildInput& input, const ParamSet& p) { return build_binned_sah(input, binned_config(p)); },
      [](const ParamSet& p) { check_config(top_down_config(p), "binned_sah"); }};
}

BuilderInfo wide_binned_sah_info() {
  auto params = binned_params(kWideSahBlock);
  params.insert(params.begin(), arity_param());
  auto config = [](const ParamSet& p) {
    BinnedSahParams c = binned_config(p);
    c.top_down.arity = arity_of(p);
    return c;
  };
  return {"wide_binned_sah",
          "binned SAH building wide nodes directly: the child of largest area is split until `arity` "
          "children (Wald et al. 2008; Embree's BVHN builder)",
          std::move(params),
          [config](const BuildInput& input, const ParamSet& p) { return build_binned_sah(input, config(p)); },
          [config](const ParamSet& p) { check_config(config(p).top_down, "wide_binned_sah"); },
          arity_of};
}

// wide_collapse's SAH constants, after Ylitie, Karras and Laine 2017 ("Efficient incoherent ray traversal
// on GPUs through compressed wide BVHs"), who build the binary source down to single triangles and let
// the SAH collapse choose the wide leaves: the source is built with c_trav scaled by kSourceTravScale,
// splitting far below the leaves the collapse then keeps, and the collapse prices a node visit at three
// 4-triangle block tests. The two values were tuned on configs/tune.toml's scenes (configs/wide.toml
// keeps the history). c_trav = 1 and a scale of 1 are Embree's constants, the plain collapse, faster to
// build (configs/claim.toml measures both).
constexpr double kWideCollapseTrav = 3.0;
constexpr double kSourceTravScale = 0.0625;

// Sets the default of the parameter `name` in `params`.
void set_default(std::vector<ParamSpec>& params, const std::string& name, double value) {
  const auto it =
      std::find_if(params.begin(), params.end(), [&](const ParamSpec& p) { return p.name == name; });
  if (it == params.end()) throw Error("no parameter " + name + " to give a default");
  it->default_value = value;
}

// The parameters that wide_collapse applies only to its own binary build of a source named alone, and to
// which of those sources (ParamSpec::only_with_sources): the sweep has no bins. With any other source they
// are not recorded, and given they would do nothing (even at their defaults), so that is an error that
// says what to write instead.
const std::vector<std::pair<std::string, std::vector<std::string>>>& own_build_params() {
  static const std::vector<std::pair<std::string, std::vector<std::string>>> params = {
      {"bins", {"binned_sah", "sbvh"}},
      {"adaptive_bins", {"binned_sah", "sbvh"}},
      {"min_leaf", {"binned_sah", "sweep_sah", "sbvh"}},
      {"size_split", {"binned_sah", "sweep_sah"}},
      {"source_c_trav_scale", {"binned_sah", "sweep_sah", "sbvh"}},
      {"reinsert_iterations", {"binned_sah", "sweep_sah", "sbvh"}}};
  return params;
}

void check_own_build_params(const ParamSet& p, const char* builder) {
  const SourceSpec& source = p.get_source("source");
  for (const ParamSpec& spec : find_builder(builder).params) {
    if (spec.only_with_sources.empty() || !p.given(spec.name)) continue;
    const auto& takers = spec.only_with_sources;
    if (source.shared() && std::find(takers.begin(), takers.end(), source.name()) != takers.end()) continue;
    std::string names;
    for (const std::string& name : takers) names += (names.empty() ? "" : ", ") + name;
    const bool source_has = !source.shared() && source.params->has(spec.name);
    std::string instead;
    const auto& source_params = find_builder(source.name()).params;
    const bool declared = std::any_of(source_params.begin(), source_params.end(),
                                      [&](const ParamSpec& q) { return q.name == spec.name; });
    if (source.shared() && declared)
      instead = "the collapse's own " + source.name() + " build keeps " + source.name() +
                "'s default; give " + source.name() + " its own (source." + spec.name +
                "=...) to build it as the plain builder";
    else if (source.shared())
      instead = source.name() + " has no " + spec.name;
    else if (spec.name == "source_c_trav_scale")
      instead = source.params->has("c_trav") ? "give the source its own c_trav (source.c_trav=...)"
                                             : "source=" + source.name() + " has no c_trav to scale";
    else if (spec.name == "reinsert_iterations")
      instead = source.name() == "reinsert"
                    ? "give the source its own iterations (source.iterations=...)"
                    : "name the pass as the source (source=reinsert,source.source=" + source.name() + ")";
    else
      instead = source_has ? "give it to the source (source." + spec.name + "=...)"
                           : "source=" + source.name() + " has no such parameter";
    throw Error(std::string(builder) + ": " + spec.name +
                " applies only to the collapse's own build of a source named alone (" + names +
                "), not to source=" + source.name() + "; " + instead);
  }
}

void mark_own_build_params(std::vector<ParamSpec>& params) {
  for (ParamSpec& spec : params)
    for (const auto& [name, sources] : own_build_params())
      if (spec.name == name) spec.only_with_sources = sources;
}

BuilderInfo wide_collapse_info() {
  auto params = binned_params(kWideSahBlock);
  set_default(params, "c_trav", kWideCollapseTrav);
  params.insert(
      params.begin(),
      {arity_param(),
       choice_param("method", {"sah", "greedy"}, 0,
                    "sah: SAH-optimal collapse (Ylitie et al. 2017); greedy: open the largest child"),
       source_param(
           "source", "binned_sah",
           "the binary builder or pass whose tree is collapsed; binned_sah, sweep_sah and sbvh named "
           "alone take the bins and leaf parameters here, any source given its own (source.KEY=...) "
           "takes those; method=sah may merge a subtree of up to max_leaf references into one leaf",
           {"binned_sah", "sweep_sah", "sbvh"}),
       {"source_c_trav_scale", ParamType::kFloat, kSourceTravScale, 0, 1,
        "the binary source is built with c_trav times this (below 1: a finer source, whose leaves "
        "method=sah merges back where its SAH says so)"},
       {"reinsert_iterations", ParamType::kInt, double(ReinsertParams{}.iterations), 0, 1000,
        "rounds of the reinsert pass on a source named alone before the collapse, stopping early once "
        "a round finds little to gain (0: that source's tree collapsed as built)"}});
  mark_own_build_params(params);
  return {"wide_collapse",
          "a binary SAH tree collapsed to `arity` children per node; build time includes the binary build",
          std::move(params),
          [](const BuildInput& input, const ParamSet& p) {
            BinnedSahParams binary = binned_config(p);
            binary.top_down.cost.c_trav *= p.get_float("source_c_trav_scale");
            const SourceSpec& spec = p.get_source("source");
            const std::string& source = spec.name();
            Bvh tree;
            if (!spec.shared()) {
              tree = build_source(input, p);
            } else if (source == "sweep_sah") {
              // The sweep counts primitives, not blocks, in its split search: it builds with block 1, and
              // the collapse applies sah_block.
              TopDownConfig per_prim = binary.top_down;
              per_prim.cost.block = 1;
              tree = build_sweep_sah(input, {per_prim});
            } else if (source == "sbvh") {
              // Spatial splits with sbvh's defaults for its own parameters (alpha, max_dup, size_split ...),
              // costed per block like the binned source: built per primitive, the SBVH's small leaves
              // collapsed to 60% more wide leaves than the binned tree's on the same scene, and traced 5-13%
              // slower.
              SbvhParams sbvh;
              sbvh.bins = binary.bins;
              sbvh.adaptive_bins = binary.adaptive_bins;
              sbvh.top_down = binary.top_down;
              sbvh.top_down.size_split = SbvhParams{}.top_down.size_split;
              tree = build_sbvh(input, sbvh, "wide_collapse");
            } else {
              tree = build_binned_sah(input, binary);
            }
            // A top-down build places each split by its own node's cost alone; reinsertion then lowers
            // the inner nodes' area where the greedy splits left boxes that overlap (Bittner et al. 2013).
            // The wide tree's inner nodes are a subset of the binary tree's, so the collapse keeps most
            // of that gain (not all: its optimum over another binary tree may differ). A source with
            // parameters of its own (a chain, a tree file) is collapsed as given.
            if (const uint32_t rounds = p.get_uint("reinsert_iterations"); spec.shared() && rounds > 0) {
              ReinsertParams optimise;
              optimise.iterations = rounds;
              optimise.cost = sah_cost_of(p);
              tree = reinsert(tree, optimise);
            }
            if (p.get_choice("method") == "greedy") return collapse_greedy(tree, arity_of(p));
            return collapse_sah(tree, arity_of(p), sah_cost_of(p), p.get_uint("max_leaf"));
          },
          [](const ParamSet& p) {
            TopDownConfig config = top_down_config(p);
            config.arity = arity_of(p);
            check_config(config, "wide_collapse");
            check_own_build_params(p, "wide_collapse");
          },
          arity_of};
}

std::vector<ParamSpec> sweep_params() {
  auto params = top_down_params();
  params.push_back(size_split_param(SweepSahParams{}.top_down.size_split));
  return params;
}

BuilderInfo sweep_sah_info() {
  return {"sweep_sah", "full-sweep SAH over presorted centroids (MacDonald and Booth 1990)", sweep_params(),
          [](const BuildInput& input, const ParamSet& p) {
            return build_sweep_sah(input, {plane_search_config(p)});
          },
          [](const ParamSet& p) { check_config(top_down_config(p), "sweep_sah"); }};
}

SbvhParams sbvh_params(const ParamSet& p) {
  SbvhParams s;
  s.bins = p.get_uint("bins");
  s.spatial_bins = p.get_uint("spatial_bins");
  s.adaptive_bins = p.get_uint("adaptive_bins") != 0;
  s.alpha = p.get_float("alpha");
  s.node_overlap = p.get_float("node_overlap");
  s.max_dup = p.get_float("max_dup");
  s.unsplit = p.get_uint("unsplit") != 0;
  s.top_down = plane_search_config(p);
  return s;
}

std::vector<ParamSpec> sbvh_param_specs(uint32_t default_block = 0) {
  auto params = top_down_params();
  const SbvhParams defaults;
  params.push_back(size_split_param(defaults.top_down.size_split));
  // alpha and max_dup as doubles, so the CSV shows 1e-05 and 0.5 rather than their float roundings.
  constexpr double kDefaultAlpha = 1e-5, kDefaultNodeOverlap = 0.1, kDefaultMaxDup = 0.5;
  static_assert(float(kDefaultAlpha) == SbvhParams{}.alpha &&
                float(kDefaultNodeOverlap) == SbvhParams{}.node_overlap &&
                float(kDefaultMaxDup) == SbvhParams{}.max_dup);
  params.insert(
      params.begin(),
      {{"bins", ParamType::kInt, double(defaults.bins), kMinBins, kMaxBins, "object-split bins per axis"},
       {"spatial_bins", ParamType::kInt, double(defaults.spatial_bins), kMinBins, kMaxBins,
        "spatial-split slabs per axis"},
       {"adaptive_bins", ParamType::kInt, double(defaults.adaptive_bins), 0, 1,
        "1: at most 4 + n/20 bins and slabs on a node of n references"},
       {"alpha", ParamType::kFloat, kDefaultAlpha, 0, 1,
        "spatial splits where object-split children overlap by more than alpha * root area (1: none)"},
       {"node_overlap", ParamType::kFloat, kDefaultNodeOverlap, 0, 1,
        "... and by at least node_overlap * node area (Embree's rule; 0: Stich et al.'s alone)"},
       {"max_dup", ParamType::kFloat, kDefaultMaxDup, 0, kSbvhMaxDup, "at most (1 + max_dup) * n references"},
       {"unsplit", ParamType::kInt, double(defaults.unsplit), 0, 1, "1: reference unsplitting"}});
  if (default_block != 0) params.push_back(sah_block_param(default_block));
  return params;
}

BuilderInfo sbvh_info() {
  return {
      "sbvh", "spatial-split BVH (Stich, Friedrich and Dietrich 2009), object and spatial binned SAH",
      sbvh_param_specs(),
      [](const BuildInput& input, const ParamSet& p) { return build_sbvh(input, sbvh_params(p), "sbvh"); },
      [](const ParamSet& p) { check_sbvh_params(sbvh_params(p), "sbvh"); }};
}

// Spatial splits on the direct wide recursion: each wide node splits its child of largest area, by the
// better of the object and the spatial split, until it has `arity` children, as Embree's spatial-split
// BVH8 builder does (kernels/bvh/bvh_builder_sah_spatial.cpp), rather than collapsing a binary SBVH.
BuilderInfo wide_sbvh_info() {
  auto params = sbvh_param_specs(kWideSahBlock);
  params.insert(params.begin(), arity_param());
  auto config = [](const ParamSet& p) {
    SbvhParams s = sbvh_params(p);
    s.top_down.arity = arity_of(p);
    return s;
  };
  return {"wide_sbvh",
          "spatial-split BVH built wide directly: the child of largest area is split, by an object or a "
          "spatial split, until `arity` children (Stich et al. 2009 on Embree's BVHN builder)",
          std::move(params),
          [config](const BuildInput& input, const ParamSet& p) {
            return build_sbvh(input, config(p), "wide_sbvh");
          },
          [config](const ParamSet& p) { check_sbvh_params(config(p), "wide_sbvh"); },
          arity_of};
}

// The Morton-order builders: the code length as a choice, and the leaf parameters of the top-down
// builders, which their SAH leaf collapse (leaf_collapse.h) follows.
ParamSpec morton_bits_param() {
  return choice_param("bits", {"30", "63"}, 0, "Morton code length: 10 or 21 bits per axis");
}

uint32_t morton_bits(const ParamSet& p) {
  return p.get_choice("bits") == "63" ? 63 : 30;
}

BuilderInfo lbvh_info() {
  auto params = top_down_params();
  params.insert(params.begin(),
                {morton_bits_param(),
                 choice_param("hierarchy", {"karras", "apetrei"}, 1,
                              "apetrei: one bottom-up pass (Apetrei 2014); karras: one search per inner node "
                              "(Karras 2012); the same tree")});
  auto config = [](const ParamSet& p) {
    const auto hierarchy =
        p.get_choice("hierarchy") == "apetrei" ? LbvhHierarchy::kApetrei : LbvhHierarchy::kKarras;
    return LbvhParams{morton_bits(p), hierarchy, top_down_config(p)};
  };
  return {"lbvh",
          "linear BVH: Morton codes, radix sort, parallel radix tree (Karras 2012), SAH leaf collapse",
          std::move(params),
          [config](const BuildInput& input, const ParamSet& p) { return build_lbvh(input, config(p)); },
          [config](const ParamSet& p) { check_lbvh_params(config(p)); }};
}

BuilderInfo ploc_info() {
  auto params = top_down_params();
  const PlocParams defaults;
  params.insert(params.begin(), {{"radius", ParamType::kInt, double(defaults.radius), 1, kPlocMaxRadius,
                                  "clusters searched on each side in the Morton order"},
                                 morton_bits_param()});
  auto config = [](const ParamSet& p) {
    return PlocParams{p.get_uint("radius"), morton_bits(p), top_down_config(p)};
  };
  return {
      "ploc",
      "parallel locally-ordered clustering (Meister and Bittner 2018) over Morton order, SAH leaf collapse",
      std::move(params),
      [config](const BuildInput& input, const ParamSet& p) { return build_ploc(input, config(p)); },
      [config](const ParamSet& p) { check_ploc_params(config(p)); }};
}

BuilderInfo presplit_info() {
  auto params = binned_params(0, PresplitParams{}.binned);
  // As a double, so that the CSV shows 0.3 rather than its float rounding.
  constexpr double kDefaultSplitBudget = 0.3;
  static_assert(float(kDefaultSplitBudget) == PresplitParams{}.split_budget);
  params.insert(params.begin(),
                {"split_budget", ParamType::kFloat, kDefaultSplitBudget, 0, kPresplitMaxBudget,
                 "extra references for split triangles, as a fraction of n"});
  auto config = [](const ParamSet& p) {
    return PresplitParams{p.get_float("split_budget"), binned_config(p)};
  };
  return {"presplit",
          "large triangles' references split before a binned SAH build (Karras and Aila 2013, section 5)",
          std::move(params),
          [config](const BuildInput& input, const ParamSet& p) { return build_presplit(input, config(p)); },
          [config](const ParamSet& p) { check_presplit_params(config(p)); }};
}

// The wide builders' trees come out with each node's children in the order in which any hit visits the
// children of wide nodes (child_order.h), by the builder's own SAH constants.
BuilderInfo with_children_for_occlusion(BuilderInfo info) {
  info.build = [build = std::move(info.build)](const BuildInput& input, const ParamSet& p) {
    Bvh bvh = build(input, p);
    order_children_for_occlusion(bvh, input.triangles, sah_cost_of(p));
    return bvh;
  };
  return info;
}

// The SAH constants a pass reports its tree's cost with (the statistics'); its optimisation lowers the
// inner nodes' areas, which any c_trav weighs alike.
std::vector<ParamSpec> pass_cost_params() {
  const SahCost defaults;
  return {{"c_trav", ParamType::kFloat, defaults.c_trav, 0, 1e6, "SAH cost of visiting an inner node"},
          {"c_isect", ParamType::kFloat, defaults.c_isect, 1e-6, 1e6, "SAH cost of one ray/triangle test"}};
}

const char* const kPassSourceHelp =
    "the binary builder or pass whose tree is optimised, with its own parameters (source.KEY=...)";

BuilderInfo reinsert_info() {
  const ReinsertParams defaults;
  std::vector<ParamSpec> params = {
      source_param("source", "binned_sah", kPassSourceHelp),
      {"iterations", ParamType::kInt, double(defaults.iterations), 0, 1000,
       "rounds of search and reinsertion (0: the source's tree)"},
      {"batch", ParamType::kFloat, defaults.batch, 1e-6, 1,
       "fraction of the nodes, the largest first, searched for a better place per round"},
      {"min_gain", ParamType::kFloat, defaults.min_gain, 0, kMaxMinGain,
       "a round whose search finds less than this fraction of the inner nodes' summed area to gain is "
       "the last"}};
  for (auto& p : pass_cost_params()) params.push_back(std::move(p));
  return {"reinsert",
          "pass: reinsertion of subtrees where the SAH drops most (Bittner, Hapala and Havran 2013; parallel "
          "search as Meister and Bittner 2018); never raises the source's SAH",
          std::move(params),
          [](const BuildInput& input, const ParamSet& p) {
            return reinsert(build_source(input, p),
                            {p.get_uint("iterations"), p.get("batch"), p.get("min_gain"), sah_cost_of(p)});
          },
          {}};
}

BuilderInfo treelet_info() {
  const TreeletParams defaults;
  std::vector<ParamSpec> params = {
      source_param("source", "binned_sah", kPassSourceHelp),
      {"treelet_size", ParamType::kInt, double(defaults.treelet_size), kMinTreeletSize, kMaxTreeletSize,
       "leaves per treelet; its work grows as 3^treelet_size"},
      {"iterations", ParamType::kInt, double(defaults.iterations), 0, 100,
       "bottom-up passes (0: the source's tree); stops early once one gains nothing"}};
  for (auto& p : pass_cost_params()) params.push_back(std::move(p));
  return {"treelet",
          "pass: treelet restructuring by dynamic programming over subsets (Karras and Aila 2013); never "
          "raises the source's SAH",
          std::move(params),
          [](const BuildInput& input, const ParamSet& p) {
            return restructure_treelets(build_source(input, p), {p.get_uint("treelet_size"),
                                                                 p.get_uint("iterations"), sah_cost_of(p)});
          },
          {}};
}

std::vector<BuilderInfo>& registry() {
  // One line per builder.
  static std::vector<BuilderInfo> all = {
      binned_sah_info(),
      sweep_sah_info(),
      with_children_for_occlusion(wide_binned_sah_info()),
      with_children_for_occlusion(wide_collapse_info()),
      sbvh_info(),
      with_children_for_occlusion(wide_sbvh_info()),
      reinsert_info(),
      treelet_info(),
      lbvh_info(),
      ploc_info(),
      presplit_info(),
  };
  return all;
}

}  // namespace

std::span<const BuilderInfo> builders() {
  return registry();
}

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

Bvh build_source(const BuildInput& input, const ParamSet& params, std::string_view key) {
  const SourceSpec& source = params.get_source(key);
  if (source.shared())
    throw Error("source '" + source.name() + "' shares its pass's parameters; the pass builds it itself");
  return source.info->build(input, *source.params);
}

SahCost sah_cost_of(const ParamSet& params) {
  SahCost cost{params.get_float("c_trav"), params.get_float("c_isect")};
  if (params.has("sah_block")) cost.block = params.get_uint("sah_block");
  return cost;
}

}  // namespace sahbench
