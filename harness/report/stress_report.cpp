#include "harness/report/stress_report.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <ostream>
#include <set>
#include <sstream>
#include <string>
#include <tuple>

#include "harness/report/html_report.h"
#include "harness/report/report_table.h"
#include "harness/report/table_fit.h"

namespace sahbench {
namespace {

// ulp_distance saturates here for an infinite or NaN t against a finite one.
constexpr double kSaturatedUlps = std::numeric_limits<uint32_t>::max();

double number(const CsvRow& row, const std::string& column) {
  return csv_number(row, column).value_or(0.0);
}

// "embree (robust)" for Embree's modes, the builder's name otherwise (the layout column tells the arity).
std::string builder_label(const CsvRow& row) {
  const std::string& params = row.at("builder_params");
  const auto mode = params.find("mode=");
  if (row.at("builder") == "embree" && mode != std::string::npos)
    return "embree (" + params.substr(mode + 5) + ")";
  return row.at("builder");
}

std::string layout_label(const CsvRow& row) {
  return row.at("layout").empty() ? "(not traced)" : row.at("layout");
}

std::string ulps(double value) {
  if (value >= kSaturatedUlps) return "inf";
  return value >= 1e6 ? fmt::format("{:.2g}", value) : fmt::format("{:.0f}", value);
}

// One variant's totals over the cases. Speed is the geometric mean of the per-case rays/second: the
// cases differ by 100x in cost (100,000 coincident triangles), and a plain total would be one case's.
struct Totals {
  std::map<std::string, double> log_mrays;  ///< per case traced
  double traced = 0, weighted_mean_ulps = 0, hits = 0, max_ulps = 0;
  double false_misses = 0, false_hits = 0, wrong_prim = 0, wrong_prim_far = 0, leaks = 0, build_failed = 0,
         nan_bounds = 0;
  int cases = 0;

  /// The geometric mean over `cases`, which this variant has all traced; none for no cases.
  std::optional<double> mrays(const std::vector<std::string>& over) const {
    if (traced == 0 || over.empty()) return std::nullopt;
    double sum = 0;
    for (const std::string& c : over) sum += log_mrays.at(c);
    return std::exp(sum / static_cast<double>(over.size()));
  }

  void add(const CsvRow& r) {
    ++cases;
    build_failed += number(r, "build_failed");
    nan_bounds += number(r, "nan_bounds");
    const auto mrays = csv_number(r, "trace_mrays_median");
    if (!mrays || *mrays <= 0) return;
    log_mrays[r.at("scene")] = std::log(*mrays);
    ++traced;
    false_misses += number(r, "false_misses");
    false_hits += number(r, "false_hits");
    wrong_prim += number(r, "wrong_prim");
    wrong_prim_far += number(r, "wrong_prim_far");
    leaks += number(r, "leaks");
    max_ulps = std::max(max_ulps, number(r, "t_err_ulps_max"));
    weighted_mean_ulps += number(r, "t_err_ulps_mean") * number(r, "exact_hits");
    hits += number(r, "exact_hits");
  }
};

// The error-against-time table, one row per (builder, layout), speed as a ratio to the first variant
// traced (the first builder's default layout).
ReportTable error_against_time(const std::vector<CsvRow>& rows) {
  // A builder run with several parameter sets gets a row per set, named by its parameters.
  std::map<std::string, std::set<std::string>> params_of;
  for (const CsvRow& r : rows) params_of[builder_label(r)].insert(r.at("builder_params"));
  auto variant = [&](const CsvRow& r) {
    const std::string label = builder_label(r);
    return params_of[label].size() > 1 ? label + " [" + r.at("builder_params") + "]" : label;
  };
  std::vector<std::pair<std::string, std::string>> keys;
  std::map<std::pair<std::string, std::string>, Totals> totals;
  for (const CsvRow& r : rows) {
    const auto key = std::make_pair(variant(r), layout_label(r));
    if (!totals.count(key)) keys.push_back(key);
    totals[key].add(r);
  }
  // Speeds are compared over the cases every traced variant traced: a variant whose build failed on a
  // slow case would otherwise gain that case's weight against the others.
  std::vector<std::string> common;
  bool first = true;
  for (const auto& key : keys) {
    const Totals& t = totals[key];
    if (t.traced == 0) continue;
    if (first) {
      for (const auto& [name, log] : t.log_mrays) common.push_back(name);
      first = false;
    } else {
      std::erase_if(common, [&](const std::string& name) { return !t.log_mrays.count(name); });
    }
  }
  std::optional<double> anchor;
  std::string anchor_name;
  for (const auto& key : keys)
    if (!anchor && totals[key].mrays(common))
      anchor = totals[key].mrays(common), anchor_name = key.first + " " + key.second;
  const std::string speeds =
      anchor ? fmt::format(
                   "geometric mean of each case's median rays/second (one traversal pass over its "
                   "rays) over the {} cases that every traced variant traced, with its ratio to {}'s",
                   common.size(), anchor_name)
             : "none: no case was traced by every traced variant";

  ReportTable table;
  table.title = "Error against run time, all cases";
  table.label = "tab:stress";
  // Smaller is better everywhere but speed; counts print without decimals.
  table.columns = {{"cases", "Cases", 0},
                   {"traced", "Traced", 0},
                   {"Mrays/s", "Mrays/s", 2, true},
                   {"false misses", "False misses", 0},
                   {"false hits", "False hits", 0},
                   {"wrong prim", "Wrong prim.", 0},
                   {"(far)", "(far)", 0},
                   {"leaks", "Leaks", 0},
                   {"t err max ulps", "$t$ err. max (ulp)", 0},
                   {"t err mean ulps", "$t$ err. mean (ulp)", 1},
                   {"builds failed", "Builds failed", 0},
                   {"NaN bounds", "NaN bounds", 0}};
  for (const auto& key : keys) {
    const Totals& t = totals[key];
    const auto mrays = t.mrays(common);
    ReportRow row;
    row.builder = row.builder_short = key.first;
    row.layout = key.second;
    auto cell = [](std::optional<double> v) { return ReportCell{v, std::nullopt, false}; };
    const bool traced = t.traced > 0;
    auto traced_cell = [&](double v) { return cell(traced ? std::optional<double>(v) : std::nullopt); };
    row.cells = {
        cell(t.cases), cell(t.traced),
        ReportCell{mrays, mrays && anchor ? std::optional<double>(*mrays / *anchor) : std::nullopt, false},
        traced_cell(t.false_misses), traced_cell(t.false_hits), traced_cell(t.wrong_prim),
        traced_cell(t.wrong_prim_far), traced_cell(t.leaks),
        // ulp_distance's saturation (an infinite t) prints as inf.
        traced_cell(t.max_ulps >= kSaturatedUlps ? std::numeric_limits<double>::infinity() : t.max_ulps),
        cell(t.hits > 0 ? std::optional<double>(t.weighted_mean_ulps / t.hits) : std::nullopt),
        cell(t.build_failed), cell(t.nan_bounds)};
    table.rows.push_back(std::move(row));
  }
  mark_best(table);
  // A column where every variant has the same value (no build failed anywhere), or whose best is an
  // infinite t error, names no winner: no bold there; nor do the counts of cases.
  for (ReportRow& row : table.rows) row.cells[0].best = row.cells[1].best = false;
  for (std::size_t c = 0; c < table.columns.size(); ++c) {
    std::size_t marked = 0;
    bool infinite = false;
    for (const ReportRow& row : table.rows)
      if (row.cells[c].best) ++marked, infinite |= std::isinf(*row.cells[c].value);
    if (marked == table.rows.size() || infinite)
      for (ReportRow& row : table.rows) row.cells[c].best = false;
  }
  table.caption = "Stress suite: errors of each variant over every case it traced, against its rays/s.";
  table.legend.push_back(fmt::format(
      "Traced: the cases a variant built and traced; errors are summed over those. Mrays/s: {}. Errors are "
      "against the exact reference: a tie on a "
      "shared edge or "
      "vertex "
      "accepts any of its triangles; (far): wrong primitives more than 1e-5 (relative) away in t. t errors "
      "are "
      "over hits on an accepted primitive; inf: an infinite t where the exact one is finite, which the mean "
      "(weighted by exact hits) leaves out. The best value of each column is in bold.",
      speeds));
  return table;
}

void print_wrong_cases(const std::vector<CsvRow>& rows, std::ostream& out) {
  fmt::print(
      out,
      "## Where a variant is wrong\n\n"
      "Per case, the variants with the same errors together; variants without errors are not listed.\n\n"
      "| case | variants | false misses | false hits | wrong prim (far) | leaks | t err max ulps | notes |\n"
      "|---|---|---:|---:|---:|---:|---:|---|\n");
  std::vector<std::string> cases;
  for (const CsvRow& r : rows)
    if (std::find(cases.begin(), cases.end(), r.at("scene")) == cases.end()) cases.push_back(r.at("scene"));
  using Errors = std::tuple<double, double, double, double, double, std::string>;
  for (const std::string& name : cases) {
    std::vector<Errors> order;
    std::map<Errors, std::vector<std::string>> variants;
    std::map<Errors, double> max_ulps;
    for (const CsvRow& r : rows) {
      if (r.at("scene") != name) continue;
      const Errors e{number(r, "false_misses"),   number(r, "false_hits"), number(r, "wrong_prim"),
                     number(r, "wrong_prim_far"), number(r, "leaks"),      r.at("notes")};
      const bool wrong =
          std::get<0>(e) + std::get<1>(e) + std::get<2>(e) + std::get<4>(e) + number(r, "build_failed") > 0 ||
          r.at("notes").starts_with("trace failed");
      if (!wrong) continue;
      if (!variants.count(e)) order.push_back(e);
      variants[e].push_back(builder_label(r) + "|" + layout_label(r));
      max_ulps[e] = std::max(max_ulps[e], number(r, "t_err_ulps_max"));
    }
    for (const Errors& e : order) {
      // "builder layout, layout; builder layout": layouts of one builder together.
      std::vector<std::pair<std::string, std::string>> by_builder;
      for (const auto& v : variants[e]) {
        const auto bar = v.find('|');
        const std::string builder = v.substr(0, bar), layout = v.substr(bar + 1);
        auto it = std::find_if(by_builder.begin(), by_builder.end(),
                               [&](const auto& p) { return p.first == builder; });
        if (it == by_builder.end())
          by_builder.emplace_back(builder, layout);
        else
          it->second += ", " + layout;
      }
      std::string list;
      for (const auto& [builder, layouts] : by_builder)
        list += (list.empty() ? "" : "; ") + builder + " " + layouts;
      fmt::print(out, "| {} | {} | {:.0f} | {:.0f} | {:.0f} ({:.0f}) | {:.0f} | {} | {} |\n", name, list,
                 std::get<0>(e), std::get<1>(e), std::get<2>(e), std::get<3>(e), std::get<4>(e),
                 ulps(max_ulps[e]), std::get<5>(e));
    }
  }
  fmt::print(out, "\n");
}

void print_cases(const std::vector<CsvRow>& rows, std::ostream& out) {
  fmt::print(out,
             "## Cases\n\n"
             "| case | kind | triangles | removed | rays | exact hits | ties | must hit | closed | exact "
             "reference ms |\n"
             "|---|---|---:|---:|---:|---:|---:|---:|---|---:|\n");
  std::vector<std::string> seen;
  for (const CsvRow& r : rows) {
    if (std::find(seen.begin(), seen.end(), r.at("scene")) != seen.end()) continue;
    seen.push_back(r.at("scene"));
    fmt::print(out, "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", r.at("scene"), r.at("case_kind"),
               r.at("scene_triangles"), r.at("scene_removed"), r.at("ray_count"), r.at("exact_hits"),
               r.at("ties"), r.at("must_hit_rays"), r.at("closed") == "1" ? "yes" : "no",
               r.at("reference_ms"));
  }
  fmt::print(out, "\n");
}

}  // namespace

bool is_stress_result(const std::vector<CsvRow>& rows) {
  return !rows.empty() && rows.front().count("false_misses") && rows.front().count("leaks");
}

void print_stress_report(const std::vector<CsvRow>& rows, ReportFormat format, std::ostream& out,
                         PageWidth width) {
  const CsvRow& first = rows.front();
  const ReportTable table = error_against_time(rows);
  if (format == ReportFormat::kHtml) {
    html_begin("sahbench stress report: run " + first.at("run_id"),
               fmt::format("commit {}, {}, {}, {}; config {}", first.at("git_commit"), first.at("cpu"),
                           first.at("compiler"), first.at("embree_version"), first.at("config")),
               out);
    render_html(table, out);
    std::ostringstream cases;
    print_wrong_cases(rows, cases);
    print_cases(rows, cases);
    fmt::print(out, "<pre>{}</pre>\n", html_escape(cases.str()));
    return html_end(out);
  }
  if (format == ReportFormat::kLatex) {
    fmt::print(out,
               "% sahbench stress report: run {}, commit {}, {}, {}, {}; config {}\n% Needs "
               "\\usepackage{{booktabs}}.\n\n",
               first.at("run_id"), first.at("git_commit"), first.at("cpu"), first.at("compiler"),
               first.at("embree_version"), first.at("config"));
    for (const ReportTable& part : split_to_width(table, width)) render_latex(part, out, width);
    return;
  }
  fmt::print(
      out,
      "# sahbench stress report: run {}\n\ncommit {}, {}, {}, {}; {} thread(s), trace reps {}, build time "
      "bound {} s; config {}\n\n",
      first.at("run_id"), first.at("git_commit"), first.at("cpu"), first.at("compiler"),
      first.at("embree_version"), first.at("threads"), first.at("trace_reps"), first.at("build_time_limit_s"),
      first.at("config"));
  render_markdown(table, out);
  print_wrong_cases(rows, out);
  print_cases(rows, out);
}

}  // namespace sahbench
