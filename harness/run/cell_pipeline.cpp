#include "harness/run/cell_pipeline.h"

#include <fmt/format.h>

#include <algorithm>

#include "builders/registry.h"
#include "core/epo.h"
#include "core/error.h"
#include "core/memory_tracker.h"
#include "core/refit.h"
#include "harness/embree/embree_trace.h"
#include "harness/run/result_row.h"
#include "harness/run/round_order.h"

namespace sahbench {

int64_t MemoryMeter::bytes() const {
  return device ? device->bytes() : heap_bytes();
}

void MemoryMeter::reset_peak() const {
  if (device)
    device->reset_peak();
  else
    reset_heap_peak();
}

int64_t MemoryMeter::peak() const {
  return device ? device->peak_bytes() : heap_peak_bytes();
}

namespace {

void make_timed(TreeSource& source, const std::function<void()>& before_each) {
  before_each();
  if (source.release) source.release();
  const int64_t before = source.meter.bytes();
  source.meter.reset_peak();
  const double ms = source.make();
  if (source.ms.empty()) source.peak = source.meter.peak() - before;
  source.ms.push_back(ms);
}

}  // namespace

TreeSource our_build(std::string label, const BuilderInfo& builder, const ParamSet& params,
                     std::span<const Triangle> triangles, std::shared_ptr<Bvh> tree) {
  TreeSource source;
  source.label = std::move(label);
  source.release = [tree] { *tree = Bvh{}; };
  source.make = [tree, &builder, params, triangles] {
    return time_ms([&] { *tree = builder.build(BuildInput::from_triangles(triangles), params); });
  };
  return source;
}

TreeSource embree_build(std::string label, std::shared_ptr<EmbreeBuild> embree,
                        std::span<const Triangle> triangles, EmbreeQuality quality,
                        EmbreeSceneOptions options) {
  TreeSource source;
  source.label = std::move(label);
  source.meter.device = &embree->device;
  source.release = [embree] { embree->scene.reset(); };
  source.make = [embree, triangles, quality, options] {
    embree->scene = std::make_unique<EmbreeScene>(embree->device, triangles, quality, options);
    return embree->scene->commit_ms();
  };
  return source;
}

TreeSource our_refit(std::string label, Bvh& tree, std::span<const Triangle> triangles) {
  TreeSource source;
  source.label = std::move(label);
  source.make = [&tree, triangles] { return time_ms([&] { refit(tree, triangles); }); };
  return source;
}

TreeSource embree_refit(std::string label, std::shared_ptr<EmbreeBuild> embree,
                        std::span<const Triangle> triangles) {
  TreeSource source;
  source.label = std::move(label);
  source.meter.device = &embree->device;
  source.make = [embree, triangles] { return embree->scene->update_vertices(triangles); };
  return source;
}

void time_sources(std::span<TreeSource* const> sources, const Repetitions& reps, uint64_t seed,
                  const std::function<void()>& before_each, const std::function<void(int round)>& on_round) {
  if (!reps.interleave) {
    // Each source warmed right before its own timed makes, as time_cells does for traces.
    for (TreeSource* source : sources) {
      for (int w = 0; w < reps.build_warmup; ++w) {
        if (source->release) source->release();
        source->make();
      }
      for (int r = 0; r < reps.build; ++r) make_timed(*source, before_each);
    }
    return;
  }
  for (int w = 0; w < reps.build_warmup; ++w)
    for (TreeSource* source : sources) {
      if (source->release) source->release();
      source->make();
    }
  for (int r = 0; r < reps.build; ++r) {
    if (on_round) on_round(r);
    for (const std::size_t k : round_order(seed, sources.size(), r)) make_timed(*sources[k], before_each);
  }
}

CheckedTree check_tree(const Bvh& bvh, std::span<const Triangle> triangles, const ParamSet& params,
                       bool with_epo) {
  CheckedTree out;
  out.report = validate(bvh, triangles);
  out.cost = sah_cost_of(params);
  if (out.ok()) out.stats = compute_stats(bvh, triangles.size(), out.cost);
  if (out.ok() && with_epo) out.epo_ms = time_ms([&] { out.epo = epo_cost(bvh, triangles, out.cost); });
  return out;
}

std::optional<double> source_sah_cost(std::span<const Triangle> triangles, const ParamSet& params) {
  if (!params.has("source") || params.get_source("source").shared()) return std::nullopt;
  return sah_cost(build_source(BuildInput::from_triangles(triangles), params), sah_cost_of(params));
}

void put_invalid_tree(CsvRow& row, const Bvh& bvh, const ValidationReport& report) {
  row["nodes"] = std::to_string(bvh.nodes.size());
  row["arity"] = std::to_string(bvh.arity);
  add_note(row, "invalid tree, not traced: " + report.errors.front());
}

void put_our_layout(CsvRow& row, const CompiledLayout& layout, const Bvh& bvh, const CheckedTree& tree,
                    std::size_t scene_triangles, int64_t peak) {
  row["isa"] = layout.isa();
  row["mem_bytes"] = std::to_string(layout.bytes());
  row["bytes_per_tri"] = bytes_per_triangle(layout.bytes(), scene_triangles);
  row["mem_peak_bytes"] = tracking_enabled() ? std::to_string(peak) : "";
  put_tree_stats(row, tree.stats, tree.cost);
  if (tree.epo) put_epo(row, *tree.epo, tree.stats.sah_cost);
  if (tree.source_sah) row["source_sah_cost"] = fmt::format("{:.6f}", *tree.source_sah);
  row["arity"] = std::to_string(bvh.arity);
}

void put_embree_scene(CsvRow& row, const EmbreeScene& scene, const EmbreeDevice& device,
                      std::size_t scene_triangles, int64_t peak) {
  row["isa"] = "embree:" + embree_isa(device);
  row["mem_bytes"] = std::to_string(scene.bytes());
  row["bytes_per_tri"] = bytes_per_triangle(static_cast<std::size_t>(scene.bytes()), scene_triangles);
  row["mem_peak_bytes"] = std::to_string(peak);
}

TimedCompile compile_timed(const LayoutSpec& spec, const Bvh& bvh, std::span<const Triangle> triangles,
                           const Repetitions& reps) {
  TimedCompile out;
  std::vector<double> compile_ms;
  for (int r = 0; r < std::max(1, reps.build); ++r) {
    out.layout.reset();
    compile_ms.push_back(time_ms([&] { out.layout = compile_layout(spec, bvh, triangles); }));
  }
  out.time = summarize(std::move(compile_ms));
  return out;
}

namespace {

TraceCell new_cell(CsvRow row, std::string label, const RaySet& rs, std::size_t set_index) {
  TraceCell cell;
  cell.row = std::move(row);
  put_ray_set(cell.row, rs);
  cell.label = std::move(label);
  cell.set = &rs;
  cell.set_index = set_index;
  cell.hits = std::make_shared<std::vector<Hit>>(rs.occlusion ? 0 : rs.rays.size());
  cell.occluded = std::make_shared<std::vector<uint8_t>>(rs.occlusion ? rs.rays.size() : 0);
  return cell;
}

}  // namespace

TraceCell our_cell(CsvRow row, std::string label, std::shared_ptr<const CompiledLayout> layout,
                   const RaySet& rs, std::size_t set_index, std::optional<SahCost> cost) {
  TraceCell cell = new_cell(std::move(row), std::move(label), rs, set_index);
  cell.cost = cost;
  const CompiledLayout* l = layout.get();
  const RaySet* set = &rs;
  cell.trace = [l, set, hits = cell.hits, occluded = cell.occluded] {
    if (set->occlusion)
      l->trace_any(set->rays, *occluded);
    else
      l->trace_closest(set->rays, *hits);
  };
  cell.count = [l, set] { return set->occlusion ? l->count_any(set->rays) : l->count_closest(set->rays); };
  cell.keep_alive = std::move(layout);
  return cell;
}

TraceCell embree_cell(CsvRow row, std::string label, const EmbreeScene& scene, const EmbreeLayout& layout,
                      const RaySet& rs, std::size_t set_index, std::shared_ptr<const void> keep_alive) {
  // Embree's assertion would stop the process (and the run) on such a ray: an error naming it instead.
  check_embree_range(rs.rays, "ray set '" + rs.name + "'");
  TraceCell cell = new_cell(std::move(row), std::move(label), rs, set_index);
  const EmbreeScene* s = &scene;
  const RaySet* set = &rs;
  cell.trace = [s, set, layout, hits = cell.hits, occluded = cell.occluded] {
    if (set->occlusion)
      embree_trace_any(*s, layout, set->rays, *occluded);
    else
      embree_trace_closest(*s, layout, set->rays, *hits);
  };
  cell.keep_alive = std::move(keep_alive);
  return cell;
}

void time_cells(std::vector<TraceCell>& cells, const Repetitions& reps, uint64_t seed,
                const std::function<void()>& before_each, const std::function<void(int round)>& on_round) {
  auto time_once = [&](TraceCell& cell) {
    before_each();
    // A pass too short for the clock (an empty set) counts as 1 ns rather than dividing by zero.
    const double ms = std::max(time_ms(cell.trace), 1e-6);
    cell.mrays.push_back(static_cast<double>(cell.set->rays.size()) / (ms * 1e3));
  };
  if (!reps.interleave) {
    for (auto& cell : cells) {
      for (int w = 0; w < reps.trace_warmup; ++w) cell.trace();
      for (int r = 0; r < reps.trace; ++r) time_once(cell);
    }
    return;
  }
  for (auto& cell : cells)
    for (int w = 0; w < reps.trace_warmup; ++w) cell.trace();
  for (int r = 0; r < reps.trace && !cells.empty(); ++r) {
    if (on_round) on_round(r);
    for (const std::size_t k : round_order(seed, cells.size(), r)) time_once(cells[k]);
  }
}

void finish_cell(TraceCell& cell, const Reference& ref, float scene_diagonal) {
  put_timing(cell.row, "trace_mrays", summarize(cell.mrays));
  if (cell.count) put_per_ray_counts(cell.row, cell.count(), cell.cost);
  put_hit_fraction(cell.row, *cell.hits, *cell.occluded);
  put_mismatches(cell.row, ref, *cell.set, scene_diagonal, *cell.hits, *cell.occluded);
}

}  // namespace sahbench
