#include "harness/run/run_session.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <csignal>
#include <cstring>
#include <fstream>
#include <iterator>
#include <ostream>
#include <random>

#include "core/fnv1a.h"
#include "core/text_file.h"
#include "harness/run/csv.h"
#include "harness/run/result_row.h"
#include "harness/run/run_common.h"
#include "scenes/procedural.h"
#include "scenes/scene_path.h"

namespace sahbench {
namespace {

// A scene's source: a procedural spec stands for itself; a file, for its path, size and contents.
std::string scene_source(const std::string& name) {
  if (is_procedural_spec(name)) return name;
  std::filesystem::path file = name;
  if (!std::filesystem::is_regular_file(file)) {
    const auto found = find_scene_file(name);
    if (!found) return name + "@missing";
    file = *found;
  }
  // A .gltf names its buffers by relative path: every file of its folder is part of the scene.
  std::vector<std::filesystem::path> files = {file};
  if (file.extension() == ".gltf") {
    files.clear();
    for (const auto& entry : std::filesystem::directory_iterator(file.parent_path()))
      if (entry.is_regular_file()) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
  }
  std::string text = name;
  for (const auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    text += fmt::format(" {}:{}:{:016x}", f.filename().string(), bytes.size(), fnv1a(bytes));
  }
  return text;
}

std::atomic<bool> g_interrupted{false};
struct sigaction g_previous_int {};
struct sigaction g_previous_term {};

// The first SIGINT or SIGTERM asks the run to stop between two timed steps; a second of either ends the
// process at once (_exit is async-signal-safe), for a step that takes too long.
extern "C" void on_interrupt(int) {
  if (g_interrupted.exchange(true)) ::_exit(130);
}

}  // namespace

std::string make_run_id(const std::string& config_name) {
  std::random_device entropy;
  return fmt::format("{}-{}-{}-{:04x}", config_name, now_stamp(), static_cast<long>(::getpid()),
                     entropy() & 0xffffu);
}

std::string Fingerprint::parts_text() const {
  std::string out;
  for (const auto& [name, hash] : parts) out += (out.empty() ? "" : ";") + name + "=" + hash;
  return out;
}

std::vector<std::pair<std::string, std::string>> Fingerprint::parse_parts(const std::string& text) {
  std::vector<std::pair<std::string, std::string>> out;
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t end = std::min(text.find(';', start), text.size());
    const std::string item = text.substr(start, end - start);
    const std::size_t eq = item.find('=');
    if (eq != std::string::npos) out.emplace_back(item.substr(0, eq), item.substr(eq + 1));
    start = end + 1;
  }
  return out;
}

Fingerprint fingerprint_of(const ExperimentConfig& cfg, const std::vector<std::string>& scenes,
                           const std::vector<std::string>& builder_runs, const Environment& env) {
  const Repetitions& r = cfg.reps;
  std::string sources, sets, cameras;
  for (const auto& scene : scenes) sources += scene_source(scene) + "\n";
  for (const auto& rs : cfg.ray_sets)
    sets += fmt::format("{} {} {}x{} count {} lights {} {} ao {}\n", rs.name, static_cast<int>(rs.kind),
                        rs.width, rs.height, rs.count, rs.lights, rs.light_source, rs.ao_radius);
  for (const auto& c : cfg.cameras) cameras += c.scene + ": " + camera_note(c) + "\n";
  // The configured lights in the same part, so that a config without them keeps its fingerprint.
  for (const auto& l : cfg.lights) cameras += l.scene + ": " + lights_note(l) + "\n";
  std::vector<std::string> layouts;
  for (const LayoutSpec& l : cfg.layouts) layouts.push_back(l.text());
  // Part name -> the text it hashes.
  std::vector<std::pair<std::string, std::string>> text = {
      {"seed", std::to_string(cfg.seed)},
      {"repetitions", fmt::format("build {} warmup {}, trace {} warmup {}, interleave {}", r.build,
                                  r.build_warmup, r.trace, r.trace_warmup, r.interleave)},
      {"scenes", sources},
      {"builders", fmt::format("{}", fmt::join(builder_runs, "\n"))},
      {"layouts", fmt::format("{}", fmt::join(layouts, "\n"))},
      {"threads", fmt::format("{}", fmt::join(cfg.threads, ","))},
      {"ray_sets", sets},
      {"cameras", cameras},
      {"reference", fmt::format("{} {}", to_string(cfg.reference), cfg.brute_force_max_triangles)},
      {"animation", cfg.animation ? fmt::format("frames {} times {}", cfg.animation->frames,
                                                fmt::join(cfg.animation->times, ","))
                                  : "static"},
      {"build", env.git_commit + " " + env.compiler + " " + env.isa + " " + env.cpu + " " + env.embree},
  };
  // Only where it is on, so that the fingerprints of runs without it stay as they were.
  if (cfg.epo) text.emplace_back("metrics", "epo");

  Fingerprint fp;
  uint64_t whole = kFnv1aOffset;
  for (const auto& [name, value] : text) {
    fp.parts.emplace_back(name, fmt::format("{:08x}", fnv1a(value) >> 32));
    whole = fnv1a(name + "=" + value + "\n", whole);
  }
  fp.hash = fmt::format("{:016x}", whole);
  return fp;
}

OutputLock::OutputLock(const std::filesystem::path& csv) : path_(csv.string() + ".lock") {
  require_file_path(csv, "result CSV");
  if (path_.has_parent_path()) std::filesystem::create_directories(path_.parent_path());
  fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw Error(fmt::format("{}: cannot create the lock file: {}", path_.string(), std::strerror(errno)));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    char pid[32] = {};
    const ssize_t n = ::pread(fd_, pid, sizeof pid - 1, 0);
    ::close(fd_);
    fd_ = -1;
    throw Error(
        fmt::format("{}: another sahbench run (pid {}) is writing this file; wait for it, or give "
                    "--output another file",
                    csv.string(), n > 0 ? std::string(pid, static_cast<std::size_t>(n)) : "unknown"));
  }
  const std::string pid = std::to_string(static_cast<long>(::getpid()));
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) < 0) {
    // The pid is only for the message a second writer gets; the lock holds without it.
  }
}

OutputLock::~OutputLock() {
  // The file stays: unlinking it would let a writer that opened it just before lock a file no longer on
  // disk while a third creates and locks a new one, two writers at once. Closing releases the lock.
  if (fd_ >= 0) ::close(fd_);
}

ResumePoint find_resume_point(const std::filesystem::path& output, const Fingerprint& fp, std::ostream& log,
                              const std::string& shard) {
  ResumePoint point;
  if (!std::filesystem::exists(output)) {
    log << fmt::format("resume: {} does not exist yet; starting a new run\n", output.string());
    return point;
  }
  const std::vector<CsvRow> rows = read_csv(output);
  if (rows.empty()) {
    log << fmt::format("resume: {} has no rows yet; starting a new run\n", output.string());
    return point;
  }
  auto field = [](const CsvRow& row, const char* column) {
    const auto it = row.find(column);
    return it == row.end() ? std::string() : it->second;
  };
  // A shard's rows are continued only by the same shard: another's cells are not in its plan.
  std::string other_shard;
  bool fingerprint_seen = false;
  for (const auto& row : rows) {
    if (field(row, "run_fingerprint") != fp.hash) continue;
    fingerprint_seen = true;
    if (field(row, "shard") == shard)
      point.run_id = field(row, "run_id");
    else
      other_shard = field(row, "shard");
  }
  if (point.run_id.empty() && fingerprint_seen)
    throw Error(
        fmt::format("{}: --resume: this file holds rows of this config's fingerprint from {}, not "
                    "from {}; give each shard its own --output",
                    output.string(), other_shard.empty() ? "the whole run" : "shard " + other_shard,
                    shard.empty() ? "the whole run" : "shard " + shard));
  if (point.run_id.empty()) {
    const CsvRow& last = rows.back();
    const auto theirs = Fingerprint::parse_parts(field(last, "fingerprint_parts"));
    std::vector<std::string> differ;
    for (const auto& [name, hash] : fp.parts) {
      const auto it =
          std::find_if(theirs.begin(), theirs.end(), [&](const auto& p) { return p.first == name; });
      if (it == theirs.end() || it->second != hash) differ.push_back(name);
    }
    throw Error(fmt::format(
        "{}: --resume: no run in this file has this config's fingerprint {}; its latest run {} differs in: "
        "{}. Run without --resume to start a new run (in this file or, with --output, another)",
        output.string(), fp.hash, field(last, "run_id"),
        differ.empty() ? "(unknown: that run has no fingerprint_parts)"
                       : fmt::format("{}", fmt::join(differ, ", "))));
  }
  for (const auto& row : rows)
    if (field(row, "run_id") == point.run_id && field(row, "shard") == shard)
      point.finished.insert(cell_key(row.at("scene"), row.at("builder"), row.at("builder_params"),
                                     row.at("layout"), std::stoi(row.at("threads")), row.at("ray_set"),
                                     std::stoi(row.at("frame"))));
  log << fmt::format("resume: run {}, {} finished cells in {}\n", point.run_id, point.finished.size(),
                     output.string());
  return point;
}

Interrupted::Interrupted(std::size_t done, std::size_t total, const std::string& continue_with,
                         const std::string& units)
    : Error(fmt::format("interrupted after {} of {} {}; continue with: {}", done, total, units,
                        continue_with)) {}

InterruptGuard::InterruptGuard() {
  g_interrupted.store(false);
  struct sigaction action {};
  action.sa_handler = on_interrupt;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;
  sigaction(SIGINT, &action, &g_previous_int);
  sigaction(SIGTERM, &action, &g_previous_term);
}

InterruptGuard::~InterruptGuard() {
  sigaction(SIGINT, &g_previous_int, nullptr);
  sigaction(SIGTERM, &g_previous_term, nullptr);
}

bool InterruptGuard::requested() {
  return g_interrupted.load();
}

void InterruptGuard::check(std::size_t done, std::size_t total, const std::string& continue_with,
                           const std::string& units) {
  if (requested()) throw Interrupted(done, total, continue_with, units);
}

namespace {

// `text` as one shell word: as it is when it holds only characters no shell treats specially, else in
// single quotes (a quote inside written '\'').
std::string shell_word(const std::string& text) {
  const bool plain = !text.empty() && std::all_of(text.begin(), text.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) ||
           std::string_view("_./:=,+-@%").find(c) != std::string_view::npos;
  });
  if (plain) return text;
  std::string out = "'";
  for (const char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace

std::string resume_command(const RunOptions& options) {
  std::string command = "sahbench run " + shell_word(options.config.string()) + " --resume";
  if (options.output) command += " --output " + shell_word(options.output->string());
  if (!options.only.empty()) command += " --only " + shell_word(options.only);
  if (options.shard) command += " --shard " + options.shard->text();
  return command;
}

}  // namespace sahbench
