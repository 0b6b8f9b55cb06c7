#pragma once
// The builder variants and scenes every builder test runs over.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "builders/registry.h"
#include "builders/sbvh.h"
#include "core/clip_polygon.h"
#include "core/triangle.h"
#include "tests/support/test_scenes.h"

namespace sahbench::test {

struct BuilderVariant {
  std::string builder;
  ParamOverrides params;
  std::string label() const {
    std::string s = builder;
    for (const auto& [k, v] : params) s += "_" + k + v;
    for (char& c : s)
      if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    return s;
  }
};

/// `tris` built by the registered `builder` with its defaults under `overrides`.
inline Bvh build_tree(const std::string& builder, const std::vector<Triangle>& tris,
                      const ParamOverrides& overrides = {}) {
  const BuilderInfo& info = find_builder(builder);
  return info.build(BuildInput::from_triangles(tris), resolve_params(info.name, info.params, overrides));
}

/// Every registered builder with its defaults, plus the parameter extremes.
inline std::vector<BuilderVariant> builder_variants() {
  std::vector<BuilderVariant> out;
  for (const auto& b : builders()) out.push_back({b.name, {}});
  out.push_back({"binned_sah", {{"bins", "4"}}});
  out.push_back({"binned_sah", {{"bins", "256"}}});
  out.push_back({"binned_sah", {{"bins", "16"}, {"adaptive_bins", "0"}}});
  out.push_back({"binned_sah", {{"max_leaf", "1"}}});
  out.push_back({"binned_sah", {{"sah_block", "4"}}});
  out.push_back({"binned_sah", {{"min_leaf", "4"}, {"max_leaf", "16"}, {"c_trav", "3"}}});
  out.push_back({"sweep_sah", {{"max_leaf", "1"}}});
  out.push_back({"wide_binned_sah", {{"arity", "4"}}});
  out.push_back({"wide_binned_sah", {{"arity", "4"}, {"max_leaf", "1"}}});
  out.push_back({"wide_collapse", {{"method", "greedy"}}});
  out.push_back({"wide_collapse", {{"arity", "4"}, {"source", "sweep_sah"}}});
  out.push_back({"wide_collapse", {{"method", "greedy"}, {"arity", "4"}, {"max_leaf", "1"}}});
  out.push_back({"wide_collapse", {{"source", "sbvh"}}});
  // A source finer than the plain collapse's, coarser than the default's, with min_leaf 4.
  out.push_back({"wide_collapse", {{"c_trav", "2"}, {"source_c_trav_scale", "0.25"}, {"min_leaf", "4"}}});
  out.push_back({"wide_collapse", {{"source_c_trav_scale", "0"}, {"source", "sbvh"}}});
  // The passes over every kind of binary source, and composed: a pass over a pass, the collapse over each.
  out.push_back({"reinsert", {{"source", "sweep_sah"}, {"batch", "1"}, {"iterations", "2"}}});
  out.push_back({"reinsert", {{"source", "sbvh"}, {"iterations", "2"}}});
  out.push_back({"reinsert", {{"source.max_leaf", "1"}, {"iterations", "3"}, {"batch", "0.5"}}});
  out.push_back({"treelet", {{"treelet_size", "3"}, {"source", "sbvh"}}});
  out.push_back({"treelet", {{"treelet_size", "10"}, {"iterations", "1"}, {"source.max_leaf", "1"}}});
  out.push_back({"treelet", {{"source", "reinsert"}, {"source.source", "sweep_sah"}}});
  out.push_back({"wide_collapse", {{"source", "reinsert"}, {"source.iterations", "2"}}});
  out.push_back(
      {"wide_collapse",
       {{"source", "reinsert"}, {"source.source", "binned_sah"}, {"source.source.sah_block", "4"}}});
  out.push_back({"wide_collapse", {{"arity", "4"}, {"method", "greedy"}, {"source", "treelet"}}});
  out.push_back({"wide_collapse", {{"source", "binned_sah"}, {"source.max_leaf", "2"}}});
  // Spatial splits tried at every node: without unsplitting, with the fewest slabs everywhere; and with
  // the most slabs, a large budget and single-reference leaves.
  out.push_back({"sbvh", {{"alpha", "0"}, {"unsplit", "0"}, {"spatial_bins", "4"}, {"adaptive_bins", "0"}}});
  out.push_back(
      {"sbvh",
       {{"alpha", "0"}, {"max_dup", "2"}, {"max_leaf", "1"}, {"spatial_bins", "256"}, {"c_trav", "3"}}});
  out.push_back({"wide_sbvh", {{"arity", "4"}, {"alpha", "0"}, {"max_leaf", "1"}}});
  // The bottom-up builders: 63-bit codes, Karras's pass beside the default Apetrei's, single-primitive
  // leaves, and a coarser collapse.
  out.push_back({"lbvh", {{"bits", "63"}}});
  out.push_back({"lbvh", {{"hierarchy", "karras"}}});
  out.push_back({"lbvh", {{"hierarchy", "karras"}, {"bits", "63"}, {"max_leaf", "1"}}});
  out.push_back({"lbvh", {{"max_leaf", "1"}}});
  out.push_back({"lbvh", {{"min_leaf", "4"}, {"max_leaf", "16"}, {"c_trav", "3"}}});
  out.push_back({"ploc", {{"radius", "1"}}});
  out.push_back({"ploc", {{"radius", "64"}, {"bits", "63"}, {"max_leaf", "1"}}});
  out.push_back({"ploc", {{"min_leaf", "4"}, {"max_leaf", "16"}, {"c_trav", "3"}}});
  // Presplitting: none, and the largest budget with single-reference leaves.
  out.push_back({"presplit", {{"split_budget", "0"}}});
  out.push_back({"presplit", {{"split_budget", "4"}, {"max_leaf", "1"}}});
  return out;
}

/// The most references a builder may return for `prims` primitives: (1 + max_dup) n or
/// (1 + split_budget) n for builders with a duplication budget (spatial splits, presplitting), n for the
/// others; a pass's, its source's.
inline std::size_t max_references(const BuilderInfo& info, const ParamSet& params, std::size_t prims) {
  if (params.has("source")) {
    const SourceSpec& source = params.get_source("source");
    if (!source.shared()) return max_references(*source.info, *source.params, prims);
    // wide_collapse source=sbvh collapses an SBVH with sbvh's default budget.
    if (source.name() == "sbvh")
      return static_cast<std::size_t>(std::floor((1.0 + double(SbvhParams{}.max_dup)) * double(prims)));
  }
  for (const auto& spec : info.params)
    if (spec.name == "max_dup" || spec.name == "split_budget")
      return static_cast<std::size_t>(
          std::floor((1.0 + double(params.get_float(spec.name))) * double(prims)));
  return prims;
}

/// The largest leaf a builder may make: its max_leaf, and a pass's source's where the pass keeps the
/// source's leaves (a collapse merges leaves up to its own max_leaf and keeps larger ones).
inline uint32_t max_leaf_of(const ParamSet& params) {
  uint32_t limit = params.has("max_leaf") ? params.get_uint("max_leaf") : 0;
  if (params.has("source") && !params.get_source("source").shared())
    limit = std::max(limit, max_leaf_of(*params.get_source("source").params));
  return limit;
}

/// The override that sets the leaf size of `info`'s trees to `value`: its own max_leaf, or for a pass
/// without one its source's.
inline std::pair<std::string, std::string> max_leaf_override(const BuilderInfo& info, std::string value) {
  for (const auto& spec : info.params)
    if (spec.name == "max_leaf") return {"max_leaf", std::move(value)};
  return {"source.max_leaf", std::move(value)};
}

/// Each reference of each leaf: the leaf box (grown by the validator's tolerance) holds a part of its
/// triangle, i.e. the triangle clipped to the box is not empty. The validator asks less of split
/// triangles (their leaves together must cover them); a builder that clips only boxes can leave a
/// reference whose box misses the triangle, but one that clips the triangles, as the SBVH does, never does.
inline ::testing::AssertionResult leaves_hold_parts_of_their_triangles(const Bvh& bvh,
                                                                       std::span<const Triangle> tris) {
  for (uint32_t n = 0; n < bvh.nodes.size(); ++n) {
    const Node& node = bvh.nodes[n];
    if (!node.is_leaf()) continue;
    for (uint32_t r = node.first; r < node.first + node.prim_count; ++r) {
      const Triangle& t = tris[bvh.prim_refs[r]];
      const double tol = 0x1p-30 * coordinate_scale(t);
      ClipPolygon part = ClipPolygon::of(t);
      for (int a = 0; a < 3; ++a) {
        part.clip(a, double(node.bounds.min[a]) - tol, false);
        part.clip(a, double(node.bounds.max[a]) + tol, true);
      }
      if (part.empty())
        return ::testing::AssertionFailure()
               << "leaf " << n << " holds triangle " << bvh.prim_refs[r] << ", which does not meet its box";
    }
  }
  return ::testing::AssertionSuccess();
}

struct SceneCase {
  std::string name;
  std::vector<Triangle> triangles;
};

inline Triangle translated(Triangle t, Vec3 d) {
  return {t.v0 + d, t.v1 + d, t.v2 + d};
}

/// Random scenes of several sizes and adversarial ones: identical triangles, nested triangles sharing a
/// centroid, everything in one plane, needles, a closed cube grid, tiny detail in a huge box, and one
/// large enough to take the parallel binning and partitioning paths.
inline std::vector<SceneCase> scene_cases() {
  std::vector<SceneCase> out;
  for (std::size_t n : {1u, 2u, 3u, 17u, 1000u, 20000u})
    out.push_back({"random" + std::to_string(n), random_triangles(n, n)});
  out.push_back({"random_parallel_paths", random_triangles(70000, 5, 50.0f)});

  const Triangle base{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  out.push_back({"identical", std::vector<Triangle>(1000, base)});

  std::vector<Triangle> nested;
  for (int i = 1; i <= 500; ++i) {
    const float s = static_cast<float>(i);
    nested.push_back({{-s, -s, 0}, {s, -s, 0}, {0, s, 0.5f * s}});
  }
  out.push_back({"nested_same_centroid_box", nested});

  std::vector<Triangle> planar = random_triangles(3000, 11);
  for (auto& t : planar) t.v0.z = t.v1.z = t.v2.z = 0.0f;
  out.push_back({"planar", planar});

  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-20.0f, 20.0f);
  std::vector<Triangle> needles;
  for (int i = 0; i < 2000; ++i) {
    const Vec3 a{u(rng), u(rng), u(rng)}, d = normalize(Vec3{u(rng), u(rng), u(rng)}) * 30.0f;
    needles.push_back({a, a + d, a + d + Vec3{0.01f, 0.0f, 0.02f}});
  }
  out.push_back({"needles", needles});

  out.push_back({"cube_grid", cube_grid(12, 3.0f)});

  std::vector<Triangle> multiscale = cube_grid(2, 1000.0f);
  for (const auto& t : random_triangles(2000, 17, 1e-2f, 1e-3f))
    multiscale.push_back(translated(t, {1, 2, 3}));
  out.push_back({"multiscale", multiscale});
  return out;
}

}  // namespace sahbench::test
