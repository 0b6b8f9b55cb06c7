#include "harness/report/compare.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <ostream>
#include <set>
#include <string_view>

#include "core/error.h"
#include "harness/report/ratio_stats.h"
#include "harness/report/result_cells.h"
#include "harness/report/stress_report.h"
#include "harness/run/result_row.h"
#include "harness/run/run_session.h"

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
  if (is_stress_result(f.rows))
    throw Error(
        path.string() +
        ": a `sahbench stress` result, which compare does not gate (its rows are cases, not the cells "
        "of a run); compare two CSVs of `sahbench run`, and read this one with `sahbench report`");
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
  double holm_p = 1.0;                  ///< timings: Holm's adjusted p-value of no change
};

// A timing change with an interval, before Holm's procedure decides which are flagged.
struct TimingChange {
  std::string cell, metric;
  double baseline, current;
  RatioInterval change;
  bool larger_is_better;
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
  // Through a JSON library: cell names hold scene paths, which may hold quotes and backslashes.
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const JsonEntry& e : entries) list.push_back({{"name", e.name}, {"unit", e.unit}, {"value", e.value}});
  out << list.dump(2) << "\n";
}

// The parts of a run's fingerprint (harness/run/run_session.h) that decide what its cells measure: two
// runs that differ in one of them measure other inputs under the same cell names. The build (what a
// comparison is for), the repetitions, and the lists of builders, layouts and threads (which add or
// remove cells, each named by its key) may differ. The scenes, ray sets and cameras are hashed as lists,
// so their parts are held to only where both runs have the same scenes and ray sets; where one run has
// more, each cell's own scene size and ray count are (check_same_cell_input).
constexpr std::string_view kInputParts[] = {"seed", "reference", "animation"};

std::optional<std::vector<std::pair<std::string, std::string>>> input_parts(const Run& run) {
  const ResultFile& f = run.file;
  if (!f.has_column("fingerprint_parts")) return std::nullopt;
  const std::string& text = f.field(run.cells.begin()->second, "fingerprint_parts");
  if (text.empty()) return std::nullopt;
  return Fingerprint::parse_parts(text);
}

std::set<std::string> values_of(const Run& run, const std::string& column) {
  std::set<std::string> out;
  for (const auto& [key, i] : run.cells) out.insert(run.file.field(i, column));
  return out;
}

// Refuses two runs whose cells measure different inputs, naming what differs; returns a note for the
// summary where the inputs could not be checked (a CSV from before fingerprint_parts).
std::string check_same_inputs(const Run& base, const Run& cur) {
  const auto bp = input_parts(base), cp = input_parts(cur);
  if (!bp || !cp)
    return fmt::format(
        "Inputs not checked: {} has no fingerprint_parts (a CSV from before them); only each "
        "cell's scene_triangles and ray_count are held to its baseline's.",
        (!bp ? base : cur).file.path.string());
  auto part = [](const std::vector<std::pair<std::string, std::string>>& parts, std::string_view name) {
    const auto it = std::find_if(parts.begin(), parts.end(), [&](const auto& p) { return p.first == name; });
    return it == parts.end() ? std::string() : it->second;
  };
  std::vector<std::string> differ;
  for (const std::string_view name : kInputParts)
    if (part(*bp, name) != part(*cp, name)) differ.emplace_back(name);
  const bool same_scenes = values_of(base, "scene") == values_of(cur, "scene");
  const bool same_sets = values_of(base, "ray_set") == values_of(cur, "ray_set");
  if (same_scenes && part(*bp, "scenes") != part(*cp, "scenes"))
    differ.emplace_back("scenes (a scene file's path, size or contents, or the scenes' order)");
  if (same_sets && part(*bp, "ray_sets") != part(*cp, "ray_sets"))
    differ.emplace_back("ray_sets (a ray set's size, lights or radius, or the sets' order)");
  if (same_scenes && part(*bp, "cameras") != part(*cp, "cameras"))
    differ.emplace_back("cameras (a view or the lights of a scene)");
  if (!differ.empty())
    throw Error(fmt::format(
        "{} (run {}) and {} (run {}) measure different inputs, so their cells are not comparable: their "
        "fingerprint_parts differ in {}; make the baseline from the same config and scenes",
        base.file.path.string(), base.id, cur.file.path.string(), cur.id, fmt::join(differ, ", ")));
  return "";
}

// A cell's input, as far as its own row tells it: the same scene size and number of rays in both runs.
void check_same_cell_input(const Run& base, std::size_t bi, const Run& cur, std::size_t ci) {
  for (const char* column : {"scene_triangles", "ray_count"}) {
    if (!base.file.has_column(column) || !cur.file.has_column(column)) continue;
    const std::string &b = base.file.field(bi, column), &c = cur.file.field(ci, column);
    if (b != c)
      throw Error(
          fmt::format("{}: column '{}' is '{}', where {} has '{}': the cell measures another input "
                      "than its baseline, and is not comparable",
                      cur.file.where(ci), column, c, base.file.where(bi), b));
  }
}

// A deterministic metric's change in the summary: relative, or the difference where the baseline is 0
// (0 to 1 mismatches is no percentage).
std::string deterministic_change(double baseline, double current) {
  if (baseline == 0.0) return fmt::format("{:+.6g}", current - baseline);
  return fmt::format("{:+.2f}%", 100.0 * (current - baseline) / std::fabs(baseline));
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
  const std::string inputs_note = check_same_inputs(base, cur);
  CompareResult result;
  std::vector<Finding> findings;
  std::vector<TimingChange> timing_changes;
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
    check_same_cell_input(base, bi, cur, ci);
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
    // Timings: only as ratios to Embree in the same run, each from samples paired by round; their changes
    // are judged together below.
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
      timing_changes.push_back({key, metric, rb->estimate, rc->estimate, change, t.larger_is_better});
    }
  }
  // A change is flagged where it exceeds the margin and Holm's procedure over every timing change of the
  // file rejects no change: a hundred intervals at 95% each would flag an unchanged build somewhere most
  // of the time.
  std::vector<double> p_values;
  for (const TimingChange& t : timing_changes) p_values.push_back(p_value_of_no_change(t.change));
  const HolmResult holm_result = holm(p_values);
  result.timing_comparisons = static_cast<int>(timing_changes.size());
  std::vector<double> half_widths;  // of the changes' 95% intervals, on the log scale
  for (std::size_t k = 0; k < timing_changes.size(); ++k) {
    const TimingChange& t = timing_changes[k];
    half_widths.push_back(0.5 * std::log(*t.change.hi / *t.change.lo));
    const double margin = options.min_timing_margin;
    const bool beyond_margin = t.change.estimate > 1.0 + margin || t.change.estimate < 1.0 - margin;
    if (!holm_result.rejected[k] || !beyond_margin) continue;
    const bool worse = t.larger_is_better ? t.change.estimate < 1.0 : t.change.estimate > 1.0;
    findings.push_back({t.cell, t.metric, t.baseline, t.current, worse, t.change, holm_result.adjusted[k]});
  }
  std::vector<std::string> only_new;  // cells of the new run the baseline lacks
  for (const auto& [key, i] : cur.cells)
    if (!is_embree(cf, i) && !base.find(key)) only_new.push_back(key);
  result.new_cells = static_cast<int>(only_new.size());

  // A baseline without any of Embree's rows gates no timing at all: passing would say they were checked.
  // One that lacks some anchors leaves those cells' timings out, and says which.
  if (!unanchored_base.empty() && unanchored_base.size() == static_cast<std::size_t>(result.compared_cells))
    throw Error(
        fmt::format("{}: the baseline has no Embree anchor (embree [quality=medium] in its default mode, "
                    "embree_1) for any of its {} cells, "
                    "so no timing can be compared; make the baseline with Embree in the run, or compare with "
                    "--deterministic-only",
                    options.baseline.string(), result.compared_cells));
  for (const auto& f : findings) {
    (f.regression ? result.regressions : result.improvements) += 1;
    if (!f.regression && !f.change) ++result.out_of_date;
  }
  result.regressions += result.missing_cells + result.missing_anchors;
  fmt::print(
      out,
      "# sahbench compare\n\nbaseline {} vs {}: {} cells compared, {} missing (each a regression{}), {} "
      "other regressions, {} improvements{}{}{}\n\n",
      options.baseline.string(), options.current.string(), result.compared_cells,
      result.missing_cells + result.missing_anchors,
      result.missing_anchors
          ? fmt::format("; {} of them cells whose Embree anchor alone is missing", result.missing_anchors)
          : "",
      result.regressions - result.missing_cells - result.missing_anchors, result.improvements,
      result.out_of_date
          ? fmt::format(" ({} of a deterministic metric: the baseline is out of date)", result.out_of_date)
          : "",
      result.new_cells ? fmt::format(", {} new cells (not gated)", result.new_cells) : "",
      options.deterministic_only ? " (deterministic metrics only)" : "");
  if (result.out_of_date)
    fmt::print(out,
               "Deterministic metrics are reproduced to the bit by the same code on the same input: an "
               "improvement means the baseline no longer describes the code, and a later regression below "
               "its old value would pass. The gate fails until the baseline is made again from the new run "
               "(copy {} over {} and commit it).\n\n",
               options.current.string(), options.baseline.string());
  if (!inputs_note.empty()) fmt::print(out, "{}\n\n", inputs_note);
  for (const ResultFile* f : {&bf, &cf})
    if (f->cut_last_line)
      fmt::print(out,
                 "Note: {}: its last line is incomplete (a run stopped while writing it); that row is "
                 "left out.\n\n",
                 f->path.string());
  if (!not_in_base.empty())
    fmt::print(out, "Not compared: {}, which the baseline {} has no column for (a CSV from before it).\n\n",
               fmt::join(not_in_base, ", "), options.baseline.string());
  if (!options.deterministic_only) {
    fmt::print(out,
               "Timing ratios to Embree are geometric means of per-round ratios; a change is flagged when it "
               "exceeds {:.1f}% and Holm's step-down test over the file's {} timing changes rejects no "
               "change, which keeps the chance of flagging an unchanged build anywhere at 5% (the table "
               "gives each change's own 95% interval and its Holm-adjusted p).{}\n\n",
               100.0 * options.min_timing_margin, result.timing_comparisons,
               result.timings_without_interval
                   ? fmt::format(" {} timing ratios come from one round in a run and cannot be told from "
                                 "noise; they are not gated.",
                                 result.timings_without_interval)
                   : "");
    // What the gate can see: a change well inside a cell's interval is not measured, flagged or not.
    if (!half_widths.empty()) {
      std::sort(half_widths.begin(), half_widths.end());
      constexpr double kWide = 0.10;  // log scale: about +-10%
      const auto wide =
          std::count_if(half_widths.begin(), half_widths.end(), [](double h) { return h > kWide; });
      const double median = half_widths[half_widths.size() / 2];
      fmt::print(
          out,
          "Resolution: the median 95% interval of a change reaches from {:+.1f}% to {:+.1f}%; {} of {} "
          "reach beyond +-10% and cannot show a change that small (more trace rounds narrow them).\n\n",
          100.0 * (std::exp(-median) - 1.0), 100.0 * (std::exp(median) - 1.0), wide, half_widths.size());
    }
  }
  if (!findings.empty()) {
    fmt::print(out,
               "| | cell | metric | baseline | new | change | 95% interval of the change | p (Holm) |\n"
               "|---|---|---|---:|---:|---:|---:|---:|\n");
    for (const auto& f : findings) {
      const std::string change =
          f.change ? percent(f.change->estimate) : deterministic_change(f.baseline, f.current);
      const std::string interval =
          f.change ? fmt::format("[{}, {}]", percent(*f.change->lo), percent(*f.change->hi)) : "-";
      const std::string label = f.regression ? "REGRESSION"
                                : f.change   ? "improved"
                                             : "improved (out of date)";
      fmt::print(out, "| {} | {} | {} | {:.6g} | {:.6g} | {} | {} | {} |\n", label, markdown_key(f.cell),
                 f.metric, f.baseline, f.current, change, interval,
                 f.change ? fmt::format("{:.2g}", f.holm_p) : "-");
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
  if (!only_new.empty()) {
    fmt::print(
        out,
        "\nCells in the new run but not in the baseline (not gated; make a new baseline to gate them):\n");
    for (const auto& key : only_new) fmt::print(out, "- {}\n", key);
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
