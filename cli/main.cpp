// The sahbench command line. Library code throws sahbench::Error; this is the one place that prints
// errors and chooses exit codes: 0 success, 1 a failed check (invalid tree), 2 bad input, 130 a run
// stopped by SIGINT or SIGTERM (its finished rows kept).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "builders/params.h"
#include "cli/build_command.h"
#include "cli/image_command.h"
#include "cli/list_command.h"
#include "cli/plan_command.h"
#include "cli/suggest.h"
#include "cli/trace_command.h"
#include "core/error.h"
#include "harness/config/config.h"
#include "harness/embree/embree_bvh_builder.h"
#include "harness/report/compare.h"
#include "harness/report/report.h"
#include "harness/run/run_session.h"
#include "harness/run/runner.h"
#include "harness/run/shard_merge.h"
#include "harness/run/shard_plan.h"
#include "harness/run/stress_runner.h"
#include "harness/run/tree_file_builder.h"

int main(int argc, char** argv) {
  using namespace sahbench;
  // Builders backed by Embree or by files live in the harness (builders/ must know neither); register
  // them before anything looks a builder up.
  register_embree_builders();
  register_tree_file_builder();
  CLI::App app{"sahbench: benchmark and research harness for SAH BVH builders"};
  app.require_subcommand(1);

  BuildCommandOptions build;
  std::vector<std::string> params, build_builders;
  auto* build_cmd =
      app.add_subcommand("build", "Load a scene, build, validate, and print build time and tree statistics");
  build_cmd->add_option("--scene", build.scene, "scene file, shared-scene name, or proc:KIND[:key=value,...]")
      ->required();
  build_cmd
      ->add_option("--builder", build_builders,
                   "builder NAME or NAME:key=value,...; repeatable; embree:quality=low|medium|high "
                   "(or embree_low|embree_medium|embree_high) for Embree's rtcCommitScene, "
                   "embree:quality=Q,robust=1 in its robust mode; vs_emb_m is the ratio to "
                   "embree_medium in its default mode")
      ->required();
  build_cmd->add_option("--param", params, "key=value for every one of our builders; repeatable");
  build_cmd->add_option("--threads", build.threads, "thread counts, e.g. 1,2")->delimiter(',');
  build_cmd->add_option("--reps", build.reps, "timed repetitions (median reported)")->capture_default_str();
  build_cmd->add_option("--warmup", build.warmup, "untimed builds first")->capture_default_str();
  build_cmd->add_option("--save", build.save,
                        "write the tree to this tree file (docs/tree_format.md); one builder of the common "
                        "format only; read it back with --builder file:PATH");

  RunOptions run;
  std::string run_output;
  auto* run_cmd = app.add_subcommand(
      "run", "Run an experiment config: cells of scene x builder x layout x threads x ray set");
  run_cmd->add_option("config", run.config, "experiment config (TOML)")->required();
  run_cmd->add_flag("--resume", run.resume, "skip cells whose rows are already in the output CSV");
  run_cmd->add_option(
      "--only", run.only,
      "run only cells whose key scene|builder|params|layout|threads|ray_set|frame contains this text "
      "(Embree's params: quality=Q, or quality=Q;robust=1 in its robust mode)");
  run_cmd->add_option("--output", run_output,
                      "CSV path instead of the config's (with --shard: the config's with -shard-K-of-N)");
  std::string run_shard;
  run_cmd->add_option("--shard", run_shard,
                      "K/N: run only shard K (0..N-1) of the plan `sahbench plan CONFIG --shards N` prints; "
                      "merge the shards' CSVs with `sahbench merge`");

  PlanCommandOptions plan;
  auto* plan_cmd = app.add_subcommand(
      "plan",
      "Cells of a config per scene, builder and layout, and their split into shards with estimated times");
  plan_cmd->add_option("config", plan.config, "experiment config (TOML)")->required();
  plan_cmd->add_option("--shards", plan.shards, "number of shards")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  plan_cmd->add_flag("--cells", plan.list_cells, "also list every cell with the shards that run it");
  plan_cmd->add_flag("!--no-calibration", plan.calibrate,
                     "skip the timed build that turns the estimate into seconds");

  MergeOptions merge;
  auto* merge_cmd = app.add_subcommand(
      "merge",
      "Merge the CSVs of a sweep's shards (run --shard K/N) into one run; exit 2 naming missing or "
      "duplicated cells and shards");
  merge_cmd->add_option("output", merge.output, "merged CSV (replaced)")->required();
  merge_cmd->add_option("shards", merge.shards, "the shards' CSVs")->required();
  merge_cmd->add_option("--config", merge.config,
                        "the config the shards ran (default: the one their rows name)");

  StressOptions stress;
  stress.config = "configs/stress.toml";
  std::string stress_output;
  auto* stress_cmd =
      app.add_subcommand("stress",
                         "Numerical stress suite: extreme generated cases, every builder, layout "
                         "variant and Embree mode against an exact reference");
  stress_cmd->add_option("config", stress.config, "stress config (TOML)")->capture_default_str();
  stress_cmd->add_option("--output", stress_output, "CSV path instead of the config's");
  stress_cmd->add_option("--only", stress.only, "run only cases whose name contains this text");

  ReportOptions report;
  std::string report_format = "markdown";
  auto* report_cmd = app.add_subcommand(
      "report", "Markdown, LaTeX or HTML tables from result CSVs, with ratios to Embree medium");
  report_cmd->add_option("csv", report.inputs, "result CSV files")->required();
  report_cmd->add_option("--run", report.run_id, "run_id to report (default: the latest)");
  std::string report_width = "single";
  report_cmd
      ->add_option("--format", report_format, "markdown | latex (booktabs) | html (one self-contained page)")
      ->capture_default_str();
  report_cmd->add_option("--output", report.output, "write the report to this file instead of stdout");
  report_cmd
      ->add_option("--width", report_width,
                   "LaTeX: single (one-column article, 345 pt) | double (one column of a two-column paper, "
                   "229 pt); a table wider than that is split into parts by columns")
      ->capture_default_str();
  report_cmd
      ->add_option("--columns", report.columns,
                   "columns to print, in order: build, build_layout, memory, sah, a ray set's name, or rays "
                   "(every ray set); default all")
      ->delimiter(',');
  report_cmd->add_option("--figures", report.figures,
                         "HTML: embed every PNG and SVG of this folder (scripts/plots.py --out)");

  TraceCommandOptions trace;
  std::string trace_query = "closest";
  auto* trace_cmd =
      app.add_subcommand("trace", "Trace rays from a file on one builder's tree; one output line per ray");
  trace_cmd->add_option("--scene", trace.scene, "scene file, shared-scene name or procedural spec")
      ->required();
  trace_cmd
      ->add_option("--builder", trace.builder,
                   "NAME or NAME:key=value,...; embree:quality=low|medium|high[,robust=1] for Embree's "
                   "own BVH (robust=1: its robust mode, RTC_SCENE_FLAG_ROBUST)")
      ->capture_default_str();
  trace_cmd->add_option(
      "--layout", trace.layout,
      "layout spec (default: bvh2 for binary trees, bvh4 or bvh8 for wide ones); with --builder embree: "
      "embree_1 (default), embree_8 or embree_16");
  trace_cmd->add_option("--query", trace_query, "closest | any (any: only the hit column is filled)")
      ->capture_default_str();
  trace_cmd->add_option("--rays", trace.rays, "ray file: 'ox oy oz dx dy dz [tmin tmax]' per line")
      ->required();
  trace_cmd
      ->add_option("--out", trace.out,
                   "output CSV ('-': standard output): a '# builder=... layout=... isa=... query=...' line, "
                   "then ray,hit,prim,t,u,v")
      ->required();

  CompareOptions compare;
  std::string compare_json;
  auto* compare_cmd = app.add_subcommand(
      "compare",
      "Regression check of a result CSV against a baseline (exit 1 on a regression or an out-of-date "
      "baseline, 2 on runs of different inputs)");
  compare_cmd->add_option("baseline", compare.baseline, "baseline CSV")->required();
  compare_cmd->add_option("current", compare.current, "new CSV")->required();
  compare_cmd->add_flag("--deterministic-only", compare.deterministic_only,
                        "compare SAH, counts, bytes, mismatches; ignore timings");
  compare_cmd
      ->add_option(
          "--margin", compare.min_timing_margin,
          "smallest change of a timing ratio worth flagging, a fraction in [0, 1) (its 95% interval must "
          "also exclude no change)")
      ->capture_default_str()
      // CLI::Range lets NaN through (every comparison with it is false), and a NaN margin gates nothing.
      ->check(CLI::Validator(
          [](const std::string& text) -> std::string {
            double v = 0.0;
            try {
              v = std::stod(text);
            } catch (const std::exception&) {
              return "'" + text + "' is not a number";
            }
            return std::isfinite(v) && v >= 0.0 && v < 1.0
                       ? ""
                       : text + " is not a fraction in [0, 1) (0.05 flags changes beyond 5%)";
          },
          "FRACTION"));
  compare_cmd->add_option(
      "--json", compare_json,
      "write smaller-is-better metrics to F and bigger-is-better ones beside it (bench.json: "
      "bench-bigger.json)");

  ImageCommandOptions image;
  auto* image_cmd = app.add_subcommand(
      "image", "Per-pixel maps of primary rays: nodes visited, primitives tested, depth, normal (PNG + EXR)");
  image_cmd->add_option("--scene", image.scene, "scene file, shared-scene name or procedural spec")
      ->required();
  image_cmd->add_option("--builder", image.builder, "NAME or NAME:key=value,...")->capture_default_str();
  image_cmd->add_option("--layout", image.layout,
                        "layout spec (default: bvh2 for binary trees, bvh4 or bvh8 for wide ones)");
  image_cmd->add_option("--width", image.width, "pixels")->capture_default_str();
  image_cmd->add_option("--height", image.height, "pixels")->capture_default_str();
  image_cmd->add_option("--ray-set", image.ray_set, "ray set (primary)")->capture_default_str();
  image_cmd->add_option("--out", image.out, "prefix: PREFIX_nodes.png, PREFIX_nodes.exr, ...")->required();
  auto* eye_opt = image_cmd->add_option(
      "--eye", image.eye,
      "camera position x,y,z, with --target (default: the scene's camera, else automatic)");
  image_cmd->add_option("--target", image.target, "point x,y,z at the image centre, with --eye");
  image_cmd->add_option("--up", image.up, "image up direction x,y,z, with --eye")
      ->capture_default_str()
      ->needs(eye_opt);
  image_cmd->add_option("--fov", image.fov, "vertical field of view in degrees, with --eye")
      ->capture_default_str()
      ->needs(eye_opt);

  ImageDiffOptions image_diff;
  auto* image_diff_cmd = app.add_subcommand(
      "image-diff", "B - A of two images (EXR signed, PNG diverging), max and mean |B - A|");
  image_diff_cmd->add_option("a", image_diff.a, "image A (EXR)")->required();
  image_diff_cmd->add_option("b", image_diff.b, "image B (EXR)")->required();
  image_diff_cmd->add_option("--out", image_diff.out, "prefix: OUT.exr and OUT.png")->required();

  auto* list_cmd = app.add_subcommand(
      "list", "Builders and their parameters, procedural scene kinds, shared scenes found");
  auto* list_scenes_cmd = app.add_subcommand("list-scenes", "Names of the shared scenes found, one per line");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every usage mistake exits 2, as any other bad input does (CLI11's own
    // codes, 106 and up, differ by mistake and are promised nowhere).
    if (app.exit(e) == 0) return 0;
    std::vector<std::string> names;
    for (const CLI::App* sub : app.get_subcommands({})) names.push_back(sub->get_name());
    if (argc > 1 && argv[1][0] != '-' && std::find(names.begin(), names.end(), argv[1]) == names.end()) {
      const auto near = closest_name(argv[1], names);
      std::cerr << "sahbench: '" << argv[1] << "' is not a subcommand"
                << (near ? "; did you mean '" + *near + "'?" : " (see sahbench --help)") << "\n";
    }
    return 2;
  }
  try {
    if (*build_cmd) {
      for (const auto& p : params) build.params.push_back(parse_override(p));
      for (const auto& b : build_builders) build.builders.push_back(parse_builder_run(b));
      return run_build_command(build, std::cout, std::cerr);
    }
    if (*run_cmd) {
      if (!run_output.empty()) run.output = run_output;
      if (!run_shard.empty()) run.shard = parse_shard_spec(run_shard);
      return run_experiment(run, std::cerr);
    }
    if (*plan_cmd) run_plan_command(plan, std::cout, std::cerr);
    if (*merge_cmd) merge_shards(merge, std::cerr);
    if (*stress_cmd) {
      if (!stress_output.empty()) stress.output = stress_output;
      const StressSummary summary = run_stress(stress, std::cerr);
      // A build abandoned at its time bound still runs on a detached thread: end without waiting for it
      // (and without running static destructors under it).
      if (summary.abandoned_builds > 0) {
        std::cout.flush();
        std::cerr.flush();
        std::quick_exit(summary.exit_code());
      }
      return summary.exit_code();
    }
    if (*report_cmd) {
      report.format = parse_report_format(report_format);
      report.width = parse_page_width(report_width);
      // An option of another format would be ignored: a user who gave it expects it to act.
      if (report_cmd->count("--width") && report.format != ReportFormat::kLatex)
        throw Error("--width " + report_width + " sets the page width of LaTeX tables; add --format latex");
      if (report_cmd->count("--figures") && report.format != ReportFormat::kHtml)
        throw Error("--figures embeds the figures in the HTML report; add --format html");
      run_report_command(report, std::cout);
    }
    if (*compare_cmd) {
      if (!compare_json.empty()) compare.json = compare_json;
      return compare_results(compare, std::cout).failed() ? 1 : 0;
    }
    if (*trace_cmd) {
      trace.query = parse_trace_query(trace_query);
      run_trace_command(trace, std::cerr);
    }
    if (*image_cmd) run_image_command(image, std::cerr);
    if (*image_diff_cmd) run_image_diff_command(image_diff, std::cerr);
    if (*list_cmd) print_catalogue(std::cout);
    if (*list_scenes_cmd) print_scene_names(std::cout);
  } catch (const Interrupted& e) {
    std::cerr << "sahbench: " << e.what() << "\n";
    return 130;
  } catch (const Error& e) {
    std::cerr << "sahbench: error: " << e.what() << "\n";
    return 2;
  } catch (const std::filesystem::filesystem_error& e) {
    // A path the system refuses (a folder under a regular file, no permission): bad input, named by the
    // message ("cannot create directories: Not a directory [PATH]").
    std::cerr << "sahbench: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "sahbench: internal error: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
