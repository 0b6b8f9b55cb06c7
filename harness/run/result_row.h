#pragma once
// Fields of a result row that every runner (static, animation, stress) fills the same way, so that one
// column has one format in every CSV the harness writes.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "core/bvh_stats.h"
#include "core/ray.h"
#include "core/sah.h"
#include "harness/run/csv.h"
#include "harness/run/ray_sets.h"
#include "harness/run/reference.h"
#include "harness/run/timing.h"
#include "traversal/layout.h"

namespace sahbench {

/// The CSV columns of a run: DESIGN.md's (csv.h), then config, seed, scene_source, scene_removed, query,
/// embree_version, notes, build_isa, bytes_per_tri, sah_block, fingerprint_parts,
/// build_layout_ms_samples, source_sah_cost, epo_cost, sah_epo_cost, cost_per_ray, shard ("K/N" for a
/// shard's run, shard_plan.h) and shard_run_id (in a merged CSV, the run id the row had in its shard's
/// CSV; shard_merge.h).
std::vector<std::string> result_columns();

/// The key that identifies a cell, in the form `scene|builder|builder_params|layout|threads|ray_set|frame`,
/// the same from a planned cell and from a CSV row; --only matches against it.
std::string cell_key(const std::string& scene, const std::string& builder, const std::string& params,
                     const std::string& layout, int threads, const std::string& ray_set, int frame);

/// The tree's statistics and the SAH constants they were computed with: nodes, leaves, max_depth,
/// refs_per_prim (4 decimals), sah_cost (6 decimals), sah_c_trav, sah_c_isect and sah_block.
void put_tree_stats(CsvRow& row, const BvhStats& stats, const SahCost& cost);

/// PREFIX_median, PREFIX_min, PREFIX_max and PREFIX_samples (4 decimals; the samples in the order taken,
/// separated by ';'), for prefix "build_ms" or "trace_mrays".
void put_timing(CsvRow& row, const std::string& prefix, const TimingSummary& t);

/// build_layout_ms_median and build_layout_ms_samples: build plus layout compile (ms) per round, paired by
/// index, and their median. For Embree, whose rtcCommitScene does both, pass an empty `layout`.
void put_build_layout_ms(CsvRow& row, const TimingSummary& build, const TimingSummary& layout);

/// hit_fraction (4 decimals): the share of the rays in `hits` that found a hit, or of `occluded` that are
/// occluded; a miss costs a ray a fixed time that weighs on its rays/s, so a ratio needs this beside it.
void put_hit_fraction(CsvRow& row, std::span<const Hit> hits, std::span<const uint8_t> occluded);

/// mem_bytes per scene triangle (2 decimals), the figure papers quote for a layout's footprint; empty
/// for a scene without triangles.
std::string bytes_per_triangle(std::size_t bytes, std::size_t triangles);

/// The ray set of a cell: ray_set (its name), ray_count and query ("closest", or "any" for occlusion).
void put_ray_set(CsvRow& row, const RaySet& rs);

/// epo_cost (core/epo.h) and sah_epo_cost, the paper's blend of `sah` and `epo` (6 decimals each).
void put_epo(CsvRow& row, double epo, double sah);

/// nodes_per_ray, leaves_per_ray (the leaves among those nodes) and prims_per_ray (3 decimals) from a
/// counting pass; with the tree's `cost` model also
/// cost_per_ray = c_trav * nodes_per_ray + c_isect * prims_per_ray, the SAH's cost measured on the rays.
/// nodes_per_ray counts inner nodes and leaves whose contents were examined (TraceCounts), so unlike the
/// SAH, which charges a leaf only for its primitives, the measured cost charges each leaf visit c_trav
/// too; prims_per_ray counts ray/triangle tests, not SahCost's blocks. Empty `cost` (Embree's rows and
/// the stress CSV, which has no such column): no cost_per_ray.
void put_per_ray_counts(CsvRow& row, const TraceCounts& counts, const std::optional<SahCost>& cost);

/// reference (its name), and mismatches: the answers in `hits` or `occluded` that differ from `ref`'s
/// (count_mismatches), empty where there is no reference.
void put_mismatches(CsvRow& row, const Reference& ref, const RaySet& rs, float scene_diagonal,
                    std::span<const Hit> hits, std::span<const uint8_t> occluded);

/// The progress line of a finished cell: `label`, its median build time and rays/s, and its mismatches
/// ("no reference" where the run has none).
std::string cell_summary(const std::string& label, const CsvRow& row);

/// Appends `note` to the row's `notes`, after "; " when it has some already.
void add_note(CsvRow& row, const std::string& note);

}  // namespace sahbench
