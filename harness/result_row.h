#pragma once
// Fields of a result row that every runner (static, animation, stress) fills the same way, so that one
// column has one format in every CSV the harness writes.

#include <cstddef>
#include <string>

#include "core/bvh_stats.h"
#include "core/sah.h"
#include "harness/csv.h"
#include "harness/timing.h"

namespace sahbench {

/// The tree's statistics and the SAH constants they were computed with: nodes, leaves, max_depth,
/// refs_per_prim (4 decimals), sah_cost (6 decimals), sah_c_trav, sah_c_isect and sah_block.
void put_tree_stats(CsvRow& row, const BvhStats& stats, const SahCost& cost);

/// PREFIX_median, PREFIX_min and PREFIX_max (4 decimals), e.g. prefix "build_ms" or "trace_mrays".
void put_timing(CsvRow& row, const std::string& prefix, const TimingSummary& t);

/// mem_bytes per scene triangle (2 decimals), the figure papers quote for a layout's footprint; empty
/// for a scene without triangles.
std::string bytes_per_triangle(std::size_t bytes, std::size_t triangles);

}  // namespace sahbench
