#include "harness/report.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <map>
#include <optional>
#include <ostream>

#include "core/error.h"
#include "harness/csv.h"
#include "harness/stress_report.h"

namespace sahbench {
namespace {

bool is_anchor(const CsvRow& row) {
  return row.at("builder") == "embree" && row.at("builder_params") == "quality=medium" && row.at("layout") == "embree_1";
}

// "12.3 (0.85x)" with the ratio to the anchor's value when there is one.
std::string with_ratio(std::optional<double> value, std::optional<double> anchor, const char* format) {
  if (!value) return "-";
  std::string s = fmt::format(fmt::runtime(format), *value);
  if (anchor && *anchor > 0) s += fmt::format(" ({:.2f}x)", *value / *anchor);
  return s;
}

std::string row_label(const CsvRow& row) {
  const std::string& params = row.at("builder_params");
  return row.at("builder") + (params.empty() ? "" : " [" + params + "]");
}

}  // namespace

void print_report(const ReportOptions& options, std::ostream& out) {
  std::vector<CsvRow> rows;
  for (const auto& path : options.inputs) {
    auto more = read_csv(path);
    rows.insert(rows.end(), more.begin(), more.end());
  }
  if (rows.empty()) throw Error("no rows in the given CSV files");
  std::string run = options.run_id;
  // Rows are appended as cells finish, so the last row belongs to the latest run.
  if (run.empty()) run = rows.back().at("run_id");
  std::erase_if(rows, [&](const CsvRow& r) { return r.at("run_id") != run; });
  if (rows.empty()) throw Error("no rows with run_id '" + run + "'");
  // Results of `sahbench stress` have tables of their own (harness/stress_report.h).
  if (is_stress_result(rows)) return print_stress_report(rows, out);

  const CsvRow& first = rows.front();
  fmt::print(out, "# sahbench report: run {}\n\ncommit {}, {}, {}, {}; build reps {}, trace reps {}; config {}\n\n", run,
             first.at("git_commit"), first.at("cpu"), first.at("compiler"), first.at("embree_version"),
             first.at("build_reps"), first.at("trace_reps"), first.at("config"));

  // Group by (scene, threads); keep first-seen order.
  std::vector<std::pair<std::string, std::string>> groups;
  for (const auto& r : rows) {
    const auto g = std::make_pair(r.at("scene"), r.at("threads"));
    if (std::find(groups.begin(), groups.end(), g) == groups.end()) groups.push_back(g);
  }
  for (const auto& [scene, threads] : groups) {
    std::vector<const CsvRow*> group;
    std::vector<std::string> ray_sets;
    for (const auto& r : rows)
      if (r.at("scene") == scene && r.at("threads") == threads) {
        group.push_back(&r);
        if (std::find(ray_sets.begin(), ray_sets.end(), r.at("ray_set")) == ray_sets.end()) ray_sets.push_back(r.at("ray_set"));
      }
    // The anchor: Embree medium, one ray at a time, per ray set.
    std::map<std::string, const CsvRow*> anchor;
    for (const CsvRow* r : group)
      if (is_anchor(*r)) anchor[r->at("ray_set")] = r;
    const CsvRow* any_anchor = anchor.empty() ? nullptr : anchor.begin()->second;

    fmt::print(out, "## {} ({} triangles), {} thread{}\n\n", scene, group.front()->at("scene_triangles"), threads,
               threads == "1" ? "" : "s");
    fmt::print(out, "| builder | layout | build ms | memory MiB | SAH |");
    for (const auto& rs : ray_sets) fmt::print(out, " {} Mrays/s |", rs);
    fmt::print(out, "\n|---|---|---:|---:|---:|");
    for (std::size_t i = 0; i < ray_sets.size(); ++i) fmt::print(out, "---:|");
    fmt::print(out, "\n");

    // One table row per (builder, params, layout), with one trace column per ray set.
    std::vector<std::pair<std::string, std::string>> keys;
    for (const CsvRow* r : group) {
      const auto k = std::make_pair(row_label(*r), r->at("layout"));
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
    }
    auto anchor_value = [&](const std::string& column, const std::string& ray_set = "") -> std::optional<double> {
      const CsvRow* a = ray_set.empty() ? any_anchor : (anchor.count(ray_set) ? anchor[ray_set] : nullptr);
      return a ? csv_number(*a, column) : std::nullopt;
    };
    for (const auto& [label, layout] : keys) {
      std::map<std::string, const CsvRow*> by_set;
      for (const CsvRow* r : group)
        if (row_label(*r) == label && r->at("layout") == layout) by_set[r->at("ray_set")] = r;
      const CsvRow& any = *by_set.begin()->second;
      const auto mem = csv_number(any, "mem_bytes");
      const auto anchor_mem = anchor_value("mem_bytes");
      fmt::print(out, "| {} | {} | {} | {} | {} |", label, layout,
                 with_ratio(csv_number(any, "build_ms_median"), anchor_value("build_ms_median"), "{:.1f}"),
                 with_ratio(mem ? std::optional<double>(*mem / (1 << 20)) : std::nullopt,
                            anchor_mem ? std::optional<double>(*anchor_mem / (1 << 20)) : std::nullopt, "{:.1f}"),
                 csv_number(any, "sah_cost") ? fmt::format("{:.2f}", *csv_number(any, "sah_cost")) : "-");
      for (const auto& rs : ray_sets) {
        const auto it = by_set.find(rs);
        fmt::print(out, " {} |", it == by_set.end() ? "-" : with_ratio(csv_number(*it->second, "trace_mrays_median"), anchor_value("trace_mrays_median", rs), "{:.2f}"));
      }
      fmt::print(out, "\n");
    }
    fmt::print(out, "\n");
  }
  fmt::print(out, "Ratios are to embree [quality=medium] with rtcIntersect1/rtcOccluded1 in the same run; build ms and\n"
                  "Mrays/s are medians over the repetitions. Memory is the traversed structure's exact bytes.\n");
}

}  // namespace sahbench
