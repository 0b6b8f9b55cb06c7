#include "harness/report/report.h"

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <ostream>
#include <set>
#include <sstream>

#include "core/error.h"
#include "harness/report/compare.h"
#include "harness/report/html_report.h"
#include "harness/report/predictors.h"
#include "harness/report/ratio_stats.h"
#include "harness/report/report_table.h"
#include "harness/report/result_cells.h"
#include "harness/report/standing.h"
#include "harness/report/stress_report.h"
#include "harness/report/table_fit.h"
#include "harness/run/csv.h"

namespace sahbench {
namespace {

// A field that older or other CSVs may lack (frame, embree_version, ...): empty when absent.
std::string field(const CsvRow& row, const std::string& column, const std::string& fallback = "") {
  const auto it = row.find(column);
  return it == row.end() || it->second.empty() ? fallback : it->second;
}

// The columns without which a CSV is not one of sahbench's results.
const std::vector<std::string>& identity_columns() {
  static const std::vector<std::string> columns = {"run_id", "scene", "builder", "layout", "ray_set"};
  return columns;
}

// A row of the run reported, with where it is and its timing samples, parsed once (result_cells.h).
struct RowTimings {
  std::string where;  // "PATH:LINE"
  std::vector<double> build_ms, trace_mrays;
  std::vector<double> build_layout_ms;  // build + layout compile per round; Embree's are its builds
};
using Timings = std::map<const CsvRow*, RowTimings>;

std::string row_label(const CsvRow& row) {
  const std::string params = field(row, "builder_params");
  return field(row, "builder") + (params.empty() ? "" : " [" + params + "]");
}

// "k=v;k=v" as written in builder_params, in order. A tree source's value, "NAME(k=v;...)", is one value.
std::vector<std::pair<std::string, std::string>> split_params(const std::string& params) {
  std::vector<std::pair<std::string, std::string>> out;
  std::size_t start = 0;
  while (start < params.size()) {
    std::size_t end = start;
    for (int depth = 0; end < params.size() && (depth > 0 || params[end] != ';'); ++end)
      depth += params[end] == '(' ? 1 : params[end] == ')' ? -1 : 0;
    const std::string item = params.substr(start, end - start);
    const std::size_t eq = item.find('=');
    if (!item.empty())
      out.emplace_back(item.substr(0, eq), eq == std::string::npos ? "" : item.substr(eq + 1));
    start = end + 1;
  }
  return out;
}

/// Short labels for a paper: per builder, only the parameters whose values differ between that
/// builder's rows of the table (a parameter some rows lack, as Embree's robust=1, differs); the shared
/// ones are returned (per builder) for the caption.
std::map<std::string, std::string> short_labels(const std::vector<const CsvRow*>& rows,
                                                std::vector<std::string>& shared) {
  std::map<std::string, std::map<std::string, std::vector<std::string>>>
      values;  // builder -> key -> values seen
  std::map<std::string, std::vector<std::string>> key_order;
  std::map<std::string, std::map<std::string, std::size_t>> rows_with;  // builder -> key -> rows with it
  std::map<std::string, std::size_t> builder_rows;
  // builder -> K_hash -> value of K -> the hashes seen with it (a path and the hash of its file)
  std::map<std::string, std::map<std::string, std::map<std::string, std::set<std::string>>>> hashes;
  for (const CsvRow* r : rows) {
    const std::string builder = field(*r, "builder");
    ++builder_rows[builder];
    const auto params = split_params(field(*r, "builder_params"));
    for (const auto& [k, v] : params) {
      ++rows_with[builder][k];
      auto& seen = values[builder][k];
      if (std::find(seen.begin(), seen.end(), v) == seen.end()) seen.push_back(v);
      auto& order = key_order[builder];
      if (std::find(order.begin(), order.end(), k) == order.end()) order.push_back(k);
      if (!k.ends_with("_hash")) continue;
      const std::string named = k.substr(0, k.size() - 5);
      const auto it =
          std::find_if(params.begin(), params.end(), [&](const auto& p) { return p.first == named; });
      hashes[builder][k][it == params.end() ? std::string() : it->second].insert(v);
    }
  }
  auto common_to_all = [&](const std::string& builder, const std::string& k) {
    return values[builder][k].size() == 1 && rows_with[builder][k] == builder_rows[builder];
  };
  // A file's hash (path_hash beside path: the tree file builder's) adds nothing to a label that names
  // the file, and its 18 characters widened tables past the page. It is left out where the named value
  // varies and each of its values comes with one hash (the CSV records a file's name, not its folder:
  // two files of one name in two folders keep their hashes).
  auto redundant_hash = [&](const std::string& builder, const std::string& k) {
    if (!k.ends_with("_hash")) return false;
    const std::string named = k.substr(0, k.size() - 5);
    if (!rows_with[builder].contains(named) || common_to_all(builder, named)) return false;
    const auto& by_value = hashes[builder][k];
    return std::all_of(by_value.begin(), by_value.end(),
                       [](const auto& entry) { return entry.second.size() == 1; });
  };
  std::map<std::string, std::string> labels;  // full label -> short label
  for (const CsvRow* r : rows) {
    const std::string builder = field(*r, "builder");
    std::string varying;
    for (const auto& [k, v] : split_params(field(*r, "builder_params")))
      if (!common_to_all(builder, k) && !redundant_hash(builder, k))
        varying += (varying.empty() ? "" : ";") + k + "=" + v;
    labels[row_label(*r)] = builder + (varying.empty() ? "" : " [" + varying + "]");
  }
  for (const auto& [builder, order] : key_order) {
    std::string common;
    for (const auto& k : order)
      if (common_to_all(builder, k)) common += (common.empty() ? "" : ", ") + k + "=" + values[builder][k][0];
    if (!common.empty()) shared.push_back(builder + " " + common);
  }
  return labels;
}

// Letters and digits of `text`, anything else as '-': a key LaTeX accepts in \label and \ref.
std::string label_key(const std::string& text) {
  std::string out;
  for (const char c : text) out += std::isalnum(static_cast<unsigned char>(c)) ? c : '-';
  return out;
}

struct GroupKey {
  std::string scene, threads, frame;
  bool operator==(const GroupKey&) const = default;
  /// "proc:sphere at 2 threads", ", frame 3" after it where not 0.
  std::string text() const {
    return scene + " at " + threads + (threads == "1" ? " thread" : " threads") +
           (frame == "0" ? "" : ", frame " + frame);
  }
};

// A timing's ratio to the anchor: from the samples paired by round where both rows have them (ours in
// `samples`, the anchor's in `anchor_samples`, the same column unless given), else the ratio of medians
// (no interval).
std::optional<RatioInterval> timing_ratio(const Timings& timings, const CsvRow& ours, const CsvRow* anchor,
                                          std::optional<double> ours_median, const std::string& anchor_median,
                                          std::vector<double> RowTimings::*samples,
                                          std::vector<double> RowTimings::*anchor_samples = nullptr) {
  if (!anchor || !ours_median) return std::nullopt;
  const auto anchor_value = csv_number(*anchor, anchor_median);
  if (!anchor_value || !(*anchor_value > 0) || !(*ours_median > 0)) return std::nullopt;
  const RowTimings &t = timings.at(&ours), &a = timings.at(anchor);
  const std::vector<double>& theirs = a.*(anchor_samples ? anchor_samples : samples);
  if ((t.*samples).empty() || theirs.empty()) return ratio_of_medians(*ours_median, *anchor_value);
  try {
    return paired_ratio(t.*samples, theirs);
  } catch (const Error& e) {
    throw Error(t.where + " against its anchor " + a.where + ": " + e.what());
  }
}

// The instruction set each row's kernels ran with (the CSV's isa column; isa=auto resolved by
// traversal/kernel_variant.h's preferred_kernel_isa): "avx2" where every row ran one, else each ISA with
// its layouts, "scalar for bvh2, bvh2_packed; avx2 for bvh8; embree:avx2 for embree_1, embree_8".
std::string kernel_isas(const std::vector<const CsvRow*>& group) {
  std::vector<std::pair<std::string, std::vector<std::string>>> by_isa;  // in order of first appearance
  for (const CsvRow* row : group) {
    const std::string isa = field(*row, "isa"), layout = field(*row, "layout");
    if (isa.empty()) continue;
    auto it = std::find_if(by_isa.begin(), by_isa.end(), [&](const auto& e) { return e.first == isa; });
    if (it == by_isa.end()) it = by_isa.insert(by_isa.end(), {isa, {}});
    if (std::find(it->second.begin(), it->second.end(), layout) == it->second.end())
      it->second.push_back(layout);
  }
  if (by_isa.size() == 1) return by_isa.front().first;
  std::string out;
  for (const auto& [isa, layouts] : by_isa) {
    out += (out.empty() ? "" : "; ") + isa + " for ";
    for (std::size_t i = 0; i < layouts.size(); ++i) out += (i ? ", " : "") + layouts[i];
  }
  return out;
}

ReportTable make_table(const GroupKey& key, const std::vector<const CsvRow*>& group, const Timings& timings,
                       ReportFormat format) {
  std::vector<std::string> ray_sets;
  for (const CsvRow* r : group)
    if (std::find(ray_sets.begin(), ray_sets.end(), field(*r, "ray_set")) == ray_sets.end())
      ray_sets.push_back(field(*r, "ray_set"));
  // The anchors, per ray set: Embree medium, one ray at a time, in its default mode; and in its robust
  // mode where the run has it, for the rows of ours whose kernels are exact (like for like: both
  // watertight, neither trading exactness for speed).
  // Our packet rows are compared with Embree's packets, the faster width of the cell (by median).
  // Keyed by shard, then ray set: a merged sweep (harness/run/shard_merge.h) has each shard's own
  // anchors, and a row is compared only with those of its own shard (same process, same node); a whole
  // run has one shard, "".
  using Anchors = std::map<std::string, std::map<std::string, const CsvRow*>>;
  Anchors anchor, robust_anchor, packet_anchor, robust_packet_anchor;
  auto keep_faster = [](const CsvRow*& kept, const CsvRow* r) {
    if (!kept || csv_number(*r, "trace_mrays_median").value_or(0) >
                     csv_number(*kept, "trace_mrays_median").value_or(0))
      kept = r;
  };
  for (const CsvRow* r : group) {
    const std::string shard = field(*r, "shard"), rs = field(*r, "ray_set");
    if (is_anchor(*r)) anchor[shard][rs] = r;
    if (is_robust_anchor(*r)) robust_anchor[shard][rs] = r;
    if (is_packet_anchor(*r, false)) keep_faster(packet_anchor[shard][rs], r);
    if (is_packet_anchor(*r, true)) keep_faster(robust_packet_anchor[shard][rs], r);
  }
  auto compared_robust = [&](const CsvRow& r) {
    return !robust_anchor.empty() && runs_exact_kernels(field(r, "builder"), field(r, "layout"));
  };
  const bool any_marked =
      std::any_of(group.begin(), group.end(), [&](const CsvRow* r) { return compared_robust(*r); });
  auto compared_to_packets = [&](const CsvRow& r) {
    return runs_packets(field(r, "builder"), field(r, "layout")) &&
           !(compared_robust(r) ? robust_packet_anchor : packet_anchor).empty();
  };
  const bool any_packets =
      std::any_of(group.begin(), group.end(), [&](const CsvRow* r) { return compared_to_packets(*r); });

  ReportTable table;
  const CsvRow& first = *group.front();
  const std::string threads_text = key.threads + (key.threads == "1" ? " thread" : " threads");
  const std::string frame_text = key.frame == "0" ? "" : ", frame " + key.frame;
  table.title = fmt::format("{} ({} triangles), {}{}", key.scene, field(first, "scene_triangles", "?"),
                            threads_text, frame_text);
  table.label =
      "tab:" + label_key(key.scene) + "-t" + key.threads + (key.frame == "0" ? "" : "-f" + key.frame);
  table.columns = {{"build ms", "Build\n(ms)", 1, false, "build"},
                   {"build+layout ms", "Build +\nlayout (ms)", 1, false, "build_layout"},
                   {"memory MiB", "Memory\n(MiB)", 1, false, "memory"},
                   {"SAH", "SAH\ncost", 2, false, "sah"}};
  for (const auto& rs : ray_sets)
    table.columns.push_back({rs + " Mrays/s", latex_escape(rs) + "\n(Mrays/s)", 2, true, rs});

  std::vector<std::string> shared;
  const auto short_label = short_labels(group, shared);
  // The compile target of the run; each row's kernel ISA is in the CSV's isa column (the kernel-ISA note
  // below lists them).
  std::string isa = field(first, "build_isa");
  if (isa.empty()) isa = field(first, "isa");
  const std::string kernels = kernel_isas(group);
  const bool latex = format == ReportFormat::kLatex;
  // The caption names the table and the machine (three lines at most in a two-column paper); how to read
  // the table and what its rows share go in the legend under it.
  table.caption =
      fmt::format("{}; {}{}, commit {}.", table.title, field(first, "cpu", "unknown CPU"),
                  isa.empty() ? "" : " (built for " + isa + ")", field(first, "git_commit", "unknown"));
  table.legend.push_back(fmt::format("Medians of {} builds and {} traces; kernels: {}.",
                                     field(first, "build_reps", "?"), field(first, "trace_reps", "?"),
                                     kernels.empty() ? "unknown" : kernels));
  const std::string where_ratios = latex ? "Under each value" : "In parentheses";
  const std::string interval_form =
      latex ? "its 95% interval as offsets in super- and subscript" : "its 95% interval";
  table.legend.push_back(
      any_marked
          ? where_ratios +
                ": ratio to Embree (quality=medium, rtcIntersect1/rtcOccluded1) in the same run, like for "
                "like: rows marked \u2020 (our exact kernels: watertight triangle test, robust box test) to "
                "Embree's robust mode (RTC_SCENE_FLAG_ROBUST, with its watertight triangle test), the others "
                "(faster variants, and Embree's own rows) to its default mode;"
          : where_ratios + ": ratio to Embree (quality=medium, rtcIntersect1/rtcOccluded1) in the same run;");
  if (any_packets)
    table.legend.push_back(
        "our packet layouts (packet=8, 16) against Embree's packets instead (rtcIntersect8/16, "
        "rtcOccluded8/16, "
        "whichever width is faster in the cell), in the same mode;");
  table.legend.push_back(
      "for build + layout and rays/s the geometric mean of the ratios of rounds paired with Embree's, with " +
      interval_form +
      ", and an up (down) arrow where the interval lies wholly on the better (worse) side of 1. Best of each "
      "column in bold: least build time, memory and SAH cost, most rays/s.");
  // The rows name only the parameters that vary between a builder's rows; the rest are named here.
  if (!shared.empty()) {
    std::string text = "Parameters common to a builder's rows:";
    for (std::size_t i = 0; i < shared.size(); ++i) text += (i ? "; " : " ") + shared[i];
    table.legend.push_back(text + ".");
  }

  // SAH costs are comparable only under one cost model: the table's usual constants are those of most of
  // its rows with a cost, and a cost under others carries them as a note (and is not marked best). A
  // collapse with c_trav = 2 reports a larger SAH for a tree that traces faster than c_trav = 1's.
  const std::vector<std::pair<std::string, std::string>> model_fields = {
      {"sah_c_trav", "c_trav"}, {"sah_c_isect", "c_isect"}, {"sah_block", "block"}};
  auto model_of = [&](const CsvRow& r) {
    std::vector<std::string> values;
    for (const auto& [column, name] : model_fields) values.push_back(field(r, column));
    return values;
  };
  // Models in order of first appearance, so that a tie goes to the one of the earlier rows.
  std::vector<std::pair<std::vector<std::string>, int>> model_rows;
  for (const CsvRow* r : group) {
    if (!csv_number(*r, "sah_cost")) continue;
    const auto model = model_of(*r);
    auto it =
        std::find_if(model_rows.begin(), model_rows.end(), [&](const auto& m) { return m.first == model; });
    if (it == model_rows.end())
      model_rows.push_back({model, 1});
    else
      ++it->second;
  }
  std::vector<std::string> usual_model;
  int usual_rows = 0;
  for (const auto& [model, rows] : model_rows)
    if (rows > usual_rows) usual_model = model, usual_rows = rows;
  // "c_trav=2, block=4": the constants of `model` that differ from `other` (all of them without one).
  auto describe = [&](const std::vector<std::string>& model, const std::vector<std::string>* other) {
    std::string text;
    for (std::size_t i = 0; i < model.size(); ++i)
      if (!other || model[i] != (*other)[i])
        text +=
            (text.empty() ? "" : ", ") + model_fields[i].second + "=" + (model[i].empty() ? "?" : model[i]);
    return text;
  };
  auto model_note = [&](const CsvRow& r) { return describe(model_of(r), &usual_model); };
  if (model_rows.size() > 1) {
    const std::string usual = describe(usual_model, nullptr);
    table.legend.push_back(
        "SAH costs are in each builder's own constants; those in brackets differ from the table's usual " +
        usual + ", and are not compared.");
  }

  // The share of rays that hit weighs on rays/s (a miss ends early), so a ratio is read beside it. It is
  // the rays' answer, the same for every correct tree: the anchor's, else the first row's with one.
  std::string hits;
  for (const auto& rs : ray_sets) {
    const CsvRow* source = nullptr;
    for (const auto& [shard, by_set] : anchor)
      if (!source && by_set.count(rs)) source = by_set.at(rs);
    if (!source || field(*source, "hit_fraction").empty())
      for (const CsvRow* r : group)
        if (field(*r, "ray_set") == rs && !field(*r, "hit_fraction").empty()) {
          source = r;
          break;
        }
    if (source && !field(*source, "hit_fraction").empty())
      hits += (hits.empty() ? "" : ", ") + rs + " " + field(*source, "hit_fraction");
  }
  if (!hits.empty())
    table.legend.push_back("Share of rays that hit (closest) or are occluded (any hit): " + hits + ".");

  // One table row per (builder, params, layout), with one trace column per ray set.
  std::vector<std::pair<std::string, std::string>> keys;
  for (const CsvRow* r : group) {
    const auto k = std::make_pair(row_label(*r), field(*r, "layout"));
    if (std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
  }
  auto cell = [](std::optional<double> value, std::optional<double> anchor_value) {
    ReportCell c{value, std::nullopt, false};
    if (value && anchor_value && *anchor_value > 0) c.ratio = *value / *anchor_value;
    return c;
  };
  auto timing_cell = [](std::optional<double> value, std::optional<RatioInterval> ratio) {
    ReportCell c{value, std::nullopt, false};
    c.interval = ratio;
    return c;
  };
  auto anchor_number = [&](const CsvRow* a, const std::string& column) {
    return a ? csv_number(*a, column) : std::nullopt;
  };
  constexpr double kMiB = 1 << 20;
  auto mib = [&](std::optional<double> bytes) {
    return bytes ? std::optional<double>(*bytes / kMiB) : std::nullopt;
  };
  bool any_mismatch = false;
  std::set<std::string> unanchored;  // the anchors rows were to be compared with and the run lacks
  for (const auto& [label, layout] : keys) {
    std::map<std::string, const CsvRow*> by_set;
    for (const CsvRow* r : group)
      if (row_label(*r) == label && field(*r, "layout") == layout) by_set[field(*r, "ray_set")] = r;
    const CsvRow& any = *by_set.begin()->second;
    ReportRow row{label, short_label.at(label), layout, {}};
    row.marked = compared_robust(any);
    row.against_packets = compared_to_packets(any);
    const Anchors& anchors_by_shard = compared_to_packets(any)
                                          ? (row.marked ? robust_packet_anchor : packet_anchor)
                                      : row.marked ? robust_anchor
                                                   : anchor;
    static const std::map<std::string, const CsvRow*> kNone;
    const auto shard_anchors = anchors_by_shard.find(field(any, "shard"));
    const auto& anchors_of_row = shard_anchors == anchors_by_shard.end() ? kNone : shard_anchors->second;
    const CsvRow* any_anchor = anchors_of_row.empty() ? nullptr : anchors_of_row.begin()->second;
    if (anchors_of_row.empty())
      unanchored.insert(row.against_packets ? (row.marked ? "Embree's packets in its robust mode"
                                                          : "Embree's packets in its default mode")
                        : row.marked        ? "Embree 1-ray in its robust mode"
                                            : "Embree medium 1-ray in its default mode");
    row.cells.push_back(cell(csv_number(any, "build_ms_median"), std::nullopt));
    // Build plus layout compile against Embree's build, whose rtcCommitScene does both: round r's sum
    // (build_layout_ms_samples) against Embree's build r.
    const auto build_layout = csv_number(any, "build_layout_ms_median");
    row.cells.push_back(
        timing_cell(build_layout, timing_ratio(timings, any, any_anchor, build_layout, "build_ms_median",
                                               &RowTimings::build_layout_ms, &RowTimings::build_ms)));
    row.cells.push_back(cell(mib(csv_number(any, "mem_bytes")), mib(anchor_number(any_anchor, "mem_bytes"))));
    row.cells.push_back(cell(csv_number(any, "sah_cost"), anchor_number(any_anchor, "sah_cost")));
    if (row.cells.back().value) row.cells.back().note = model_note(any);
    for (const auto& rs : ray_sets) {
      const auto it = by_set.find(rs);
      const auto a = anchors_of_row.find(rs);
      if (it == by_set.end()) {
        row.cells.push_back(ReportCell{});
        continue;
      }
      const auto mrays = csv_number(*it->second, "trace_mrays_median");
      row.cells.push_back(timing_cell(
          mrays, timing_ratio(timings, *it->second, a == anchors_of_row.end() ? nullptr : a->second, mrays,
                              "trace_mrays_median", &RowTimings::trace_mrays)));
      // A speed whose answers differ from the reference's may not be the same work: said in the cell,
      // and (a cell with a note) never marked best.
      if (const auto count = csv_number(*it->second, "mismatches"); count && *count > 0) {
        row.cells.back().note = fmt::format("{:.0f} {}", *count, *count == 1 ? "mismatch" : "mismatches");
        any_mismatch = true;
      }
    }
    table.rows.push_back(std::move(row));
  }
  if (!unanchored.empty())
    table.legend.push_back(fmt::format(
        "Rows without ratios: this run has no {} to compare them with (a row is compared only with Embree "
        "in the mode of its kernels).",
        fmt::join(unanchored, ", nor ")));
  if (any_mismatch)
    table.legend.push_back(
        "[N mismatches]: N rays of the set answered otherwise than the run's reference (the CSV's reference "
        "and mismatches columns: brute force, or above brute_force_max_triangles Embree's robust mode with "
        "each disagreement settled exactly; another hit, distance or occlusion); such a cell is not marked "
        "best.");
  mark_best(table);
  return table;
}

// A row of a result file, and where it is.
struct Located {
  const ResultFile* file;
  std::size_t index;
  const CsvRow& row() const { return file->rows[index]; }
  std::string where() const { return file->where(index); }
};

// The rows of the run, checked as `sahbench compare` checks them before a table prints them as results:
// our rows' deterministic metrics are finite numbers where given, no cell is there twice (a merged sweep
// keeps Embree's rows once per shard), no time is negative and no rate of rays below or at zero. A column a
// CSV from another writer lacks prints as "-".
void check_run_rows(const std::vector<Located>& located) {
  std::map<std::string, std::string> seen;  // cell -> where
  for (const Located& l : located) {
    const ResultFile& f = *l.file;
    std::string key;
    for (const char* column : {"scene", "builder", "builder_params", "layout", "threads", "ray_set", "frame"})
      key += (key.empty() ? "" : ", ") + f.field(l.index, column);
    if (!f.field(l.index, "shard").empty()) key += " @shard " + f.field(l.index, "shard");
    const auto [it, added] = seen.emplace(key, l.where());
    if (!added)
      throw Error(fmt::format("{} and {} are the same cell ({}): a run has each cell once", it->second,
                              l.where(), key));
    if (f.field(l.index, "builder") != "embree")
      for (const MetricRule& rule : deterministic_metrics())
        if (f.has_column(rule.column)) checked_number(f, l.index, rule.column);
    // A time may round to 0.0000 ms (a refit of a tiny scene); a rate of rays may not.
    for (const char* column : {"build_ms_median", "build_layout_ms_median"})
      if (const auto v = checked_number(f, l.index, column); v && *v < 0)
        throw row_error(f, l.index, column, fmt::format("{} is a negative time", *v));
    if (const auto v = checked_number(f, l.index, "trace_mrays_median"); v && !(*v > 0))
      throw row_error(f, l.index, "trace_mrays_median", fmt::format("{} is not a positive rate", *v));
  }
}

GroupKey group_of(const CsvRow& r) {
  return GroupKey{field(r, "scene"), field(r, "threads"), field(r, "frame", "0")};
}

// A cell of a table, as a reader names it: builder and parameters, layout, ray set.
std::string cell_label(const CsvRow& r) {
  return row_label(r) + " " + field(r, "layout") + " " + field(r, "ray_set");
}

// Run id -> group (GroupKey::text) -> cell labels, of the runs other than `run` with its fingerprint, in
// the files' order of runs.
using OtherRuns = std::vector<std::pair<std::string, std::map<std::string, std::set<std::string>>>>;

OtherRuns cells_of_other_runs(const std::vector<Located>& all, const std::string& run,
                              const std::string& fingerprint) {
  OtherRuns out;
  if (fingerprint.empty()) return out;  // older CSVs: no fingerprint tells which runs are alike
  for (const Located& l : all) {
    const CsvRow& r = l.row();
    if (field(r, "run_id") == run || field(r, "run_fingerprint") != fingerprint) continue;
    auto it =
        std::find_if(out.begin(), out.end(), [&](const auto& o) { return o.first == field(r, "run_id"); });
    if (it == out.end()) it = out.insert(out.end(), {field(r, "run_id"), {}});
    it->second[group_of(r).text()].insert(cell_label(r));
  }
  return out;
}

// Report drops no cell silently: where another run of the same config and build had more cells in this
// group (this one stopped early, or ran with --only), the note says how many and which are missing.
std::vector<std::string> missing_cell_notes(const GroupKey& key, const std::vector<const CsvRow*>& group,
                                            const OtherRuns& others) {
  constexpr std::size_t kNamed = 5;  // missing cells named in full; the rest are counted
  std::set<std::string> here;
  for (const CsvRow* r : group) here.insert(cell_label(*r));
  std::vector<std::string> notes;
  for (const auto& [other_run, by_group] : others) {
    const auto it = by_group.find(key.text());
    if (it == by_group.end()) continue;
    std::vector<std::string> missing;
    for (const auto& c : it->second)
      if (!here.count(c)) missing.push_back(c);
    if (missing.empty()) continue;
    std::string names;
    for (std::size_t i = 0; i < std::min(missing.size(), kNamed); ++i) names += (i ? "; " : "") + missing[i];
    if (missing.size() > kNamed) names += fmt::format("; and {} more", missing.size() - kNamed);
    notes.push_back(fmt::format("this run has {} cells here, run {} of the same fingerprint had {}{}{}.",
                                here.size(), other_run, it->second.size(),
                                missing.empty() ? "" : "; missing: ", names));
  }
  return notes;
}

// The notes (the CSV's `notes`, "; "-separated) that hold for a whole column or table, once each: those
// every row of the table carries (the configured view), then those every row of one ray set carries (a
// shadow set's lights enclosed by the scene: ray_sets.h, enclosed), so that the figures they qualify are
// not read without them.
std::vector<std::string> row_notes(const std::vector<const CsvRow*>& group) {
  auto notes_of = [](const CsvRow& r) {
    std::set<std::string> out;
    const std::string all = field(r, "notes");
    for (std::size_t begin = 0; begin < all.size();) {
      const std::size_t end = std::min(all.find("; ", begin), all.size());
      out.insert(all.substr(begin, end - begin));
      begin = end + 2;
    }
    return out;
  };
  std::vector<std::string> sets;
  std::map<std::string, std::set<std::string>> shared;  // ray set -> notes all its rows carry
  std::set<std::string> everywhere;
  bool first = true;
  for (const CsvRow* r : group) {
    const std::string set = field(*r, "ray_set");
    const std::set<std::string> here = notes_of(*r);
    auto intersect = [&](std::set<std::string>& into) {
      std::erase_if(into, [&](const std::string& n) { return !here.count(n); });
    };
    if (const auto it = shared.find(set); it == shared.end()) {
      sets.push_back(set);
      shared[set] = here;
    } else {
      intersect(it->second);
    }
    if (first)
      everywhere = here, first = false;
    else
      intersect(everywhere);
  }
  std::vector<std::string> out;
  for (const std::string& note : everywhere) out.push_back(fmt::format("every row: {}.", note));
  for (const std::string& set : sets)
    for (const std::string& note : shared[set])
      if (!everywhere.count(note)) out.push_back(fmt::format("ray set '{}': {}.", set, note));
  return out;
}

}  // namespace

ReportFormat parse_report_format(std::string_view name) {
  if (name == "markdown" || name == "md") return ReportFormat::kMarkdown;
  if (name == "latex" || name == "tex") return ReportFormat::kLatex;
  if (name == "html") return ReportFormat::kHtml;
  throw Error("unknown report format '" + std::string(name) + "' (known: markdown, latex, html)");
}

void print_report(const ReportOptions& options, std::ostream& out) {
  std::vector<ResultFile> files;
  for (const auto& path : options.inputs) {
    files.push_back(read_result_file(path));
    for (const auto& column : identity_columns())
      if (!files.back().rows.empty() && !files.back().has_column(column))
        throw Error(path.string() + ":1: not a sahbench result CSV: the header has no column '" + column +
                    "'");
  }
  std::vector<std::string> cut_notes;
  for (const auto& f : files)
    if (f.cut_last_line)
      cut_notes.push_back(
          f.path.string() +
          ": its last line is incomplete (a run stopped while writing it); that row is left out");
  std::vector<Located> all;
  for (const auto& f : files)
    for (std::size_t i = 0; i < f.rows.size(); ++i) all.push_back({&f, i});
  if (all.empty()) throw Error("no rows in the given CSV files");
  std::string run = options.run_id;
  // Rows are appended as cells finish, so the last row belongs to the latest run.
  if (run.empty()) {
    run = field(all.back().row(), "run_id");
    // Files of several runs given together: the others are not in the tables, which the report says.
    std::vector<std::string> others;
    for (const Located& l : all)
      if (const std::string& id = field(l.row(), "run_id");
          id != run && std::find(others.begin(), others.end(), id) == others.end())
        others.push_back(id);
    if (!others.empty() && files.size() > 1)
      cut_notes.push_back(
          fmt::format("this report is of run {} (the last row of {}); the files hold {} other "
                      "runs, left out ({}): name one with --run",
                      run, files.back().path.string(), others.size(), fmt::join(others, ", ")));
  }
  std::vector<Located> located;
  std::copy_if(all.begin(), all.end(), std::back_inserter(located),
               [&](const Located& l) { return field(l.row(), "run_id") == run; });
  if (located.empty()) throw Error("no rows with run_id '" + run + "'");
  // One run has one fingerprint; two under one run id are two runs' rows mixed (CSVs from older versions
  // have none, which is one value too).
  const std::string fingerprint = field(located.front().row(), "run_fingerprint");
  for (const Located& l : located)
    if (field(l.row(), "run_fingerprint") != fingerprint)
      throw Error(
          fmt::format("run '{}' has rows of two fingerprints: {} has run_fingerprint '{}', {} has '{}'", run,
                      located.front().where(), fingerprint, l.where(), field(l.row(), "run_fingerprint")));
  // Results of `sahbench stress` have tables of their own (harness/report/stress_report.h).
  {
    std::vector<CsvRow> copies;
    for (const Located& l : located) copies.push_back(l.row());
    if (is_stress_result(copies)) return print_stress_report(copies, options.format, out, options.width);
  }
  check_run_rows(located);
  std::vector<const CsvRow*> rows;
  Timings timings;
  for (const Located& l : located) {
    rows.push_back(&l.row());
    timings[&l.row()] = {l.where(), timing_samples(*l.file, l.index, "build_ms"),
                         timing_samples(*l.file, l.index, "trace_mrays"),
                         timing_samples(*l.file, l.index, "build_layout_ms")};
  }

  const CsvRow& first = *rows.front();
  const bool latex = options.format == ReportFormat::kLatex;
  const bool html = options.format == ReportFormat::kHtml;
  if (html)
    html_begin(fmt::format("sahbench report: run {}", run),
               fmt::format("commit {}, {}, {}, {}; build reps {}, trace reps {}; config {}, seed {}; "
                           "fingerprint {}",
                           field(first, "git_commit"), field(first, "cpu"), field(first, "compiler"),
                           field(first, "embree_version"), field(first, "build_reps"),
                           field(first, "trace_reps"), field(first, "config"), field(first, "seed", "?"),
                           fingerprint.empty() ? "?" : fingerprint),
               out);
  else if (latex)
    fmt::print(
        out,
        "% sahbench report: run {}, commit {}, {}, {}, {}; config {}, seed {}; fingerprint {}\n% Needs "
        "\\usepackage{{booktabs}} (\\textuparrow and \\textdownarrow are textcomp's, in the LaTeX kernel "
        "since 2020).\n\n",
        run, field(first, "git_commit"), field(first, "cpu"), field(first, "compiler"),
        field(first, "embree_version"), field(first, "config"), field(first, "seed", "?"),
        fingerprint.empty() ? "?" : fingerprint);
  else
    fmt::print(
        out,
        "# sahbench report: run {}\n\ncommit {}, {}, {}, {}; build reps {}, trace reps {}; config {}, seed "
        "{}; fingerprint {}\n\n",
        run, field(first, "git_commit"), field(first, "cpu"), field(first, "compiler"),
        field(first, "embree_version"), field(first, "build_reps"), field(first, "trace_reps"),
        field(first, "config"), field(first, "seed", "?"), fingerprint.empty() ? "?" : fingerprint);
  for (const std::string& note : cut_notes) {
    if (html)
      html_paragraph("Note: " + note + ".", out);
    else
      fmt::print(out, "{}Note: {}.\n\n", latex ? "% " : "", note);
  }

  // Group by (scene, threads, frame); keep first-seen order.
  std::vector<GroupKey> groups;
  for (const CsvRow* r : rows)
    if (std::find(groups.begin(), groups.end(), group_of(*r)) == groups.end()) groups.push_back(group_of(*r));
  const auto others = cells_of_other_runs(all, run, fingerprint);
  bool any_marked = false;
  auto render = [&](const ReportTable& table) {
    if (html)
      render_html(table, out);
    else if (latex)
      for (const ReportTable& part : split_to_width(table, options.width)) {
        fmt::print(out, "% {}: estimated {:.0f} pt wide, text width {:.1f} pt\n", part.label,
                   estimated_latex_width(part, options.width), page_width_pt(options.width));
        render_latex(part, out, options.width);
      }
    else
      render_markdown(table, out);
  };
  std::vector<ReportTable> tables;
  for (const auto& key : groups) {
    std::vector<const CsvRow*> group;
    for (const CsvRow* r : rows)
      if (group_of(*r) == key) group.push_back(r);
    ReportTable table = select_columns(make_table(key, group, timings, options.format), options.columns);
    table.notes = missing_cell_notes(key, group, others);
    for (std::string& note : row_notes(group)) table.notes.push_back(std::move(note));
    for (const ReportRow& row : table.rows) any_marked |= row.marked;
    render(table);
    render_predictors(key.text(), predictor_rows(group), options.format, out);
    tables.push_back(std::move(table));
  }
  // Over two or more tables, each row's standing against Embree in all of them.
  if (tables.size() > 1) {
    std::vector<std::string> shared;
    const ReportTable standing = standing_table(tables, run, short_labels(rows, shared));
    if (!standing.rows.empty()) render(standing);
  }
  // Groups another run of the same fingerprint had and this one lacks altogether have no table to note.
  std::vector<std::string> lost;
  for (const auto& [other_run, by_group] : others)
    for (const auto& [group_text, cells] : by_group) {
      const std::string& text = group_text;  // clang 14 cannot capture a structured binding
      if (std::none_of(groups.begin(), groups.end(), [&](const GroupKey& g) { return g.text() == text; }))
        lost.push_back(fmt::format("{} ({} cells in run {})", group_text, cells.size(), other_run));
    }
  if (!lost.empty()) {
    std::string text = "Run " + run + " has no cells of";
    for (std::size_t i = 0; i < lost.size(); ++i) text += (i ? "; " : " ") + lost[i];
    text += ", which another run of the same fingerprint has.";
    if (html)
      html_paragraph("Note: " + text, out);
    else
      fmt::print(out, "{}Note: {}\n\n", latex ? "% " : "", text);
  }
  if (html) {
    html_figures(options.figures, out);
    return html_end(out);
  }
  if (!latex)
    fmt::print(out,
               "Ratios are to embree [quality=medium] with rtcIntersect1/rtcOccluded1 in the same run; build "
               "ms and\n"
               "Mrays/s are medians over the repetitions. Memory is the traversed structure's exact bytes. "
               "The best\n"
               "value of each column is in bold. Build + layout and Mrays/s ratios are the geometric mean of "
               "the ratios\n"
               "of rounds paired with Embree's (run in one shuffled order per round), with a 95% interval "
               "(Student's t\n"
               "on their logs): \u25B2 ahead of Embree (the interval wholly on the better side of 1: more "
               "rays/s, less\n"
               "time), \u25BC behind, no mark within noise; [n=1] is one round, with no interval; [medians] "
               "is the\n"
               "ratio of the medians, from rows without samples (older CSVs). Build + layout is our build "
               "plus the\n"
               "layout compile, against Embree's rtcCommitScene, which does both. Memory and SAH ratios are "
               "exact.\n");
  if (!latex && any_marked)
    fmt::print(out,
               "Like for like: where the run has Embree's robust mode (embree [quality=medium;robust=1], "
               "which\n"
               "also selects its watertight triangle test), the rows marked \u2020 (our exact kernels: "
               "watertight triangle\n"
               "test and robust box test, the layouts' defaults) have their ratios to its embree_1 "
               "instead; faster\n"
               "variants (tri=mt, mt0, mtn or box=fast, fma) and Embree's own rows keep its default mode.\n");
}

void run_report_command(const ReportOptions& options, std::ostream& out) {
  // Writing the report over a result CSV would lose its rows.
  for (const auto& input : options.inputs)
    if (!options.output.empty() && std::filesystem::exists(options.output) &&
        std::filesystem::exists(input) && std::filesystem::equivalent(options.output, input))
      throw Error(
          fmt::format("--output {} is one of the result CSVs the report reads; write the report to "
                      "another file",
                      options.output.string()));
  // The whole report first, so that a bad CSV or --columns leaves no half-written file or output behind.
  std::ostringstream text;
  print_report(options, text);
  if (options.output.empty()) {
    out << text.str();
    return;
  }
  std::error_code ec;
  if (options.output.has_parent_path()) std::filesystem::create_directories(options.output.parent_path(), ec);
  std::ofstream file(options.output);
  if (!file) throw Error(options.output.string() + ": cannot open for writing");
  file << text.str();
  if (!file) throw Error(options.output.string() + ": write failed");
}

}  // namespace sahbench
