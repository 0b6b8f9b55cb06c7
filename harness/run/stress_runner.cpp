#include "harness/run/stress_runner.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <ostream>
#include <set>

#include "builders/registry.h"
#include "core/build_input.h"
#include "core/bvh_stats.h"
#include "core/error.h"
#include "core/validate.h"
#include "harness/config/config.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "harness/run/bounded_run.h"
#include "harness/run/cell_pipeline.h"
#include "harness/run/csv.h"
#include "harness/run/environment.h"
#include "harness/run/result_row.h"
#include "harness/run/run_common.h"
#include "harness/run/run_session.h"
#include "harness/run/stress_metrics.h"
#include "harness/run/timing.h"
#include "traversal/exact_reference.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

// Columns after DESIGN.md's and the metrics: what the case was, and how the run went.
const std::vector<std::string>& extra_columns() {
  static const std::vector<std::string> columns = {
      "config",        "case_kind",     "case_seed",          "case_size",
      "closed",        "scene_removed", "invalid_made",       "exact_hits",
      "must_hit_rays", "reference_ms",  "build_time_limit_s", "embree_version",
      "notes",         "sah_block",     "leaves_per_ray"};
  return columns;
}

std::vector<std::string> all_columns() {
  std::vector<std::string> c = design_columns();
  c.insert(c.end(), stress_metric_columns().begin(), stress_metric_columns().end());
  c.insert(c.end(), extra_columns().begin(), extra_columns().end());
  return c;
}

// Nodes with a NaN anywhere in their box.
uint64_t count_nan_bounds(const Bvh& bvh) {
  uint64_t n = 0;
  for (const Node& node : bvh.nodes) {
    const Aabb& b = node.bounds;
    n += std::isnan(b.min.x) || std::isnan(b.min.y) || std::isnan(b.min.z) || std::isnan(b.max.x) ||
         std::isnan(b.max.y) || std::isnan(b.max.z);
  }
  return n;
}

// Where the default kernels' no-leak guarantee holds. The watertight test (traversal/triangle_tests.h)
// finishes in double where its float products overflow or underflow, but it still subtracts the ray
// origin and shears in float, which holds while coordinates stay below about FLT_MAX / 4 = 8.5e37; the
// guarantee is asserted on closed cases whose triangles and ray origins lie within +-1e36. Cases beyond
// it still count their leaks in the CSV.
constexpr double kWatertightRange = 1e36;

bool within_watertight_range(const StressCase& c) {
  auto within = [](Vec3 p) {
    return std::abs(p.x) <= kWatertightRange && std::abs(p.y) <= kWatertightRange &&
           std::abs(p.z) <= kWatertightRange;
  };
  for (const Triangle& t : c.scene.triangles)
    if (!within(t.v0) || !within(t.v1) || !within(t.v2)) return false;
  for (const Ray& r : c.rays)
    if (!within(r.org)) return false;
  return true;
}

struct BuiltTree {
  Bvh bvh;
  double ms = 0.0;
};

// Embree's own BVH: the device must outlive the scene (members are destroyed in reverse order).
struct EmbreeBuilt {
  std::unique_ptr<EmbreeDevice> device;
  std::unique_ptr<EmbreeScene> scene;
};

std::string metrics_summary(const ErrorMetrics& m) {
  return fmt::format(
      "false misses {}, false hits {}, wrong prim {}, leaks {}, t err max {} ulps ({} clear of "
      "the origin)",
      m.false_misses, m.false_hits, m.wrong_prim, m.leaks, m.t_err_ulps_max, m.t_err_ulps_max_clear);
}

class StressRunner {
 public:
  StressRunner(const StressConfig& cfg, const StressOptions& options, std::ostream& log)
      : cfg_(cfg),
        options_(options),
        log_(log),
        env_(current_environment()),
        run_id_(make_run_id(cfg.name)) {}

  StressSummary run() {
    auto selected = [&](const StressCaseSpec& spec) {
      return options_.only.empty() || spec.name.find(options_.only) != std::string::npos;
    };
    // A filter that matches nothing is a typo, not a run that passed: said before the output is created.
    if (!options_.only.empty() && std::none_of(cfg_.cases.begin(), cfg_.cases.end(), selected)) {
      std::string names;
      for (const StressCaseSpec& spec : cfg_.cases) names += (names.empty() ? "" : ", ") + spec.name;
      throw Error(fmt::format("--only '{}' matches no case of {} (its cases: {})", options_.only,
                              cfg_.path.string(), names));
    }
    const std::filesystem::path output = options_.output ? *options_.output : cfg_.output;
    if (output.has_parent_path()) std::filesystem::create_directories(output.parent_path());
    const OutputLock lock(output);
    CsvWriter csv(output, all_columns());
    csv_ = &csv;
    log_ << fmt::format(
        "stress run {}: {} cases, builders {}, {} layout variants, Embree modes {}; writing {}\n", run_id_,
        cfg_.cases.size(), builder_labels(), cfg_.layouts.size(), cfg_.embree_robust.size(), output.string());
    layouts_ = runnable_specs(cfg_.layouts, log_);  // as `sahbench run` skips them
    const auto start = std::chrono::steady_clock::now();
    // Ctrl-C stops between cases, and says what was kept: the suite has no --resume (it runs in minutes).
    const InterruptGuard interrupts;
    const auto total =
        static_cast<std::size_t>(std::count_if(cfg_.cases.begin(), cfg_.cases.end(), selected));
    std::size_t done = 0;
    for (const StressCaseSpec& spec : cfg_.cases) {
      if (!selected(spec)) continue;
      InterruptGuard::check(
          done, total,
          fmt::format("sahbench stress {}{}{} (the rows of the finished cases are in {}; the suite has no "
                      "--resume and runs them again)",
                      cfg_.path.string(), options_.only.empty() ? "" : " --only '" + options_.only + "'",
                      options_.output ? " --output '" + options_.output->string() + "'" : "",
                      output.string()),
          "cases");
      log_ << fmt::format("[{}/{}] ", done + 1, total);
      run_case(spec);
      ++done;
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    log_ << fmt::format("done in {:.1f} s: {} rows, {} guarantee failures\n", s, summary_.rows,
                        summary_.failures.size());
    for (const auto& f : summary_.failures) log_ << "FAILED: " << f << "\n";
    return summary_;
  }

 private:
  // Everything about the current case that every row repeats.
  struct CaseContext {
    const StressCase* c = nullptr;
    std::shared_ptr<const std::vector<Triangle>> triangles;
    RaySet rays;  // the case's rays as one closest-hit set
    std::vector<ExactHit> exact;
    double reference_ms = 0.0;
    uint64_t must_hit = 0;
    bool guaranteed = false;  // closed, within kWatertightRange: the default kernels must not miss
  };

  void fail(std::string what) {
    log_ << "  FAILED: " << what << "\n";
    summary_.failures.push_back(std::move(what));
  }

  void run_case(const StressCaseSpec& spec) {
    CaseContext ctx;
    StressCase c;
    const double gen_ms = time_ms([&] { c = generate_stress_case(spec); });
    ctx.c = &c;
    ctx.triangles = std::make_shared<const std::vector<Triangle>>(c.scene.triangles);
    ctx.rays = {.name = "stress", .kind = RayKind::kRandom, .rays = c.rays};
    ctx.guaranteed = c.closed && within_watertight_range(c);
    ctx.reference_ms = time_ms([&] { ctx.exact = ExactReference(*ctx.triangles).closest(c.rays); });
    uint64_t exact_hits = 0, ties = 0, must_hit_missed = 0;
    for (std::size_t i = 0; i < c.rays.size(); ++i) {
      exact_hits += ctx.exact[i].found();
      ties += ctx.exact[i].tied.size() > 1;
      ctx.must_hit += c.must_hit[i];
      must_hit_missed += c.must_hit[i] && !ctx.exact[i].found();
    }
    log_ << fmt::format(
        "case {} ({}): {} triangles ({} removed), {} rays ({} hit exactly, {} ties, {} must hit); "
        "generated in {:.0f} ms, exact reference {:.0f} ms\n",
        spec.name, spec.kind, c.scene.triangles.size(), c.scene.removed.total(), c.rays.size(), exact_hits,
        ties, ctx.must_hit, gen_ms, ctx.reference_ms);
    if (c.closed && !ctx.guaranteed)
      log_ << fmt::format(
          "  closed, but beyond +-{:g}: the default kernels' no-leak guarantee is not asserted\n",
          kWatertightRange);
    if (c.scene.removed.total() != c.invalid_made)
      fail(fmt::format("case {}: the filter removed {} triangles, the generator made {} invalid ones",
                       spec.name, c.scene.removed.total(), c.invalid_made));
    if (must_hit_missed)
      fail(fmt::format("case {}: {} rays flagged must-hit miss exactly (a generator error)", spec.name,
                       must_hit_missed));

    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(cfg_.threads));
    std::set<uint32_t> arities_with_variants;
    for (const BuilderRun& builder : cfg_.builders) run_builder(ctx, builder, arities_with_variants);
    for (const bool robust : cfg_.embree_robust) run_embree(ctx, robust);
  }

  CsvRow base_row(const CaseContext& ctx) const {
    const StressCase& c = *ctx.c;
    CsvRow row;
    row["run_id"] = run_id_;
    row["git_commit"] = env_.git_commit;
    row["cpu"] = env_.cpu;
    row["compiler"] = env_.compiler;
    row["threads"] = std::to_string(cfg_.threads);
    row["scene"] = c.spec.name;
    row["scene_triangles"] = std::to_string(c.scene.triangles.size());
    row["frame"] = "0";
    row["build_reps"] = "1";
    row["ray_set"] = "stress";
    row["ray_count"] = std::to_string(c.rays.size());
    row["reference"] = "exact";
    row["config"] = cfg_.path.string();
    row["case_kind"] = c.spec.kind;
    row["case_seed"] = std::to_string(c.spec.seed);
    row["case_size"] = std::to_string(c.spec.size);
    row["closed"] = c.closed ? "1" : "0";
    row["scene_removed"] = std::to_string(c.scene.removed.total());
    row["invalid_made"] = std::to_string(c.invalid_made);
    uint64_t exact_hits = 0;
    for (const ExactHit& e : ctx.exact) exact_hits += e.found();
    row["exact_hits"] = std::to_string(exact_hits);
    row["must_hit_rays"] = std::to_string(ctx.must_hit);
    row["reference_ms"] = fmt::format("{:.1f}", ctx.reference_ms);
    row["build_time_limit_s"] = fmt::format("{}", cfg_.build_time_limit_s);
    row["embree_version"] = env_.embree;
    row["build_failed"] = "0";
    return row;
  }

  void write(const CsvRow& row) {
    csv_->append(row);
    ++summary_.rows;
  }

  static void put_build(CsvRow& row, double ms) {
    for (const char* suffix : {"_median", "_min", "_max"})
      row[std::string("build_ms") + suffix] = fmt::format("{:.4f}", ms);
  }

  // Times a cell's closest-hit traces back to back (the pipeline's time_cells), compares its last pass
  // with the exact answers and fills the row. `index`: where each of the cell's rays sits among the
  // case's, when it traces only some of them (the rest count as misses); null when it traces all.
  ErrorMetrics put_trace(CsvRow& row, TraceCell& cell, const CaseContext& ctx,
                         const std::vector<std::size_t>* index = nullptr) const {
    Repetitions reps;
    reps.trace = cfg_.trace_reps;
    reps.trace_warmup = cfg_.trace_warmup;
    reps.interleave = false;
    std::vector<TraceCell> one;
    one.push_back(std::move(cell));
    time_cells(one, reps, 0, [] {}, {});
    cell = std::move(one.front());
    put_timing(row, "trace_mrays", summarize(cell.mrays));
    row["trace_reps"] = std::to_string(cfg_.trace_reps);
    std::vector<Hit> all;
    if (index) {
      all.assign(ctx.c->rays.size(), Hit{});
      for (std::size_t k = 0; k < index->size(); ++k) all[(*index)[k]] = (*cell.hits)[k];
    }
    const ErrorMetrics m = measure_errors(index ? all : *cell.hits, ctx.exact, ctx.c->must_hit, ctx.c->rays);
    row["mismatches"] = std::to_string(m.errors());
    row["false_misses"] = std::to_string(m.false_misses);
    row["false_hits"] = std::to_string(m.false_hits);
    row["wrong_prim"] = std::to_string(m.wrong_prim);
    row["wrong_prim_far"] = std::to_string(m.wrong_prim_far);
    row["ties"] = std::to_string(m.ties);
    row["t_err_ulps_max"] = std::to_string(m.t_err_ulps_max);
    row["t_err_ulps_mean"] = fmt::format("{:.3f}", m.t_err_ulps_mean);
    row["t_err_ulps_max_clear"] = std::to_string(m.t_err_ulps_max_clear);
    row["leaks"] = std::to_string(m.leaks);
    if (cell.count) put_per_ray_counts(row, cell.count(), std::nullopt);
    return m;
  }

  // The layout specs a tree of `arity` is traced with: every configured variant for the first tree of
  // that arity, only the default kernels for the others.
  std::vector<LayoutSpec> layouts_for(uint32_t arity, std::set<uint32_t>& arities_with_variants) const {
    const bool all_variants = arities_with_variants.insert(arity).second;
    std::vector<LayoutSpec> out;
    for (const LayoutSpec& spec : layouts_) {
      if (find_layout(spec.name).arity != arity) continue;
      if (all_variants || spec.variant == KernelVariant{}) out.push_back(spec);
    }
    return out;
  }

  std::string builder_labels() const {
    std::vector<std::string> labels;
    for (const BuilderRun& b : cfg_.builders) labels.push_back(b.label());
    return fmt::format("{}", fmt::join(labels, " "));
  }

  void run_builder(const CaseContext& ctx, const BuilderRun& spec,
                   std::set<uint32_t>& arities_with_variants) {
    const StressCase& c = *ctx.c;
    const BuilderInfo* info = spec.info;
    const ParamSet params = spec.values;
    CsvRow row = base_row(ctx);
    row["builder"] = info->name;
    row["builder_params"] = params.to_string();
    row["isa"] = env_.isa;
    const std::string label = fmt::format("case {}: builder {}", c.spec.name, spec.label());

    // The build owns copies of what it uses, so that an abandoned build cannot outlive its inputs.
    auto triangles = ctx.triangles;
    const BoundedResult<BuiltTree> built = run_bounded<BuiltTree>(
        [info, params, triangles] {
          BuiltTree out;
          out.ms = time_ms([&] { out.bvh = info->build(BuildInput::from_triangles(*triangles), params); });
          return out;
        },
        cfg_.build_time_limit_s);
    std::string failure;
    if (built.timed_out) {
      ++summary_.abandoned_builds;
      failure =
          fmt::format("still running after the time bound of {} s (abandoned)", cfg_.build_time_limit_s);
    } else if (!built.value) {
      failure = "threw: " + built.error;
    }
    if (!failure.empty()) {
      row["build_failed"] = "1";
      row["notes"] = "build " + failure;
      write(row);
      fail(label + ": build " + failure);
      return;
    }
    const Bvh& bvh = built.value->bvh;
    put_build(row, built.value->ms);
    const uint64_t nan_bounds = count_nan_bounds(bvh);
    row["nan_bounds"] = std::to_string(nan_bounds);
    row["arity"] = std::to_string(bvh.arity);
    const CheckedTree checked = check_tree(bvh, *ctx.triangles, params, /*with_epo=*/false);
    if (!checked.ok() || nan_bounds) {
      row["build_failed"] = "1";
      row["notes"] = "invalid tree, not traced: " +
                     (checked.ok() ? std::string("NaN bounds") : checked.report.errors.front());
      write(row);
      fail(label + ": " + row["notes"]);
      return;
    }
    put_tree_stats(row, checked.stats, checked.cost);

    const std::vector<LayoutSpec> specs = layouts_for(bvh.arity, arities_with_variants);
    if (specs.empty()) {
      row["notes"] = fmt::format("built and validated; no configured layout traverses arity {}", bvh.arity);
      write(row);
      log_ << fmt::format("  {} {}: build {:.1f} ms; {}\n", info->name, params.to_string(), built.value->ms,
                          row["notes"]);
      return;
    }
    for (const LayoutSpec& layout : specs) {
      CsvRow r = row;
      r["layout"] = layout.text();
      try {
        std::shared_ptr<const CompiledLayout> compiled;
        r["layout_ms"] =
            fmt::format("{:.4f}", time_ms([&] { compiled = compile_layout(layout, bvh, *ctx.triangles); }));
        r["isa"] = compiled->isa();
        r["mem_bytes"] = std::to_string(compiled->bytes());
        // The stress CSV has no cost_per_ray column.
        TraceCell cell = our_cell({}, label, compiled, ctx.rays, 0, std::nullopt);
        const ErrorMetrics m = put_trace(r, cell, ctx);
        log_ << fmt::format("  {} {}: {} Mrays/s; {}\n", info->name, r["layout"], r["trace_mrays_median"],
                            metrics_summary(m));
        if (ctx.guaranteed && layout.variant == KernelVariant{} && (m.false_misses || m.leaks))
          fail(fmt::format(
              "{} layout {}: the default kernels have {} false misses and {} leaks on a closed case", label,
              r["layout"], m.false_misses, m.leaks));
        if (layout.variant == KernelVariant{} && m.t_err_ulps_max_clear > kMaxClearTErrorUlps)
          fail(
              fmt::format("{} layout {}: the default kernels' t is {} ulps from the exact one on a hit clear "
                          "of the origin (the bound is {})",
                          label, r["layout"], m.t_err_ulps_max_clear, kMaxClearTErrorUlps));
      } catch (const Error& e) {
        r["notes"] = std::string("trace failed: ") + e.what();
        fail(label + " layout " + r["layout"] + ": " + r["notes"]);
      }
      write(r);
    }
  }

  void run_embree(const CaseContext& ctx, bool robust) {
    CsvRow row = base_row(ctx);
    row["builder"] = "embree";
    row["builder_params"] = std::string("quality=medium;mode=") + (robust ? "robust" : "default");
    row["layout"] = "embree_1";
    const std::string label =
        fmt::format("case {}: embree {}", ctx.c->spec.name, robust ? "robust" : "default");
    auto triangles = ctx.triangles;
    const int threads = cfg_.threads;
    const BoundedResult<std::shared_ptr<EmbreeBuilt>> built = run_bounded<std::shared_ptr<EmbreeBuilt>>(
        [triangles, threads, robust] {
          auto out = std::make_shared<EmbreeBuilt>();
          out->device = std::make_unique<EmbreeDevice>(threads);
          EmbreeSceneOptions options;
          options.robust = robust;
          out->scene =
              std::make_unique<EmbreeScene>(*out->device, *triangles, EmbreeQuality::kMedium, options);
          return out;
        },
        cfg_.build_time_limit_s);
    if (!built.value) {
      if (built.timed_out) ++summary_.abandoned_builds;
      row["build_failed"] = "1";
      row["notes"] = built.timed_out ? "build still running after the time bound (abandoned)"
                                     : "build threw: " + built.error;
      write(row);
      fail(label + ": " + row["notes"]);
      return;
    }
    const EmbreeBuilt& embree = **built.value;
    put_build(row, embree.scene->commit_ms());
    row["isa"] = "embree:" + embree_isa(*embree.device);
    row["mem_bytes"] = std::to_string(embree.scene->bytes());
    // Rays Embree's kernels reject: they are reported as misses without being traced.
    RaySet accepted{.name = "stress", .kind = RayKind::kRandom};
    std::vector<std::size_t> accepted_index;
    for (std::size_t i = 0; i < ctx.c->rays.size(); ++i)
      if (embree_accepts(ctx.c->rays[i])) {
        accepted.rays.push_back(ctx.c->rays[i]);
        accepted_index.push_back(i);
      }
    const std::size_t rejected = ctx.c->rays.size() - accepted.rays.size();
    if (rejected)
      row["notes"] =
          fmt::format("{} rays beyond Embree's valid range (|org|, |dir| <= {:g}) counted as misses",
                      rejected, kEmbreeLargeFloat);
    try {
      TraceCell cell = embree_cell({}, label, *embree.scene, kEmbreeLayouts[0], accepted, 0, *built.value);
      const ErrorMetrics m = put_trace(row, cell, ctx, &accepted_index);
      log_ << fmt::format("  embree {}: {} Mrays/s; {}\n", robust ? "robust" : "default",
                          row["trace_mrays_median"], metrics_summary(m));
    } catch (const Error& e) {
      row["notes"] = std::string("trace failed: ") + e.what();
      fail(label + ": " + row["notes"]);
    }
    write(row);
  }

  const StressConfig& cfg_;
  std::vector<LayoutSpec> layouts_;  // those of cfg_ this CPU runs
  const StressOptions& options_;
  std::ostream& log_;
  Environment env_;
  std::string run_id_;
  CsvWriter* csv_ = nullptr;
  StressSummary summary_;
};

}  // namespace

const std::vector<std::string>& stress_metric_columns() {
  static const std::vector<std::string> columns = {
      "false_misses", "false_hits",     "wrong_prim",      "wrong_prim_far",
      "ties",         "t_err_ulps_max", "t_err_ulps_mean", "t_err_ulps_max_clear",
      "leaks",        "build_failed",   "nan_bounds"};
  return columns;
}

StressSummary run_stress(const StressOptions& options, std::ostream& log) {
  return run_stress(load_stress_config(options.config), options, log);
}

StressSummary run_stress(const StressConfig& config, const StressOptions& options, std::ostream& log) {
  for (const BuilderRun& run : config.builders) require_resolved(run);
  return StressRunner(config, options, log).run();
}

}  // namespace sahbench
