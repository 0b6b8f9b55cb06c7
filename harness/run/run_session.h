#pragma once
// The identity and integrity of one `sahbench run`, shared by the static and animation experiments: a
// run id no two processes share, a fingerprint of everything that decides what a cell measures, an
// exclusive lock on the output CSV, --resume of the run with the same fingerprint only, and a clean stop
// on SIGINT or SIGTERM between cells.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "harness/config/config.h"
#include "harness/run/environment.h"
#include "harness/run/run_options.h"

namespace sahbench {

/// "NAME-YYYYMMDD-HHMMSS-PID-XXXX" (UTC, XXXX four random hex digits): two runs started in the same
/// second, by one process after another or by two at once, still get different ids.
std::string make_run_id(const std::string& config_name);

/// A hash of what decides a run's measurements: the resolved config (seed, repetitions, scenes and their
/// source files, builder runs with every parameter, layouts, threads, ray sets, cameras, reference,
/// animation frames) and the build (commit, compiler, target ISA). Not the output path, nor --only.
/// `parts` hashes each of those apart, so that a refused --resume can name what differs.
struct Fingerprint {
  std::string hash;                                        ///< 16 hex digits: the run_fingerprint column
  std::vector<std::pair<std::string, std::string>> parts;  ///< name -> 8 hex digits, in a fixed order

  /// "seed=1a2b3c4d;repetitions=..." (the fingerprint_parts column), and back.
  std::string parts_text() const;
  static std::vector<std::pair<std::string, std::string>> parse_parts(const std::string& text);
};

/// Who a row belongs to: its run, and the fingerprint of what that run measures.
struct RunIdentity {
  std::string run_id;
  Fingerprint fingerprint;
  std::string shard;  ///< "K/N" for a run of one shard (ShardSpec::text), empty for a whole run
};

/// The fingerprint of running `cfg` over `scenes` (scenes_to_run) with its builder runs resolved to
/// `builder_runs` (each "name params_text", every parameter's value, defaults included) and the build in
/// `env`. A scene file is hashed by its resolved path, size and contents, so an edited file is a
/// different run.
Fingerprint fingerprint_of(const ExperimentConfig& cfg, const std::vector<std::string>& scenes,
                           const std::vector<std::string>& builder_runs, const Environment& env);

/// An exclusive lock on an output CSV for as long as the object lives: flock(2) on "CSV.lock" beside it,
/// which holds the owner's pid. A second writer gets an Error naming the file and that pid; the lock is
/// the kernel's, so a crashed owner leaves none behind.
class OutputLock {
 public:
  explicit OutputLock(const std::filesystem::path& csv);
  ~OutputLock();
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

/// What --resume continues: the cells already finished in the latest run of `output` whose fingerprint
/// is `fp`, under that run's id. Only that run's rows count, so resuming after a killed rerun finishes the
/// full cell set under one id. A file with rows of other runs only is an Error that names what differs
/// from the latest of them (seed, repetitions, a scene, ...); a missing or empty file resumes nothing.
/// A shard's run (`shard` "K/N") continues only rows of that shard: rows of the fingerprint under another
/// shard are an Error naming both, since the file would then hold two shards.
struct ResumePoint {
  std::string run_id;  ///< empty: nothing to resume, a new run
  std::set<std::string> finished;
};
ResumePoint find_resume_point(const std::filesystem::path& output, const Fingerprint& fp, std::ostream& log,
                              const std::string& shard = "");

/// Thrown between cells once SIGINT or SIGTERM has arrived: finished rows are on disk, the cells in
/// progress are dropped. The CLI prints message() and exits 130.
class Interrupted : public Error {
 public:
  /// "interrupted after DONE of TOTAL UNITS; continue with: CONTINUE_WITH"
  Interrupted(std::size_t done, std::size_t total, const std::string& continue_with,
              const std::string& units = "cells");
};

/// While alive, SIGINT and SIGTERM only set a flag that check() turns into Interrupted; a second signal of
/// either kind ends the process at once (exit status 130). The previous handlers come back on
/// destruction.
class InterruptGuard {
 public:
  InterruptGuard();
  ~InterruptGuard();
  InterruptGuard(const InterruptGuard&) = delete;
  InterruptGuard& operator=(const InterruptGuard&) = delete;

  static bool requested();
  /// Throws Interrupted(done, total, continue_with) if a signal has arrived.
  static void check(std::size_t done, std::size_t total, const std::string& continue_with,
                    const std::string& units = "cells");
};

/// "sahbench run CONFIG --resume", with the run's --output, --only and --shard, each quoted for a shell where
/// it needs it: how to continue.
std::string resume_command(const RunOptions& options);

}  // namespace sahbench
