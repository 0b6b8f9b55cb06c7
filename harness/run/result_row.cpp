#include "harness/run/result_row.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>

#include "core/epo.h"

namespace sahbench {
namespace {

// Columns written after DESIGN.md's (never renamed; these may grow).
const std::vector<std::string>& extra_columns() {
  static const std::vector<std::string> columns = {"config",
                                                   "seed",
                                                   "scene_source",
                                                   "scene_removed",
                                                   "query",
                                                   "embree_version",
                                                   "notes",
                                                   "build_isa",
                                                   "bytes_per_tri",
                                                   "sah_block",
                                                   "fingerprint_parts",
                                                   "build_layout_ms_samples",
                                                   "source_sah_cost",
                                                   "epo_cost",
                                                   "sah_epo_cost",
                                                   "cost_per_ray",
                                                   "shard",
                                                   "shard_run_id",
                                                   "leaves_per_ray"};
  return columns;
}

}  // namespace

std::string cell_key(const std::string& scene, const std::string& builder, const std::string& params,
                     const std::string& layout, int threads, const std::string& ray_set, int frame) {
  return fmt::format("{}|{}|{}|{}|{}|{}|{}", scene, builder, params, layout, threads, ray_set, frame);
}

std::vector<std::string> result_columns() {
  std::vector<std::string> c = design_columns();
  c.insert(c.end(), extra_columns().begin(), extra_columns().end());
  return c;
}

void put_tree_stats(CsvRow& row, const BvhStats& stats, const SahCost& cost) {
  row["nodes"] = std::to_string(stats.nodes);
  row["leaves"] = std::to_string(stats.leaves);
  row["max_depth"] = std::to_string(stats.max_depth);
  row["refs_per_prim"] = fmt::format("{:.4f}", stats.refs_per_prim);
  row["sah_cost"] = fmt::format("{:.6f}", stats.sah_cost);
  row["sah_c_trav"] = fmt::format("{}", cost.c_trav);
  row["sah_c_isect"] = fmt::format("{}", cost.c_isect);
  row["sah_block"] = std::to_string(cost.block);
}

void put_timing(CsvRow& row, const std::string& prefix, const TimingSummary& t) {
  row[prefix + "_median"] = fmt::format("{:.4f}", t.median);
  row[prefix + "_min"] = fmt::format("{:.4f}", t.min);
  row[prefix + "_max"] = fmt::format("{:.4f}", t.max);
  row[prefix + "_samples"] = fmt::format("{:.4f}", fmt::join(t.samples, ";"));
}

void put_build_layout_ms(CsvRow& row, const TimingSummary& build, const TimingSummary& layout) {
  // Round r's build plus compile r, each after freeing the last: the like-for-like with one
  // rtcCommitScene, whose build and packing are one call.
  std::vector<double> sums = build.samples;
  if (!layout.samples.empty()) {
    sums.resize(std::min(build.samples.size(), layout.samples.size()));
    for (std::size_t r = 0; r < sums.size(); ++r) sums[r] += layout.samples[r];
  }
  const TimingSummary t = summarize(std::move(sums));
  row["build_layout_ms_median"] = fmt::format("{:.4f}", t.median);
  row["build_layout_ms_samples"] = fmt::format("{:.4f}", fmt::join(t.samples, ";"));
}

void put_hit_fraction(CsvRow& row, std::span<const Hit> hits, std::span<const uint8_t> occluded) {
  const std::size_t rays = hits.size() + occluded.size();
  std::size_t hit = 0;
  for (const Hit& h : hits) hit += h.found();
  for (const uint8_t o : occluded) hit += o != 0;
  row["hit_fraction"] =
      rays ? fmt::format("{:.4f}", static_cast<double>(hit) / static_cast<double>(rays)) : "";
}

std::string bytes_per_triangle(std::size_t bytes, std::size_t triangles) {
  if (triangles == 0) return "";
  return fmt::format("{:.2f}", static_cast<double>(bytes) / static_cast<double>(triangles));
}

void put_ray_set(CsvRow& row, const RaySet& rs) {
  row["ray_set"] = rs.name;
  row["ray_count"] = std::to_string(rs.rays.size());
  row["query"] = rs.occlusion ? "any" : "closest";
  if (!rs.note.empty()) add_note(row, rs.note);
}

void put_epo(CsvRow& row, double epo, double sah) {
  row["epo_cost"] = fmt::format("{:.6f}", epo);
  row["sah_epo_cost"] = fmt::format("{:.6f}", sah_epo_cost(sah, epo));
}

void put_per_ray_counts(CsvRow& row, const TraceCounts& counts, const std::optional<SahCost>& cost) {
  const auto rays = static_cast<double>(std::max<uint64_t>(1, counts.rays));
  const double nodes = static_cast<double>(counts.nodes_visited) / rays;
  const double prims = static_cast<double>(counts.prims_tested) / rays;
  row["nodes_per_ray"] = fmt::format("{:.3f}", nodes);
  row["prims_per_ray"] = fmt::format("{:.3f}", prims);
  row["leaves_per_ray"] = fmt::format("{:.3f}", static_cast<double>(counts.leaves_visited) / rays);
  if (cost)
    row["cost_per_ray"] = fmt::format(
        "{:.3f}", static_cast<double>(cost->c_trav) * nodes + static_cast<double>(cost->c_isect) * prims);
}

void put_mismatches(CsvRow& row, const Reference& ref, const RaySet& rs, float scene_diagonal,
                    std::span<const Hit> hits, std::span<const uint8_t> occluded) {
  row["reference"] = ref.name;
  row["mismatches"] =
      ref.name == "none" ? "" : std::to_string(count_mismatches(ref, rs, scene_diagonal, hits, occluded));
}

std::string cell_summary(const std::string& label, const CsvRow& row) {
  const auto field = [&](const char* column) {
    const auto it = row.find(column);
    return it == row.end() ? std::string() : it->second;
  };
  const std::string mismatches = field("mismatches");
  return fmt::format(
      "{}: build {} ms, {} Mrays/s, {}", label, field("build_ms_median"), field("trace_mrays_median"),
      mismatches.empty() ? "no reference" : mismatches + (mismatches == "1" ? " mismatch" : " mismatches"));
}

void add_note(CsvRow& row, const std::string& note) {
  std::string& notes = row["notes"];
  if (!notes.empty()) notes += "; ";
  notes += note;
}

}  // namespace sahbench
