#include "harness/report.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <map>
#include <optional>
#include <ostream>
#include <set>
#include <sstream>

#include "core/error.h"
#include "harness/csv.h"
#include "harness/report_table.h"
#include "harness/stress_report.h"

namespace sahbench {
namespace {

// A field that older or other CSVs may lack (frame, embree_version, ...): empty when absent.
std::string field(const CsvRow& row, const std::string& column, const std::string& fallback = "") {
  const auto it = row.find(column);
  return it == row.end() || it->second.empty() ? fallback : it->second;
}

bool is_anchor(const CsvRow& row) {
  return field(row, "builder") == "embree" && field(row, "builder_params") == "quality=medium" &&
         field(row, "layout") == "embree_1";
}

std::string row_label(const CsvRow& row) {
  const std::string params = field(row, "builder_params");
  return field(row, "builder") + (params.empty() ? "" : " [" + params + "]");
}

// "k=v;k=v" as written in builder_params, in order.
std::vector<std::pair<std::string, std::string>> split_params(const std::string& params) {
  std::vector<std::pair<std::string, std::string>> out;
  std::size_t start = 0;
  while (start < params.size()) {
    const std::size_t end = std::min(params.find(';', start), params.size());
    const std::string item = params.substr(start, end - start);
    const std::size_t eq = item.find('=');
    if (!item.empty())
      out.emplace_back(item.substr(0, eq), eq == std::string::npos ? "" : item.substr(eq + 1));
    start = end + 1;
  }
  return out;
}

/// Short labels for a paper: per builder, only the parameters whose values differ between that
/// builder's rows of the table; the shared ones are returned (per builder) for the caption.
std::map<std::string, std::string> short_labels(const std::vector<const CsvRow*>& rows,
                                                std::vector<std::string>& shared) {
  std::map<std::string, std::map<std::string, std::vector<std::string>>>
      values;  // builder -> key -> values seen
  std::map<std::string, std::vector<std::string>> key_order;
  for (const CsvRow* r : rows) {
    const std::string builder = field(*r, "builder");
    for (const auto& [k, v] : split_params(field(*r, "builder_params"))) {
      auto& seen = values[builder][k];
      if (std::find(seen.begin(), seen.end(), v) == seen.end()) seen.push_back(v);
      auto& order = key_order[builder];
      if (std::find(order.begin(), order.end(), k) == order.end()) order.push_back(k);
    }
  }
  std::map<std::string, std::string> labels;  // full label -> short label
  for (const CsvRow* r : rows) {
    const std::string builder = field(*r, "builder");
    std::string varying;
    for (const auto& [k, v] : split_params(field(*r, "builder_params")))
      if (values[builder][k].size() > 1) varying += (varying.empty() ? "" : ";") + k + "=" + v;
    labels[row_label(*r)] = builder + (varying.empty() ? "" : " [" + varying + "]");
  }
  for (const auto& [builder, order] : key_order) {
    std::string common;
    for (const auto& k : order)
      if (values[builder][k].size() == 1)
        common += (common.empty() ? "" : ", ") + k + "=" + values[builder][k][0];
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
};

ReportTable make_table(const GroupKey& key, const std::vector<const CsvRow*>& group, ReportFormat format) {
  std::vector<std::string> ray_sets;
  for (const CsvRow* r : group)
    if (std::find(ray_sets.begin(), ray_sets.end(), field(*r, "ray_set")) == ray_sets.end())
      ray_sets.push_back(field(*r, "ray_set"));
  // The anchor: Embree medium, one ray at a time, per ray set.
  std::map<std::string, const CsvRow*> anchor;
  for (const CsvRow* r : group)
    if (is_anchor(*r)) anchor[field(*r, "ray_set")] = r;
  const CsvRow* any_anchor = anchor.empty() ? nullptr : anchor.begin()->second;

  ReportTable table;
  const CsvRow& first = *group.front();
  const std::string threads_text = key.threads + (key.threads == "1" ? " thread" : " threads");
  const std::string frame_text = key.frame == "0" ? "" : ", frame " + key.frame;
  table.title = fmt::format("{} ({} triangles), {}{}", key.scene, field(first, "scene_triangles", "?"),
                            threads_text, frame_text);
  table.label =
      "tab:" + label_key(key.scene) + "-t" + key.threads + (key.frame == "0" ? "" : "-f" + key.frame);
  table.columns = {{"build ms", "Build (ms)", 1, false},
                   {"memory MiB", "Memory (MiB)", 1, false},
                   {"SAH", "SAH cost", 2, false}};
  for (const auto& rs : ray_sets)
    table.columns.push_back({rs + " Mrays/s", latex_escape(rs) + " (Mrays/s)", 2, true});

  std::vector<std::string> shared;
  const auto short_label = short_labels(group, shared);
  // The compile target of the run; each row's kernel ISA is in the CSV's isa column (the kernel-ISA note
  // below lists them).
  std::string isa = field(first, "build_isa");
  if (isa.empty()) isa = field(first, "isa");
  std::set<std::string> kernel_isas;
  for (const auto* row : group)
    if (const std::string k = field(*row, "isa"); !k.empty()) kernel_isas.insert(k);
  std::string kernels;
  for (const auto& k : kernel_isas) kernels += (kernels.empty() ? "" : ", ") + k;
  table.caption = fmt::format(
      "{}; {}{}, commit {}; medians of {} builds and {} traces; kernels: {}. In parentheses: ratio to Embree "
      "(quality=medium, rtcIntersect1/rtcOccluded1) in the same run. Best of each column in bold: least "
      "build "
      "time, memory and SAH cost, most rays/s.",
      table.title, field(first, "cpu", "unknown CPU"), isa.empty() ? "" : " (built for " + isa + ")",
      field(first, "git_commit", "unknown"), field(first, "build_reps", "?"), field(first, "trace_reps", "?"),
      kernels.empty() ? "unknown" : kernels);
  // The Markdown rows name every parameter; the LaTeX rows only the varying ones, so name the rest here.
  if (format == ReportFormat::kLatex && !shared.empty()) {
    table.caption += " Parameters common to a builder's rows:";
    for (std::size_t i = 0; i < shared.size(); ++i) table.caption += (i ? "; " : " ") + shared[i];
    table.caption += ".";
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
    table.caption +=
        " SAH costs are in each builder's own constants; those in brackets differ from the table's "
        "usual " +
        usual + ", and are not compared.";
  }

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
  auto anchor_number = [&](const CsvRow* a, const std::string& column) {
    return a ? csv_number(*a, column) : std::nullopt;
  };
  constexpr double kMiB = 1 << 20;
  auto mib = [&](std::optional<double> bytes) {
    return bytes ? std::optional<double>(*bytes / kMiB) : std::nullopt;
  };
  for (const auto& [label, layout] : keys) {
    std::map<std::string, const CsvRow*> by_set;
    for (const CsvRow* r : group)
      if (row_label(*r) == label && field(*r, "layout") == layout) by_set[field(*r, "ray_set")] = r;
    const CsvRow& any = *by_set.begin()->second;
    ReportRow row{label, short_label.at(label), layout, {}};
    row.cells.push_back(
        cell(csv_number(any, "build_ms_median"), anchor_number(any_anchor, "build_ms_median")));
    row.cells.push_back(cell(mib(csv_number(any, "mem_bytes")), mib(anchor_number(any_anchor, "mem_bytes"))));
    row.cells.push_back(cell(csv_number(any, "sah_cost"), anchor_number(any_anchor, "sah_cost")));
    if (row.cells.back().value) row.cells.back().note = model_note(any);
    for (const auto& rs : ray_sets) {
      const auto it = by_set.find(rs);
      const auto a = anchor.find(rs);
      row.cells.push_back(it == by_set.end() ? ReportCell{}
                                             : cell(csv_number(*it->second, "trace_mrays_median"),
                                                    anchor_number(a == anchor.end() ? nullptr : a->second,
                                                                  "trace_mrays_median")));
    }
    table.rows.push_back(std::move(row));
  }
  mark_best(table);
  return table;
}

}  // namespace

ReportFormat parse_report_format(std::string_view name) {
  if (name == "markdown" || name == "md") return ReportFormat::kMarkdown;
  if (name == "latex" || name == "tex") return ReportFormat::kLatex;
  throw Error("unknown report format '" + std::string(name) + "' (known: markdown, latex)");
}

void print_report(const ReportOptions& options, std::ostream& out) {
  std::vector<CsvRow> rows;
  for (const auto& path : options.inputs) {
    auto more = read_csv(path);
    rows.insert(rows.end(), more.begin(), more.end());
  }
  if (rows.empty()) throw Error("no rows in the given CSV files");
  std::string run = options.run_id;
  // Rows are appended as cells finish, so the last row belongs to the latest run.
  if (run.empty()) run = field(rows.back(), "run_id");
  std::erase_if(rows, [&](const CsvRow& r) { return field(r, "run_id") != run; });
  if (rows.empty()) throw Error("no rows with run_id '" + run + "'");
  // Results of `sahbench stress` have tables of their own (harness/stress_report.h).
  if (is_stress_result(rows)) return print_stress_report(rows, options.format, out);

  const CsvRow& first = rows.front();
  const bool latex = options.format == ReportFormat::kLatex;
  if (latex)
    fmt::print(
        out,
        "% sahbench report: run {}, commit {}, {}, {}, {}; config {}\n% Needs \\usepackage{{booktabs}}.\n\n",
        run, field(first, "git_commit"), field(first, "cpu"), field(first, "compiler"),
        field(first, "embree_version"), field(first, "config"));
  else
    fmt::print(
        out,
        "# sahbench report: run {}\n\ncommit {}, {}, {}, {}; build reps {}, trace reps {}; config {}\n\n",
        run, field(first, "git_commit"), field(first, "cpu"), field(first, "compiler"),
        field(first, "embree_version"), field(first, "build_reps"), field(first, "trace_reps"),
        field(first, "config"));

  // Group by (scene, threads, frame); keep first-seen order.
  std::vector<GroupKey> groups;
  auto key_of = [](const CsvRow& r) {
    return GroupKey{field(r, "scene"), field(r, "threads"), field(r, "frame", "0")};
  };
  for (const auto& r : rows)
    if (std::find(groups.begin(), groups.end(), key_of(r)) == groups.end()) groups.push_back(key_of(r));
  for (const auto& key : groups) {
    std::vector<const CsvRow*> group;
    for (const auto& r : rows)
      if (key_of(r) == key) group.push_back(&r);
    const ReportTable table = make_table(key, group, options.format);
    if (latex)
      render_latex(table, out);
    else
      render_markdown(table, out);
  }
  if (!latex)
    fmt::print(out,
               "Ratios are to embree [quality=medium] with rtcIntersect1/rtcOccluded1 in the same run; build "
               "ms and\n"
               "Mrays/s are medians over the repetitions. Memory is the traversed structure's exact bytes. "
               "The best\n"
               "value of each column is in bold.\n");
}

void run_report_command(const ReportOptions& options, std::ostream& out) {
  if (options.output.empty()) return print_report(options, out);
  // Write the whole report first, so that a bad CSV leaves no half-written file behind.
  std::ostringstream text;
  print_report(options, text);
  std::error_code ec;
  if (options.output.has_parent_path()) std::filesystem::create_directories(options.output.parent_path(), ec);
  std::ofstream file(options.output);
  if (!file) throw Error(options.output.string() + ": cannot open for writing");
  file << text.str();
  if (!file) throw Error(options.output.string() + ": write failed");
}

}  // namespace sahbench
