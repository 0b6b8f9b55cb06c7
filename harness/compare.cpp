#include "harness/compare.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <ostream>

#include "core/error.h"
#include "harness/csv.h"
#include "harness/runner.h"

namespace sahbench {
namespace {

// The latest run of a file (rows are appended as cells finish, so the last row's run), keyed by cell.
std::map<std::string, CsvRow> latest_run(const std::filesystem::path& path) {
  const auto rows = read_csv(path);
  if (rows.empty()) throw Error(path.string() + ": no result rows");
  const std::string run = rows.back().at("run_id");
  std::map<std::string, CsvRow> cells;
  for (const auto& r : rows)
    if (r.at("run_id") == run)
      cells[cell_key(r.at("scene"), r.at("builder"), r.at("builder_params"), r.at("layout"),
                     std::stoi(r.at("threads")), r.at("ray_set"), std::stoi(r.at("frame")))] = r;
  return cells;
}

bool is_embree(const CsvRow& r) {
  return r.at("builder") == "embree";
}

// The anchor of a cell: Embree medium, one ray at a time, same scene, threads and ray set, same run.
const CsvRow* anchor_of(const CsvRow& r, const std::map<std::string, CsvRow>& run) {
  const auto it = run.find(cell_key(r.at("scene"), "embree", "quality=medium", "embree_1",
                                    std::stoi(r.at("threads")), r.at("ray_set"), std::stoi(r.at("frame"))));
  return it == run.end() ? nullptr : &it->second;
}

// Relative spread (max - min) / median of a timing column, the noise a comparison must allow for.
double spread(const CsvRow& r, const std::string& prefix) {
  const auto med = csv_number(r, (prefix + "_median").c_str()), lo = csv_number(r, (prefix + "_min").c_str()),
             hi = csv_number(r, (prefix + "_max").c_str());
  if (!med || !lo || !hi || *med <= 0) return 0.0;
  return (*hi - *lo) / *med;
}

struct Finding {
  std::string cell, metric;
  double baseline, current;
  bool regression;
};

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
      {"sah_cost", true, 1e-6}, {"nodes", true, 0.0},          {"leaves", true, 0.0},
      {"max_depth", true, 0.0}, {"nodes_per_ray", true, 1e-6}, {"prims_per_ray", true, 1e-6},
      {"mem_bytes", true, 0.0}, {"refs_per_prim", true, 1e-6}, {"mismatches", true, 0.0},
  };
  return rules;
}

CompareResult compare_results(const CompareOptions& options, std::ostream& out) {
  const auto base = latest_run(options.baseline);
  const auto cur = latest_run(options.current);
  CompareResult result;
  std::vector<Finding> findings;
  std::vector<JsonEntry> smaller, bigger;

  for (const auto& [key, b] : base) {
    // Embree's rows are anchors, not subjects: its structure and its packet widths depend on the CPU
    // (no 16-wide rows without AVX-512), so they neither gate nor count as missing.
    if (is_embree(b)) continue;
    const auto it = cur.find(key);
    if (it == cur.end()) {
      ++result.missing_cells;
      continue;
    }
    const CsvRow& c = it->second;
    ++result.compared_cells;
    for (const MetricRule& rule : deterministic_metrics()) {
      const auto vb = csv_number(b, rule.column), vc = csv_number(c, rule.column);
      if (!vb || !vc) continue;
      smaller.push_back({key + " " + rule.column, rule.column, *vc});
      const double rel = (*vc - *vb) / std::max(std::fabs(*vb), 1e-12);
      if (std::fabs(rel) <= rule.tolerance) continue;
      const bool worse = rule.larger_is_worse ? rel > 0 : rel < 0;
      findings.push_back({key, rule.column, *vb, *vc, worse});
    }
    if (options.deterministic_only) continue;
    // Timings: only as ratios to Embree in the same run, with a margin from the measured spread.
    const CsvRow* ab = anchor_of(b, base);
    const CsvRow* ac = anchor_of(c, cur);
    if (!ab || !ac) continue;
    for (const auto& [prefix, bigger_is_better] :
         {std::pair<std::string, bool>{"trace_mrays", true}, {"build_ms", false}}) {
      const auto ob = csv_number(b, (prefix + "_median").c_str()),
                 oc = csv_number(c, (prefix + "_median").c_str());
      const auto eb = csv_number(*ab, (prefix + "_median").c_str()),
                 ec = csv_number(*ac, (prefix + "_median").c_str());
      if (!ob || !oc || !eb || !ec || *eb <= 0 || *ec <= 0) continue;
      const double rb = *ob / *eb, rc = *oc / *ec;
      const double margin = std::max({options.min_timing_margin, spread(b, prefix), spread(c, prefix),
                                      spread(*ab, prefix), spread(*ac, prefix)});
      const std::string metric = prefix + "/embree";
      (bigger_is_better ? bigger : smaller).push_back({key + " " + metric, "ratio", rc});
      const bool worse = bigger_is_better ? rc < rb * (1.0 - margin) : rc > rb * (1.0 + margin);
      const bool better = bigger_is_better ? rc > rb * (1.0 + margin) : rc < rb * (1.0 - margin);
      if (worse || better)
        findings.push_back({key, metric + fmt::format(" (margin {:.0f}%)", 100 * margin), rb, rc, worse});
    }
  }

  for (const auto& f : findings) (f.regression ? result.regressions : result.improvements) += 1;
  result.regressions += result.missing_cells;
  fmt::print(out,
             "# sahbench compare\n\nbaseline {} vs {}: {} cells compared, {} missing, {} regressions, {} "
             "improvements{}\n\n",
             options.baseline.string(), options.current.string(), result.compared_cells, result.missing_cells,
             result.regressions - result.missing_cells, result.improvements,
             options.deterministic_only ? " (deterministic metrics only)" : "");
  if (!findings.empty()) {
    fmt::print(out, "| | cell | metric | baseline | new | change |\n|---|---|---|---:|---:|---:|\n");
    for (const auto& f : findings)
      fmt::print(out, "| {} | {} | {} | {:.6g} | {:.6g} | {:+.2f}% |\n",
                 f.regression ? "REGRESSION" : "improved", f.cell, f.metric, f.baseline, f.current,
                 100.0 * (f.current - f.baseline) / std::max(std::fabs(f.baseline), 1e-12));
  }
  if (result.missing_cells) {
    fmt::print(out, "\nCells in the baseline but not in the new run:\n");
    for (const auto& [key, row] : base)
      if (!is_embree(row) && !cur.count(key)) fmt::print(out, "- {}\n", key);
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
