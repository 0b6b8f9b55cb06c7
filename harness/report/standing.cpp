#include "harness/report/standing.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>
#include <utility>

namespace sahbench {
namespace {

// What a row's ratios are to: its table's anchor for it (report.cpp's make_table).
std::string anchor_text(const ReportRow& row) {
  if (row.against_packets) return row.marked ? "Embree robust's packets" : "Embree's packets";
  return row.marked ? "Embree robust 1-ray" : "Embree 1-ray";
}

}  // namespace

ReportTable standing_table(const std::vector<ReportTable>& tables, const std::string& run,
                           const std::map<std::string, std::string>& labels) {
  struct Tally {
    const ReportRow* first;  // the row it was first seen as
    int cells = 0, ahead = 0, at_target = 0, noise = 0, behind = 0, bare = 0, mismatched = 0;
    double lowest = std::numeric_limits<double>::infinity(), highest = -lowest;
  };
  // Keyed by label, layout and anchor: a row compared with another anchor in some table (a scene whose
  // run lacks Embree's robust or packet rows) is counted apart.
  using Key = std::tuple<std::string, std::string, bool, bool>;
  std::vector<std::pair<Key, Tally>> tallies;
  std::size_t counted_tables = 0;
  for (const ReportTable& table : tables) {
    bool counted = false;
    for (const ReportRow& row : table.rows) {
      if (row.layout.starts_with("embree_")) continue;
      for (std::size_t c = 0; c < table.columns.size() && c < row.cells.size(); ++c) {
        // The rays/s columns are the ones where more is better.
        const auto& ratio = row.cells[c].interval;
        if (!table.columns[c].larger_is_better || !ratio) continue;
        const Key key{row.builder, row.layout, row.marked, row.against_packets};
        auto it = std::find_if(tallies.begin(), tallies.end(), [&](const auto& t) { return t.first == key; });
        if (it == tallies.end()) it = tallies.insert(tallies.end(), {key, Tally{&row}});
        Tally& t = it->second;
        counted = true;
        ++t.cells;
        // A rays/s cell's note is its count of mismatches (report.cpp): a speed that may not be the same
        // work.
        if (!row.cells[c].note.empty()) ++t.mismatched;
        t.lowest = std::min(t.lowest, ratio->estimate);
        t.highest = std::max(t.highest, ratio->estimate);
        // Judged as printed: "1.10 [1.02, 1.19]" is at 1.1.
        const double printed = std::round(ratio->estimate * 100.0) / 100.0;
        if (!ratio->has_interval()) {
          ++t.bare;
        } else if (*ratio->lo > 1.0) {
          ++t.ahead;
          if (printed >= kStandingTarget - 1e-9) ++t.at_target;
        } else if (*ratio->hi < 1.0) {
          ++t.behind;
        } else {
          ++t.noise;
        }
      }
    }
    counted_tables += counted;
  }

  ReportTable out;
  out.title = "Standing against Embree";
  out.label = "tab:standing";
  out.caption =
      fmt::format("Rays/s cells of each row against its Embree anchor, over the {} tables of run {}.",
                  counted_tables, run);
  const bool any_bare =
      std::any_of(tallies.begin(), tallies.end(), [](const auto& t) { return t.second.bare; });
  out.columns = {{"cells", "Cells", 0, false, "cells"},
                 {"ahead", "Ahead", 0, false, "ahead"},
                 {fmt::format("at {:.1f}", kStandingTarget), fmt::format("At {:.1f}", kStandingTarget), 0,
                  false, "at_target"},
                 {"within noise", "Within\nnoise", 0, false, "noise"},
                 {"behind", "Behind", 0, false, "behind"}};
  if (any_bare) out.columns.push_back({"no interval", "No\ninterval", 0, false, "bare"});
  const bool any_mismatched =
      std::any_of(tallies.begin(), tallies.end(), [](const auto& t) { return t.second.mismatched; });
  if (any_mismatched) out.columns.push_back({"with mismatches", "With\nmismatches", 0, false, "mismatches"});
  out.columns.push_back({"lowest", "Lowest", 2, false, "lowest"});
  out.columns.push_back({"highest", "Highest", 2, false, "highest"});

  // A row's label is the run-wide short one; where two rows would still read alike (one row against two
  // anchors), each names its anchor.
  auto short_label = [&](const std::string& full) {
    const auto it = labels.find(full);
    return it == labels.end() ? full : it->second;
  };
  std::map<std::pair<std::string, std::string>, int> alike;
  for (const auto& [key, t] : tallies) ++alike[{std::get<0>(key), std::get<1>(key)}];
  bool any_marked = false, any_packets = false;
  for (const auto& [key, t] : tallies) {
    const auto& [full, layout, marked, packets] = key;
    any_marked |= marked;
    any_packets |= packets;
    std::string label = short_label(full);
    if (alike[{full, layout}] > 1) label += " (against " + anchor_text(*t.first) + ")";
    ReportRow row{full, label, layout, {}, marked, packets};
    for (const int count : {t.cells, t.ahead, t.at_target, t.noise, t.behind})
      row.cells.push_back({double(count), std::nullopt, false});
    if (any_bare) row.cells.push_back({double(t.bare), std::nullopt, false});
    if (any_mismatched) row.cells.push_back({double(t.mismatched), std::nullopt, false});
    row.cells.push_back({t.lowest, std::nullopt, false});
    row.cells.push_back({t.highest, std::nullopt, false});
    out.rows.push_back(std::move(row));
  }

  std::string against = "against the anchor of their table";
  if (any_marked && any_packets)
    against +=
        " (the rows marked \u2020 against Embree's robust mode, packet layouts against Embree's faster "
        "packet width)";
  else if (any_marked)
    against += " (the rows marked \u2020 against Embree's robust mode)";
  else if (any_packets)
    against += " (packet layouts against Embree's faster packet width)";
  out.legend.push_back(
      "Each row's cells are its rays/s ratios in the tables above, " + against +
      ". A cell is ahead where its 95% interval lies wholly above 1, behind where it lies wholly below, "
      "within noise otherwise; at " +
      fmt::format("{:.1f}", kStandingTarget) + ": ahead with a ratio of " +
      fmt::format("{:.1f}", kStandingTarget) + " or more as printed." +
      (any_bare ? " No interval: a ratio from one round or from medians, counted in no other verdict." : "") +
      (any_mismatched ? " With mismatches: cells (counted in their verdict too) where some rays answered "
                        "otherwise than the run's reference."
                      : "") +
      " Lowest and highest are the ratios themselves.");
  return out;
}

}  // namespace sahbench
