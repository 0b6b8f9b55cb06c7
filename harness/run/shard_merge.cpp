#include "harness/run/shard_merge.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <charconv>
#include <map>
#include <ostream>
#include <set>

#include "core/error.h"
#include "harness/config/config.h"
#include "harness/run/csv.h"
#include "harness/run/environment.h"
#include "harness/run/result_row.h"
#include "harness/run/run_common.h"
#include "harness/run/run_session.h"
#include "harness/run/shard_plan.h"

namespace sahbench {
namespace {

// Cells named in full in a message; the rest are counted.
constexpr std::size_t kNamedCells = 10;

std::string field(const CsvRow& row, const std::string& column) {
  const auto it = row.find(column);
  return it == row.end() ? std::string() : it->second;
}

// The latest run in one shard's CSV (rows are appended as cells finish: the last row's run).
struct ShardFile {
  std::filesystem::path path;
  ShardSpec spec;
  std::string run_id, fingerprint, parts, config;
  std::vector<CsvRow> rows;
  std::string name() const { return fmt::format("{} (shard {})", path.string(), spec.text()); }
};

std::optional<ShardFile> read_shard(const std::filesystem::path& path, std::ostream& log) {
  std::vector<CsvRow> rows = read_csv(path);
  if (rows.empty()) {
    // A shard with no cells (more shards than units of work) writes a header only.
    log << fmt::format("merge: {} has no rows; skipped\n", path.string());
    return std::nullopt;
  }
  ShardFile f;
  f.path = path;
  f.run_id = field(rows.back(), "run_id");
  const std::string shard = field(rows.back(), "shard");
  if (shard.empty())
    throw Error(
        fmt::format("{}: its latest run {} is not a shard's (column 'shard' is empty); run each "
                    "shard with --shard K/N",
                    path.string(), f.run_id));
  try {
    f.spec = parse_shard_spec(shard);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: column 'shard': {}", path.string(), e.what()));
  }
  f.fingerprint = field(rows.back(), "run_fingerprint");
  f.parts = field(rows.back(), "fingerprint_parts");
  f.config = field(rows.back(), "config");
  std::size_t earlier = 0;
  for (auto& row : rows) {
    if (field(row, "run_id") != f.run_id) {
      ++earlier;
      continue;
    }
    if (field(row, "shard") != shard || field(row, "run_fingerprint") != f.fingerprint)
      throw Error(fmt::format(
          "{}: run {} has rows of shard {} with fingerprint {} and of shard {} with "
          "fingerprint {}: two runs under one run id",
          path.string(), f.run_id, shard, f.fingerprint, field(row, "shard"), field(row, "run_fingerprint")));
    f.rows.push_back(std::move(row));
  }
  if (earlier)
    log << fmt::format("merge: {}: {} rows of earlier runs left out (only its latest run, {}, is merged)\n",
                       path.string(), earlier, f.run_id);
  return f;
}

// A whole-number field of data row r of a shard's CSV; anything else is an Error naming file, row and column.
int whole_number(const ShardFile& f, std::size_t r, const std::string& column) {
  const std::string text = field(f.rows[r], column);
  int value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size())
    throw Error(fmt::format("{}: data row {}: column '{}': '{}' is not a whole number", f.path.string(),
                            r + 1, column, text));
  return value;
}

// The names of the fingerprint parts in which two runs differ.
std::string differing_parts(const std::string& a, const std::string& b) {
  const auto pa = Fingerprint::parse_parts(a), pb = Fingerprint::parse_parts(b);
  std::vector<std::string> differ;
  for (const auto& part : pa) {
    const auto it = std::find_if(pb.begin(), pb.end(), [&](const auto& p) { return p.first == part.first; });
    if (it == pb.end() || it->second != part.second) differ.push_back(part.first);
  }
  return differ.empty() ? "unknown parts" : fmt::format("{}", fmt::join(differ, ", "));
}

std::string named(const std::vector<std::string>& items) {
  std::string out;
  for (std::size_t i = 0; i < std::min(items.size(), kNamedCells); ++i) out += "\n  " + items[i];
  if (items.size() > kNamedCells) out += fmt::format("\n  and {} more", items.size() - kNamedCells);
  return out;
}

// A merge replaces its output, which may only hold earlier merges (derived from shards, so made again
// from them, of this sweep or another commit's): rows of a run would be lost. A merged row carries its
// shard's run id in shard_run_id, which no run writes.
void check_output_replaceable(const std::filesystem::path& output) {
  if (!std::filesystem::exists(output)) return;
  if (std::filesystem::is_directory(output))
    throw Error(fmt::format("merge: the output {} is a directory", output.string()));
  for (const CsvRow& row : read_csv(output)) {
    const std::string id = field(row, "run_id");
    if (id.find("-merged-") == std::string::npos || field(row, "shard_run_id").empty())
      throw Error(
          fmt::format("merge: the output {} holds rows of a run ({}), which merging would replace; "
                      "merge into a new file, or move that one away first",
                      output.string(), id));
  }
}

}  // namespace

MergeSummary merge_shards(const MergeOptions& options, std::ostream& log) {
  if (options.shards.empty()) throw Error("merge: no shard CSVs given");
  for (const auto& p : options.shards)
    if (std::filesystem::exists(options.output) && std::filesystem::exists(p) &&
        std::filesystem::equivalent(options.output, p))
      throw Error(fmt::format("merge: the output {} is one of the shard CSVs", options.output.string()));

  // The shards: one fingerprint, one count, each index once.
  std::vector<ShardFile> files;
  for (const auto& path : options.shards)
    if (auto f = read_shard(path, log)) files.push_back(std::move(*f));
  if (files.empty()) throw Error("merge: none of the shard CSVs has rows");
  const ShardFile& first = files.front();
  std::map<int, const ShardFile*> by_index;
  for (const ShardFile& f : files) {
    if (f.fingerprint != first.fingerprint)
      throw Error(fmt::format(
          "merge: {} has run fingerprint {} and {} has {}: shards of different runs (they differ in: {}); "
          "merge shards of one sweep, run with one config and one build",
          first.name(), first.fingerprint, f.name(), f.fingerprint, differing_parts(first.parts, f.parts)));
    if (f.spec.count != first.spec.count)
      throw Error(fmt::format("merge: {} and {} split the sweep into different numbers of shards",
                              first.name(), f.name()));
    const auto [it, added] = by_index.emplace(f.spec.index, &f);
    if (!added)
      throw Error(fmt::format("merge: shard {} is given twice: {} and {}", f.spec.text(),
                              it->second->path.string(), f.path.string()));
  }
  const int n = first.spec.count;

  // The plan the shards ran, from their config; the scenes and builder runs must be theirs.
  const std::filesystem::path config_path =
      options.config ? *options.config : std::filesystem::path(first.config);
  const ExperimentConfig cfg = load_experiment_config(config_path);
  for (const BuilderRun& run : cfg.builders) require_resolved(run);
  const std::vector<std::string> scenes = scenes_to_run(cfg, log);
  std::vector<std::string> builder_runs;
  for (const auto& b : cfg.builders) builder_runs.push_back(b.name + " " + b.params_text());
  const Fingerprint here = fingerprint_of(cfg, scenes, builder_runs, current_environment());
  for (const auto& [name, hash] : here.parts) {
    if (name == "build") continue;  // the merge may run on another machine or build than the shards
    for (const auto& [theirs, their_hash] : Fingerprint::parse_parts(first.parts))
      if (theirs == name && their_hash != hash)
        throw Error(
            fmt::format("merge: the config {} differs from the one the shards ran in '{}'; give the "
                        "shards' config with --config",
                        config_path.string(), name));
  }
  // The layouts a run skips depend on the CPU the shards ran on (no 16-wide packets without AVX-512):
  // take those their rows have, not this machine's. A layout of ours that every CPU runs is planned
  // whether or not it has rows, so that its cells count as missing when none came back.
  const auto seen = [&](bool embree, const std::string& layout) {
    return std::any_of(files.begin(), files.end(), [&](const ShardFile& f) {
      return std::any_of(f.rows.begin(), f.rows.end(), [&](const CsvRow& r) {
        return (field(r, "builder") == "embree") == embree && field(r, "layout") == layout;
      });
    });
  };
  RunLayouts layouts;
  for (const LayoutSpec& l : cfg.layouts) {
    if (!layout_depends_on_cpu(l) || seen(false, l.text()))
      layouts.ours.push_back(l);
    else
      log << fmt::format("layout {}: no rows in any shard, taken as skipped by the shards' CPU\n", l.text());
  }
  for (const EmbreeLayout& l : kEmbreeLayouts)
    if (seen(true, l.name)) layouts.embree.push_back(l);
  const ShardPlan plan = plan_shards(cfg, scenes, layouts, n);
  std::map<std::string, std::size_t> cell_of;
  for (std::size_t i = 0; i < plan.cells.size(); ++i) cell_of.emplace(plan.cells[i].key, i);

  // Every row a cell of its shard's plan, and every cell of every shard's plan once.
  std::vector<std::string> missing_shards, stray, duplicated, missing;
  std::map<std::pair<std::size_t, int>, std::vector<std::string>> found;  // (cell, shard) -> where
  for (const ShardFile& f : files)
    for (std::size_t r = 0; r < f.rows.size(); ++r) {
      const CsvRow& row = f.rows[r];
      const std::string key = cell_key(
          field(row, "scene"), field(row, "builder"), field(row, "builder_params"), field(row, "layout"),
          whole_number(f, r, "threads"), field(row, "ray_set"), whole_number(f, r, "frame"));
      const auto it = cell_of.find(key);
      if (it == cell_of.end()) {
        stray.push_back(fmt::format("{} in {}: not a cell of the plan", key, f.name()));
      } else if (!plan.owns(it->second, f.spec.index)) {
        stray.push_back(fmt::format("{} in {}: the plan gives it to shard {}", key, f.name(),
                                    fmt::join(plan.owners[it->second], ", ")));
      } else {
        found[{it->second, f.spec.index}].push_back(std::to_string(r + 1));
      }
    }
  for (int k = 0; k < n; ++k) {
    std::size_t cells = 0;
    for (std::size_t i = 0; i < plan.cells.size(); ++i) cells += plan.owns(i, k);
    if (cells > 0 && !by_index.count(k))
      missing_shards.push_back(
          fmt::format("shard {}/{} ({} cells): no CSV given, or it has no rows", k, n, cells));
  }
  for (std::size_t i = 0; i < plan.cells.size(); ++i)
    for (const int k : plan.owners[i]) {
      if (!by_index.count(k)) continue;
      const auto it = found.find({i, k});
      if (it == found.end())
        missing.push_back(
            fmt::format("{} (shard {}/{}, {})", plan.cells[i].key, k, n, by_index.at(k)->path.string()));
      else if (it->second.size() > 1)
        duplicated.push_back(fmt::format("{} (shard {}/{}, {}: data rows {})", plan.cells[i].key, k, n,
                                         by_index.at(k)->path.string(), fmt::join(it->second, ", ")));
    }
  std::string problems;
  if (!missing_shards.empty()) problems += "\nmissing shards:" + named(missing_shards);
  if (!missing.empty()) problems += fmt::format("\n{} missing cells:", missing.size()) + named(missing);
  if (!duplicated.empty())
    problems += fmt::format("\n{} duplicated cells:", duplicated.size()) + named(duplicated);
  if (!stray.empty())
    problems += fmt::format("\n{} rows not planned for their shard:", stray.size()) + named(stray);
  if (!problems.empty())
    throw Error(
        fmt::format("merge: the shards of {} (fingerprint {}, {} shards) do not cover the plan of "
                    "{} cells once:{}",
                    config_path.string(), first.fingerprint, n, plan.cells.size(), problems));

  // One run id for the merged rows, the same whenever the same shards are merged.
  std::vector<std::string> ids;
  for (const auto& [k, f] : by_index) ids.push_back(f->run_id);
  MergeSummary summary;
  summary.shards = n;
  // FNV-1a (32 bits) of the shards' run ids tells merges of different shard runs apart.
  uint32_t h = 2166136261u;
  for (const char c : fmt::format("{}", fmt::join(ids, ",")))
    h = (h ^ static_cast<unsigned char>(c)) * 16777619u;
  summary.run_id = fmt::format("{}-merged-{}-{:08x}", cfg.name, first.fingerprint.substr(0, 8), h);
  // The run's own lock (run_session.h): no run may be writing the output while it is replaced.
  const OutputLock lock(options.output);
  check_output_replaceable(options.output);
  // Written beside the output and renamed over it, so that a failed merge leaves no half-written file.
  const std::filesystem::path partial = options.output.string() + ".partial";
  std::filesystem::remove(partial);
  {
    CsvWriter csv(partial, result_columns());
    for (const auto& [k, f] : by_index)
      for (CsvRow row : f->rows) {
        row["shard_run_id"] = row["run_id"];
        row["run_id"] = summary.run_id;
        csv.append(row);
        ++summary.rows;
      }
  }
  std::filesystem::rename(partial, options.output);
  log << fmt::format("merge: {} rows of {} shards ({} with rows) into {}, run {}\n", summary.rows, n,
                     by_index.size(), options.output.string(), summary.run_id);
  return summary;
}

}  // namespace sahbench
