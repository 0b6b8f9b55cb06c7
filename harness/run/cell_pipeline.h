#pragma once
// The one pipeline every cell of every experiment goes through: a tree from its source (one of our
// builders, a refit of one of our trees, Embree's build or its refit), timed in rounds; the tree checked
// before anything walks it, then its statistics; its layout compiled (or refitted); the cell traced in
// timed rounds, counted, checked against the reference, and completed into a row. The static, animation
// and stress experiments are plans over these steps: they decide which cells run and in what order.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "builders/params.h"
#include "builders/registry.h"
#include "core/bvh.h"
#include "core/bvh_stats.h"
#include "core/sah.h"
#include "core/triangle.h"
#include "core/validate.h"
#include "harness/config/config.h"
#include "harness/embree/embree_layouts.h"
#include "harness/embree/embree_scene.h"
#include "harness/run/csv.h"
#include "harness/run/ray_sets.h"
#include "harness/run/reference.h"
#include "harness/run/timing.h"
#include "traversal/layout.h"

namespace sahbench {

/// Where the bytes of a tree source are counted: the process heap (memory_tracker.h) for ours, or an
/// Embree device, which allocates outside the heap.
struct MemoryMeter {
  EmbreeDevice* device = nullptr;  ///< null: the heap
  int64_t bytes() const;
  void reset_peak() const;
  int64_t peak() const;
};

/// A tree made afresh on every call of `make`, which returns the step's own time in ms (for Embree
/// rtcCommitScene's, measured inside EmbreeScene). `release` (may be empty) frees the last tree, untimed,
/// before the next is made, so that no repetition pays for freeing the one before. time_sources fills
/// `ms` and `peak`.
struct TreeSource {
  std::string label;  ///< for the log
  std::function<double()> make;
  std::function<void()> release;
  MemoryMeter meter;
  std::vector<double> ms;  ///< every timed make, in the order taken
  int64_t peak = 0;        ///< bytes allocated at the peak of the first timed make
  TimingSummary time() const { return summarize(ms); }
};

/// An Embree scene and the device it lives in, kept together for the cells that trace it.
struct EmbreeBuild {
  explicit EmbreeBuild(int threads) : device(threads) {}
  EmbreeDevice device;
  std::unique_ptr<EmbreeScene> scene;
};

/// One of our builders on `triangles` (which must outlive the source), into `tree`.
TreeSource our_build(std::string label, const BuilderInfo& builder, const ParamSet& params,
                     std::span<const Triangle> triangles, std::shared_ptr<Bvh> tree);

/// Embree's rtcCommitScene on `triangles` at `quality` with the scene flags of `options`, into
/// `embree->scene`; the bytes are the device's.
TreeSource embree_build(std::string label, std::shared_ptr<EmbreeBuild> embree,
                        std::span<const Triangle> triangles, EmbreeQuality quality,
                        EmbreeSceneOptions options = {});

/// `tree`, built on another frame of an animation, refitted in place to `triangles` (core/refit.h); every
/// refit recomputes every box, so repeating it on one frame times the same work.
TreeSource our_refit(std::string label, Bvh& tree, std::span<const Triangle> triangles);

/// Embree's refit (rtcCommitScene after the vertices moved) of `embree->scene`, made with
/// EmbreeQuality::kRefit, to `triangles`.
TreeSource embree_refit(std::string label, std::shared_ptr<EmbreeBuild> embree,
                        std::span<const Triangle> triangles);

/// Times `sources` as every experiment does: `reps.build_warmup` untimed makes of each, then
/// `reps.build` rounds. Interleaved (reps.interleave), each round makes every source once, in the
/// round's own shuffle of `seed` (round_order.h), so that a slow spell of the machine falls on all of
/// them alike; otherwise each source's warm-ups and rounds run back to back. `before_each` runs before every
/// timed make (an interrupt check), `on_round` (if any) before each interleaved round (progress).
void time_sources(std::span<TreeSource* const> sources, const Repetitions& reps, uint64_t seed,
                  const std::function<void()>& before_each,
                  const std::function<void(int round)>& on_round = {});

/// A tree of ours, checked: the validator's report first, and the statistics only of a valid tree
/// (compute_stats walks nodes[] unchecked, so a child index out of range must not reach it).
struct CheckedTree {
  ValidationReport report;
  SahCost cost;
  BvhStats stats;  ///< zero for an invalid tree
  /// The EPO cost by `cost` (core/epo.h), where asked for and the tree is valid, and the time it took (ms).
  std::optional<double> epo;
  double epo_ms = 0.0;
  /// A pass's: the SAH cost, by `cost`, of the tree it started from (source_sah_cost), for the row's
  /// source_sah_cost column.
  std::optional<double> source_sah;
  bool ok() const { return report.ok(); }
};
/// `with_epo`: also the EPO cost, a walk of the tree per triangle (the config's experiment.epo).
CheckedTree check_tree(const Bvh& bvh, std::span<const Triangle> triangles, const ParamSet& params,
                       bool with_epo);

/// The SAH cost, by the constants of `params`, of the tree a pass starts from: its tree source built again
/// here (untimed) on `triangles`. Nullopt for a builder without a source of its own (not a pass, or
/// wide_collapse's shared sources, which it builds itself).
std::optional<double> source_sah_cost(std::span<const Triangle> triangles, const ParamSet& params);

/// The row of a cell whose tree is invalid: nodes, arity, and a note naming the validator's first error.
/// Its cells are not traced (a broken tree can read out of bounds).
void put_invalid_tree(CsvRow& row, const Bvh& bvh, const ValidationReport& report);

/// The columns of a cell traced with a layout of ours: isa, mem_bytes, bytes_per_tri, mem_peak_bytes (the
/// tree source's `peak`, where the heap is tracked), arity and the tree's statistics (with epo_cost and
/// sah_epo_cost where the tree has an EPO cost).
void put_our_layout(CsvRow& row, const CompiledLayout& layout, const Bvh& bvh, const CheckedTree& tree,
                    std::size_t scene_triangles, int64_t peak);

/// The same columns for an Embree scene: isa ("embree:" and the device's), mem_bytes, bytes_per_tri and
/// mem_peak_bytes (the device's).
void put_embree_scene(CsvRow& row, const EmbreeScene& scene, const EmbreeDevice& device,
                      std::size_t scene_triangles, int64_t peak);

/// A layout compiled max(1, reps.build) times, each after freeing the one before: the last compile and
/// the times of all (ms).
struct TimedCompile {
  std::unique_ptr<CompiledLayout> layout;
  TimingSummary time;
};
TimedCompile compile_timed(const LayoutSpec& spec, const Bvh& bvh, std::span<const Triangle> triangles,
                           const Repetitions& reps);

/// A cell ready for its timed rounds: its row so far, one pass of its kernel over its ray set (writing
/// `hits`, or `occluded` for an any-hit set), the counting pass (empty for Embree, which has none), the
/// rays/s of each timed pass, and what keeps its tree and layout alive.
struct TraceCell {
  CsvRow row;
  std::string label;  ///< scene, builder, layout, threads and ray set, for the log
  const RaySet* set = nullptr;
  std::size_t set_index = 0;  ///< into the plan's ray sets and references
  std::function<void()> trace;
  std::function<TraceCounts()> count;
  /// The tree's cost model, for cost_per_ray from the counting pass; empty for Embree's cells.
  std::optional<SahCost> cost;
  std::shared_ptr<std::vector<Hit>> hits;
  std::shared_ptr<std::vector<uint8_t>> occluded;
  std::shared_ptr<const void> keep_alive;
  std::vector<double> mrays;
};

/// A cell tracing `rs` with a layout of ours (trace_closest or trace_any, and the matching count). `rs`
/// and `keep_alive`, which must keep `layout` alive, outlive the cell. `cost`: the tree's cost model, for
/// the row's cost_per_ray (empty where the CSV has no such column).
TraceCell our_cell(CsvRow row, std::string label, std::shared_ptr<const CompiledLayout> layout,
                   const RaySet& rs, std::size_t set_index, std::optional<SahCost> cost);

/// A cell tracing `rs` with Embree's `layout` (rtcIntersect1/rtcOccluded1, or packets of its width) in
/// `scene`, which `keep_alive` keeps alive with its device.
TraceCell embree_cell(CsvRow row, std::string label, const EmbreeScene& scene, const EmbreeLayout& layout,
                      const RaySet& rs, std::size_t set_index, std::shared_ptr<const void> keep_alive);

/// Times the traces of `cells`: `reps.trace_warmup` untimed passes of each, then `reps.trace` timed
/// rounds. Interleaved, round r traces every cell once in round_order(seed, n, r); otherwise each cell's
/// rounds run back to back. `before_each` runs before every timed pass, `on_round` (may be empty) before
/// each interleaved round.
void time_cells(std::vector<TraceCell>& cells, const Repetitions& reps, uint64_t seed,
                const std::function<void()>& before_each, const std::function<void(int round)>& on_round);

/// Completes a timed cell's row: trace_mrays (median, min, max, samples), nodes and primitives per ray
/// from the counting pass (and cost_per_ray, by the cell's cost model), hit_fraction, and the mismatches of
/// its last pass against `ref`.
void finish_cell(TraceCell& cell, const Reference& ref, float scene_diagonal);

}  // namespace sahbench
