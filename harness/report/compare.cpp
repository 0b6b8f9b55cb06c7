#include "harness/report/compare.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <ostream>

#include "core/error.h"
#include "harness/report/ratio_stats.h"
#include "harness/report/result_cells.h"
#include "harness/run/result_row.h"

namespace sahbench {
namespace {

const std::vector<std::string>& key_columns() {
  static const std::vector<std::string> columns = {"scene",  "builder", "builder_params",
                                                   "layout", "threads", "ray_set",
                                                   "frame",  "run_id",  "run_fingerprint"};
  return columns;
}

// The timings compared, as ratios to Embree: rays/s (larger is better) and build time.
struct TimingMetric {
  const char* prefix;
  bool larger_is_better;
};
constexpr TimingMetric kTimingMetrics[] = {{"trace_mrays", true}, {"build_ms", false}};

// run_fingerprint is 16 lowercase hex digits (a hash of the resolved config, scene sources and build).
bool is_fingerprint(const std::string& text) {
  return text.size() == 16 && std::all_of(text.begin(), text.end(), [](char c) {
           return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
         });
}

// Embree's rows are anchors, not subjects: its structure and its packet widths depend on the CPU (no
// 16-wide rows without AVX-512), so they neither gate nor count as missing.
bool is_embree(const ResultFile& file, std::size_t i) {
  return file.field(i, "builder") == "embree";
}

// The key of row i's cell, or of its anchor's. A merged sweep (harness/run/shard_merge.h) holds Embree's
// rows once per shard: they, and the anchor a row is paired with, are keyed by the row's shard too, so
// that every ratio stays one of a single process on one node.
std::string key_of(const ResultFile& file, std::size_t i, bool anchor) {
  const int threads = checked_integer(file, i, "threads"), frame = checked_integer(file, i, "frame");
  const std::string& shard = file.field(i, "shard");
  const std::string in_shard = shard.empty() ? "" : " @shard " + shard;
  if (anchor)
    return cell_key(file.field(i, "scene"), std::string(kAnchorBuilder), std::string(kAnchorParams),
                    std::string(kAnchorLayout), threads, file.field(i, "ray_set"), frame) +
           in_shard;
  return cell_key(file.field(i, "scene"), file.field(i, "builder"), file.field(i, "builder_params"),
                  file.field(i, "layout"), threads, file.field(i, "ray_set"), frame) +
         (is_embree(file, i) ? in_shard : "");
}

// The latest run of a file (rows are appended as cells finish, so the last row's run), checked: the
// required columns are there, the run has one fingerprint, no cell is there twice, and the gated rows'
// deterministic metrics are numbers.
struct Run {
  ResultFile file;
  std::string id;
  std::map<std::string, std::size_t> cells;  // cell key -> row index

  std::optional<std::size_t> find(const std::string& key) const {
    const auto it = cells.find(key);
    return it == cells.end() ? std::nullopt : std::optional<std::size_t>(it->second);
  }
};

Run latest_run(const std::filesystem::path& path, bool deterministic_only) {
  Run run{read_result_file(path), {}, {}};
  const ResultFile& f = run.file;
  if (f.rows.empty()) throw Error(path.string() + ": no result rows");
  for (const auto& column : required_columns(deterministic_only))
    if (!f.has_column(column))
      throw Error(fmt::format("{}:1: the header has no column '{}'{}", path.string(), column,
                              column.ends_with("_samples")
                                  ? " (timings are compared from per-round samples; a CSV from before "
                                    "they were written can be compared with --deterministic-only)"
                                  : ""));
  run.id = f.rows.back().at("run_id");
  std::optional<std::size_t> first;
  for (std::size_t i = 0; i < f.rows.size(); ++i) {
    if (f.field(i, "run_id") != run.id) continue;
    const std::string& fingerprint = f.field(i, "run_fingerprint");
    if (!is_fingerprint(fingerprint))
      throw row_error(f, i, "run_fingerprint", "'" + fingerprint + "' is not 16 lowercase hex digits");
    if (!first) first = i;
    if (fingerprint != f.field(*first, "run_fingerprint"))
      throw Error(
          fmt::format("{}: lines {} and {} of run '{}' differ in column 'run_fingerprint' ('{}' and "
                      "'{}'): rows of two different runs under one run id",
                      path.string(), f.lines[*first], f.lines[i], run.id, f.field(*first, "run_fingerprint"),
                      fingerprint));
    const auto [it, added] = run.cells.emplace(key_of(f, i, false), i);
    if (!added)
      throw Error(
          fmt::format("{}: lines {} and {} of run '{}' are the same cell (columns scene, builder, "
                      "builder_params, layout, threads, ray_set, frame: {})",
                      path.string(), f.lines[it->second], f.lines[i], run.id, it->first));
    if (is_embree(f, i)) continue;
    for (const MetricRule& rule : deterministic_metrics())
      if (f.has_column(rule.column)) checked_number(f, i, rule.column);
  }
  return run;
}

// Row i's ratio to its anchor (row a) for `prefix`, from their samples paired by round; none where the
// row has no such timing. A timed row without samples is an Error: the ratio needs them.
std::optional<RatioInterval> ratio_to_anchor(const ResultFile& f, std::size_t i, std::size_t a,
                                             const std::string& prefix) {
  const std::string samples_column = prefix + "_samples", median_column = prefix + "_median";
  for (const std::size_t r : {i, a})
    if (!checked_number(f, r, median_column)) return std::nullopt;
  const auto ours = timing_samples(f, i, prefix), anchor = timing_samples(f, a, prefix);
  for (const std::size_t r : {i, a})
    if ((r == i ? ours : anchor).empty())
      throw row_error(f, r, samples_column,
                      fmt::format("empty, while {} is '{}': timings are compared from per-round samples (a "
                                  "row from before they were written can be compared with "
                                  "--deterministic-only)",
                                  median_column, f.field(r, median_column)));
  try {
    return paired_ratio(ours, anchor);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: lines {} and {} (its anchor): column '{}': {}", f.path.string(), f.lines[i],
                            f.lines[a], samples_column, e.what()));
  }
}

struct Finding {
  std::string cell, metric;
  double baseline, current;
  bool regression;
  std::optional<RatioInterval> change;  ///< timings: the change of the ratio, with its interval
};

// A cell key in a Markdown table: its '|' separators escaped, or they would split the cell (GitHub
// Flavored Markdown, tables: "include a pipe in a cell's content by escaping it").
std::string markdown_key(const std::string& key) {
  std::string out;
  for (const char c : key) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

std::string percent(double ratio) {
  return fmt::format("{:+.2f}%", 100.0 * (ratio - 1.0));
}

struct JsonEntry {
  std::string name, unit;
  double value;
};

void write_json(const std::filesystem::path& path, const std::vector<JsonEntry>& entries) {
  std::ofstream out(path);
  if (!out) throw Error(path.string() + ": cannot open for writing");
  out << "[\n";
  for (std::size_t i = 0; i < entries.size(); ++i)
    out << fmt::format("  {{\"name\": \"{}\", \"unit\": \"{}\", \"value\": {:.9g}}}{}\n", entries[i].name,
                       entries[i].unit, entries[i].value, i + 1 < entries.size() ? "," : "");
  out << "]\n";
}

}  // namespace

const std::vector<MetricRule>& deterministic_metrics() {
  // Same code, same input, same seed: these are reproducible to the bit on one build configuration; the
  // small tolerances absorb only printing precision.
  static const std::vector<MetricRule> rules = {
      {"sah_cost", true, 1e-6},      {"nodes", true, 0.0},
      {"leaves", true, 0.0},         {"max_depth", true, 0.0},
      {"nodes_per_ray", true, 1e-6}, {"prims_per_ray", true, 1e-6},
      {"mem_bytes", true, 0.0},      {"refs_per_prim", true, 1e-6},
      {"mismatches", true, 0.0},     {"leaves_per_ray", true, 1e-6, true},
  };
  return rules;
}

std::vector<std::string> required_columns(bool deterministic_only) {
  std::vector<std::string> columns = key_columns();
  for (const MetricRule& rule : deterministic_metrics())
    if (!rule.optional) columns.push_back(rule.column);
  if (!deterministic_only)
    for (const TimingMetric& t : kTimingMetrics) columns.push_back(std::string(t.prefix) + "_samples");
  return columns;
}

CompareResult compare_results(const CompareOptions& options, std::ostream& out) {
  const Run base = latest_run(options.baseline, options.deterministic_only);
  const Run cur = latest_run(options.current, options.deterministic_only);
  const ResultFile &bf = base.file, &cf = cur.file;
  CompareResult result;
  std::vector<Finding> findings;
  std::vector<JsonEntry> smaller, bigger;
  std::vector<std::string> unanchored;       // cells with an anchor in the baseline only
  std::vector<std::string> unanchored_base;  // cells without an anchor in the baseline
  std::vector<MetricRule> metrics;           // the deterministic metrics compared
  std::vector<std::string> not_in_base;      // optional metrics the baseline predates
  for (const MetricRule& rule : deterministic_metrics()) {
    const bool in_base = bf.has_column(rule.column), in_cur = cf.has_column(rule.column);
    if (in_base && in_cur) {
      metrics.push_back(rule);
      continue;
    }
    // latest_run has refused a file without a required column; an optional one is excused only in the
    // baseline: a new run that lost a column the baseline gates would otherwise pass unchecked.
    if (in_base)
      throw Error(fmt::format("{}:1: the header has no column '{}' (the baseline {} has it)",
                              options.current.string(), rule.column, options.baseline.string()));
    not_in_base.push_back(rule.column);
  }

  for (const auto& [key, bi] : base.cells) {
    if (is_embree(bf, bi)) continue;
    const auto ci_found = cur.find(key);
    if (!ci_found) {
      ++result.missing_cells;
      continue;
    }
    const std::size_t ci = *ci_found;
    ++result.compared_cells;
    for (const MetricRule& rule : metrics) {
      const auto vb = checked_number(bf, bi, rule.column), vc = checked_number(cf, ci, rule.column);
      // An empty metric (no reference: no mismatches) must be empty in both.
      if (!vb && !vc) continue;
      if (!vb || !vc) {
        const bool base_empty = !vb;
        throw row_error(base_empty ? bf : cf, base_empty ? bi : ci, rule.column,
                        fmt::format("empty, but {} has '{}'", base_empty ? cf.where(ci) : bf.where(bi),
                                    base_empty ? cf.field(ci, rule.column) : bf.field(bi, rule.column)));
      }
      smaller.push_back({key + " " + rule.column, rule.column, *vc});
      const double rel = (*vc - *vb) / std::max(std::fabs(*vb), 1e-12);
      if (std::fabs(rel) <= rule.tolerance) continue;
      const bool worse = rule.larger_is_worse ? rel > 0 : rel < 0;
      findings.push_back({key, rule.column, *vb, *vc, worse, std::nullopt});
    }
    if (options.deterministic_only) continue;
    // Timings: only as ratios to Embree in the same run, each from samples paired by round, and their
    // change flagged only when its interval excludes no change and it exceeds the margin.
    const auto ab = base.find(key_of(bf, bi, true)), ac = cur.find(key_of(cf, ci, true));
    if (ab && !ac) {
      ++result.missing_anchors;
      unanchored.push_back(key);
    }
    if (!ab) unanchored_base.push_back(key);
    if (!ab || !ac) continue;
    for (const TimingMetric& t : kTimingMetrics) {
      const auto rb = ratio_to_anchor(bf, bi, *ab, t.prefix), rc = ratio_to_anchor(cf, ci, *ac, t.prefix);
      if (!rb || !rc) continue;
      const RatioInterval change = ratio_change(*rb, *rc);
      const std::string metric = std::string(t.prefix) + "/embree";
      (t.larger_is_better ? bigger : smaller).push_back({key + " " + metric, "ratio", rc->estimate});
      if (!change.has_interval()) {
        ++result.timings_without_interval;
        continue;
      }
      const Verdict v = verdict(change, t.larger_is_better);
      const double margin = options.min_timing_margin;
      const bool beyond_margin = change.estimate > 1.0 + margin || change.estimate < 1.0 - margin;
      if (v != Verdict::kWithinNoise && beyond_margin)
        findings.push_back({key, metric, rb->estimate, rc->estimate, v == Verdict::kBehind, change});
    }
  }

  // A baseline without any of Embree's rows gates no timing at all: passing would say they were checked.
  // One that lacks some anchors leaves those cells' timings out, and says which.
  if (!unanchored_base.empty() && unanchored_base.size() == static_cast<std::size_t>(result.compared_cells))
    throw Error(
        fmt::format("{}: the baseline has no Embree anchor (embree [quality=medium] in its default mode, "
                    "embree_1) for any of its {} cells, "
                    "so no timing can be compared; make the baseline with Embree in the run, or compare with "
                    "--deterministic-only",
                    options.baseline.string(), result.compared_cells));
  for (const auto& f : findings) (f.regression ? result.regressions : result.improvements) += 1;
  result.regressions += result.missing_cells + result.missing_anchors;
  fmt::print(
      out,
      "# sahbench compare\n\nbaseline {} vs {}: {} cells compared, {} missing (each a regression{}), {} "
      "other regressions, {} improvements{}\n\n",
      options.baseline.string(), options.current.string(), result.compared_cells,
      result.missing_cells + result.missing_anchors,
      result.missing_anchors
          ? fmt::format("; {} of them cells whose Embree anchor alone is missing", result.missing_anchors)
          : "",
      result.regressions - result.missing_cells - result.missing_anchors, result.improvements,
      options.deterministic_only ? " (deterministic metrics only)" : "");
  for (const ResultFile* f : {&bf, &cf})
    if (f->cut_last_line)
      fmt::print(out,
                 "Note: {}: its last line is incomplete (a run stopped while writing it); that row is "
                 "left out.\n\n",
                 f->path.string());
  if (!not_in_base.empty())
    fmt::print(out, "Not compared: {}, which the baseline {} has no column for (a CSV from before it).\n\n",
               fmt::join(not_in_base, ", "), options.baseline.string());
  if (!options.deterministic_only)
    fmt::print(
        out,
        "Timing ratios to Embree are geometric means of per-round ratios; a change is flagged when its "
        "95% interval lies wholly on one side of no change and it exceeds {:.1f}%.{}\n\n",
        100.0 * options.min_timing_margin,
        result.timings_without_interval
            ? fmt::format(" {} timing ratios come from one round in a run and cannot be told from "
                          "noise; they are not gated.",
                          result.timings_without_interval)
            : "");
  if (!findings.empty()) {
    fmt::print(out,
               "| | cell | metric | baseline | new | change | 95% interval of the change |\n"
               "|---|---|---|---:|---:|---:|---:|\n");
    for (const auto& f : findings) {
      const std::string change = f.change
                                     ? percent(f.change->estimate)
                                     : fmt::format("{:+.2f}%", 100.0 * (f.current - f.baseline) /
                                                                   std::max(std::fabs(f.baseline), 1e-12));
      const std::string interval =
          f.change ? fmt::format("[{}, {}]", percent(*f.change->lo), percent(*f.change->hi)) : "-";
      fmt::print(out, "| {} | {} | {} | {:.6g} | {:.6g} | {} | {} |\n",
                 f.regression ? "REGRESSION" : "improved", markdown_key(f.cell), f.metric, f.baseline,
                 f.current, change, interval);
    }
  }
  if (result.missing_anchors) {
    fmt::print(out,
               "\nCells whose new run has no Embree anchor (embree [quality=medium] in its default mode, "
               "embree_1), so their "
               "timings were not compared (counted as regressions):\n");
    for (const auto& key : unanchored) fmt::print(out, "- {}\n", key);
  }
  if (!unanchored_base.empty()) {
    fmt::print(out,
               "\nCells whose baseline has no Embree anchor, so their timings were not compared (not counted "
               "as regressions; make the baseline with Embree in the run to gate them):\n");
    for (const auto& key : unanchored_base) fmt::print(out, "- {}\n", key);
  }
  if (result.missing_cells) {
    fmt::print(out, "\nCells in the baseline but not in the new run:\n");
    for (const auto& [key, bi] : base.cells)
      if (!is_embree(bf, bi) && !cur.find(key)) fmt::print(out, "- {}\n", key);
  }
  if (options.json) {
    write_json(*options.json, smaller);
    auto bigger_path = *options.json;
    bigger_path.replace_filename(options.json->stem().string() + "-bigger" +
                                 options.json->extension().string());
    write_json(bigger_path, bigger);
  }
  return result;
}

}  // namespace sahbench
