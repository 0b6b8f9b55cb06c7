#pragma once
// Pieces of `sahbench run` that the static runner (runner.cpp) and the animation runner
// (animation_runner.cpp) share, so that both name runs, pick scenes and layouts, resume and log the same
// way. Internal to the harness.

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <memory>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "builders/registry.h"
#include "harness/config/config.h"
#include "harness/embree/embree_layouts.h"
#include "harness/embree/embree_scene.h"
#include "harness/run/csv.h"
#include "harness/run/environment.h"
#include "harness/run/ray_sets.h"
#include "harness/run/run_options.h"
#include "harness/run/run_session.h"
#include "harness/run/static_plan.h"
#include "scenes/scene.h"
#include "traversal/layout.h"

namespace sahbench {

/// The time now in UTC as YYYYMMDD-HHMMSS: part of a run id (make_run_id).
std::string now_stamp();

/// Whole seconds as "42s", or "3m07s" from a minute on, for progress lines.
std::string format_duration(double seconds);

/// The scenes a run covers: `cfg.scenes`, then each of `cfg.optional_scenes` found on the scene search
/// path. Required scenes must exist before the first cell runs, not fail hours in: a missing one throws
/// the loader's Error; a missing optional one is skipped with a line on `log`.
std::vector<std::string> scenes_to_run(const ExperimentConfig& cfg, std::ostream& log);

/// A layout a cell is traced with: one of ours, with its spec as the config parsed it, or one of Embree's.
struct CellLayout {
  std::string name;                  ///< the CSV's layout column: LayoutSpec::text() or Embree's name
  const LayoutSpec* ours = nullptr;  ///< into RunLayouts::ours; null for Embree's
};

/// The layouts that trace `b`'s trees: every one of `layouts.embree` for Embree, else those of
/// `layouts.ours` (which must outlive the result) with the arity of `b`'s trees.
std::vector<CellLayout> layouts_for(const BuilderRun& b, const RunLayouts& layouts);

/// "camera eye (x, y, z) target (x, y, z) up (x, y, z) fov F": the view of a [[camera]], for `notes`.
std::string camera_note(const CameraConfig& camera);
/// A config's [[lights]] as a row's `notes` say it: "lights (x, y, z) (x, y, z)".
std::string lights_note(const LightsConfig& lights);

/// The columns every row of a cell starts with: the run (run_id, run_fingerprint, fingerprint_parts,
/// shard, config, seed, build_reps, trace_reps), the machine (git_commit, cpu, compiler, embree_version), the
/// scene and `frame`, the builder run (`builder`, its `params_text`) and the thread count. A scene viewed
/// through the config's [[camera]] gets it in `notes` (camera_note), so a row says which view its rays
/// came from.
CsvRow common_row(const RunIdentity& id, const Environment& env, const ExperimentConfig& cfg,
                  const Scene& scene, uint32_t frame, const std::string& builder,
                  const std::string& params_text, int threads);

/// A run of `sahbench run` opened for writing: its output CSV locked (OutputLock) and open with
/// `columns` (a row cut off by a crash removed), its identity (a new run id, or with --resume the id of
/// the run whose fingerprint matches), and the cells that run finished already. The lock is taken, and
/// every required scene checked by the caller, before the CSV is touched.
struct OpenRun {
  std::unique_ptr<OutputLock> lock;
  std::unique_ptr<CsvWriter> csv;
  RunIdentity id;
  std::set<std::string> finished;  ///< cell keys (cell_key) a resume skips
};

/// More threads than the machine has measure oversubscription, not the builder: allowed, but said, on
/// `log`, before anything runs. Each such count prints "{setting}{count} is more than the N hardware
/// threads here; those {measured} measure oversubscription".
void warn_oversubscribed(std::span<const int> threads, const std::string& setting,
                         const std::string& measured, std::ostream& log);
void warn_oversubscribed(const ExperimentConfig& cfg, std::ostream& log);

/// `builder_runs`: one "name params" line per builder run, for the fingerprint.
OpenRun open_run(const ExperimentConfig& cfg, const RunOptions& options, const std::filesystem::path& output,
                 const std::vector<std::string>& columns, const std::vector<std::string>& scenes,
                 const std::vector<std::string>& builder_runs, const Environment& env, std::ostream& log);

/// Progress on stderr: "[i/N] what | elapsed, left ~T" per finished cell. Cells timed together finish
/// together: announcing the batch (batch) makes the time left reckon with all of it from its first line
/// on. A plan that learns its cells as it goes (animation frames) adds them with plan().
class Progress {
 public:
  Progress(std::size_t total, std::ostream& log);
  void plan(std::size_t cells) { total_ += cells; }
  void skip(std::size_t cells) { total_ -= std::min(total_, cells); }
  void batch(std::size_t cells) { batch_end_ = std::min(total_, done_ + cells); }
  void cell_done(const std::string& what);
  std::size_t done() const { return done_; }
  std::size_t total() const { return total_; }
  double elapsed_s() const;

 private:
  std::size_t total_, done_ = 0, batch_end_ = 0;
  std::ostream& log_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace sahbench
