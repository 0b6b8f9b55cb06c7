#include "harness/run/run_common.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <ostream>
#include <thread>

#include "core/error.h"
#include "harness/embree/embree_scene.h"
#include "harness/embree/embree_trace.h"
#include "harness/run/csv.h"
#include "harness/run/result_row.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "scenes/scene_path.h"
#include "traversal/layout.h"

namespace sahbench {

std::string now_stamp() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", &tm);
  return buf;
}

std::string format_duration(double seconds) {
  const auto s = static_cast<long>(std::lround(seconds));
  return s >= 60 ? fmt::format("{}m{:02}s", s / 60, s % 60) : fmt::format("{}s", s);
}

std::vector<std::string> scenes_to_run(const ExperimentConfig& cfg, std::ostream& log) {
  // Each scene is checked before any work: a procedural spec parsed, a file found. The errors name the
  // scene (and the search path); the config is named before them.
  for (const auto& name : cfg.scenes) {
    try {
      if (is_procedural_spec(name))
        parse_proc_spec(name, procedural_kinds());
      else if (!std::filesystem::is_regular_file(name) && !find_scene_file(name))
        load_scene(name);
    } catch (const Error& e) {
      throw Error(fmt::format("{}: experiment.scenes: {}", cfg.path.string(), e.what()));
    }
  }
  std::vector<std::string> out = cfg.scenes;
  for (const auto& name : cfg.optional_scenes) {
    if (find_scene_file(name)) {
      out.push_back(name);
    } else {
      log << fmt::format("skipping optional scene '{}': not found on the scene search path\n", name);
    }
  }
  return out;
}

std::vector<CellLayout> layouts_for(const BuilderRun& b, const RunLayouts& layouts) {
  std::vector<CellLayout> out;
  if (b.is_embree()) {
    for (const auto& l : layouts.embree) out.push_back({l.name, nullptr});
  } else {
    for (const auto& l : layouts.ours)
      if (find_layout(l.name).arity == b.arity) out.push_back({l.text(), &l});
  }
  return out;
}

std::string lights_note(const LightsConfig& lights) {
  std::vector<std::string> points;
  for (const auto& p : lights.positions) points.push_back(fmt::format("({})", fmt::join(p, ", ")));
  return fmt::format("lights {}", fmt::join(points, " "));
}

std::string camera_note(const CameraConfig& camera) {
  return fmt::format("camera eye ({}) target ({}) up ({}) fov {}", fmt::join(camera.eye, ", "),
                     fmt::join(camera.target, ", "), fmt::join(camera.up, ", "), camera.fov);
}

CsvRow common_row(const RunIdentity& id, const Environment& env, const ExperimentConfig& cfg,
                  const Scene& scene, uint32_t frame, const std::string& builder,
                  const std::string& params_text, int threads) {
  CsvRow row;
  row["run_id"] = id.run_id;
  row["run_fingerprint"] = id.fingerprint.hash;
  row["fingerprint_parts"] = id.fingerprint.parts_text();
  row["shard"] = id.shard;
  row["git_commit"] = env.git_commit;
  row["cpu"] = env.cpu;
  row["compiler"] = env.compiler;
  // What the code was compiled for; `isa` is each row's kernel (report captions name both).
  row["build_isa"] = env.isa;
  row["threads"] = std::to_string(threads);
  row["scene"] = scene.name;
  row["scene_triangles"] = std::to_string(scene.triangles.size());
  row["frame"] = std::to_string(frame);
  row["builder"] = builder;
  row["builder_params"] = params_text;
  row["build_reps"] = std::to_string(cfg.reps.build);
  row["trace_reps"] = std::to_string(cfg.reps.trace);
  row["config"] = cfg.path.string();
  row["seed"] = std::to_string(cfg.seed);
  row["scene_source"] = scene.source;
  row["scene_removed"] = std::to_string(scene.removed.total());
  row["embree_version"] = env.embree;
  if (const CameraConfig* camera = cfg.camera_for(scene.name)) add_note(row, camera_note(*camera));
  if (const LightsConfig* lights = cfg.lights_for(scene.name)) add_note(row, lights_note(*lights));
  return row;
}

void warn_oversubscribed(std::span<const int> threads, const std::string& setting,
                         const std::string& measured, std::ostream& log) {
  const unsigned hardware = std::thread::hardware_concurrency();
  for (const int t : threads)
    if (hardware > 0 && static_cast<unsigned>(t) > hardware)
      log << fmt::format(
          "{}{} is more than the {} hardware threads here; those {} measure oversubscription\n", setting, t,
          hardware, measured);
}

void warn_oversubscribed(const ExperimentConfig& cfg, std::ostream& log) {
  warn_oversubscribed(cfg.threads, cfg.path.string() + ": warning: threads = ", "cells", log);
}

OpenRun open_run(const ExperimentConfig& cfg, const RunOptions& options, const std::filesystem::path& output,
                 const std::vector<std::string>& columns, const std::vector<std::string>& scenes,
                 const std::vector<std::string>& builder_runs, const Environment& env, std::ostream& log) {
  OpenRun run;
  run.lock = std::make_unique<OutputLock>(output);
  run.csv = std::make_unique<CsvWriter>(output, columns);
  if (run.csv->dropped_partial_row())
    log << fmt::format("{}: removed a partial last row (an interrupted write)\n", output.string());
  run.id.fingerprint = fingerprint_of(cfg, scenes, builder_runs, env);
  run.id.run_id = make_run_id(cfg.name);
  if (options.shard) run.id.shard = options.shard->text();
  if (options.resume) {
    ResumePoint point = find_resume_point(output, run.id.fingerprint, log, run.id.shard);
    if (!point.run_id.empty()) run.id.run_id = point.run_id;
    run.finished = std::move(point.finished);
  }
  return run;
}

Progress::Progress(std::size_t total, std::ostream& log)
    : total_(total), log_(log), start_(std::chrono::steady_clock::now()) {}

double Progress::elapsed_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::cell_done(const std::string& what) {
  ++done_;
  const double elapsed = elapsed_s();
  const std::size_t counted = std::min(total_, std::max(done_, batch_end_));
  const double left = elapsed / static_cast<double>(std::max<std::size_t>(counted, 1)) *
                      static_cast<double>(total_ - counted);
  log_ << fmt::format("[{}/{}] {} | elapsed {}, left ~{}\n", done_, total_, what, format_duration(elapsed),
                      format_duration(left));
}

}  // namespace sahbench
