#include "harness/report/predictors.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <ostream>

#include "core/epo.h"
#include "harness/report/report_table.h"

namespace sahbench {
namespace {

// Ranks from 1, ties given the mean of the ranks they span.
std::vector<double> ranks(std::span<const double> v) {
  std::vector<std::size_t> order(v.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
  std::vector<double> out(v.size());
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j + 1 < order.size() && v[order[j + 1]] == v[order[i]]) ++j;
    const double mean_rank = (static_cast<double>(i) + static_cast<double>(j)) / 2.0 + 1.0;
    for (std::size_t k = i; k <= j; ++k) out[order[k]] = mean_rank;
    i = j + 1;
  }
  return out;
}

std::string field(const CsvRow& row, const std::string& column) {
  const auto it = row.find(column);
  return it == row.end() ? "" : it->second;
}

// "c_trav=3, c_isect=1, block=4": the constants a row's SAH cost is under.
std::string cost_model(const CsvRow& row) {
  return fmt::format("c_trav={}, c_isect={}, block={}", field(row, "sah_c_trav"), field(row, "sah_c_isect"),
                     field(row, "sah_block"));
}

// "shadow", or "shadow [c_trav=1, c_isect=1, block=4]" where the table has rows under other constants.
std::string rays_label(const PredictorRow& r) {
  return r.model.empty() ? r.ray_set : fmt::format("{} [{}]", r.ray_set, r.model);
}

// "0.83", or "-" where there is no correlation.
std::string rho_text(const std::optional<double>& rho) {
  return rho ? fmt::format("{:.2f}", *rho) : "-";
}

// "0.74 (0.98)": the fitted weight and its correlation, or "-".
std::string fit_text(const std::optional<EpoWeightFit>& fit) {
  return fit ? fmt::format("{:.2f} ({:.2f})", fit->weight, fit->r) : "-";
}

}  // namespace

std::optional<double> spearman(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size() || x.size() < 2) return std::nullopt;
  const std::vector<double> rx = ranks(x), ry = ranks(y);
  const double mean = (static_cast<double>(x.size()) + 1.0) / 2.0;
  double sxy = 0.0, sxx = 0.0, syy = 0.0;
  for (std::size_t i = 0; i < rx.size(); ++i) {
    sxy += (rx[i] - mean) * (ry[i] - mean);
    sxx += (rx[i] - mean) * (rx[i] - mean);
    syy += (ry[i] - mean) * (ry[i] - mean);
  }
  if (!(sxx > 0.0) || !(syy > 0.0)) return std::nullopt;
  return sxy / std::sqrt(sxx * syy);
}

std::optional<double> pearson(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size() || x.size() < 2) return std::nullopt;
  const double n = static_cast<double>(x.size());
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / n;
  const double my = std::accumulate(y.begin(), y.end(), 0.0) / n;
  double sxy = 0.0, sxx = 0.0, syy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
  }
  if (!(sxx > 0.0) || !(syy > 0.0)) return std::nullopt;
  return sxy / std::sqrt(sxx * syy);
}

std::optional<EpoWeightFit> fit_epo_weight(std::span<const double> sah, std::span<const double> epo,
                                           std::span<const double> time_per_ray) {
  if (sah.size() != epo.size() || sah.size() != time_per_ray.size() || sah.size() < kMinRankedBuilders)
    return std::nullopt;
  std::optional<EpoWeightFit> best;
  const int steps = static_cast<int>(std::lround(1.0 / kEpoWeightStep));
  std::vector<double> blend(sah.size());
  for (int step = 0; step <= steps; ++step) {
    const double w = step * kEpoWeightStep;
    for (std::size_t i = 0; i < sah.size(); ++i) blend[i] = (1.0 - w) * sah[i] + w * epo[i];
    const auto r = pearson(blend, time_per_ray);
    if (r && (!best || *r > best->r)) best = EpoWeightFit{w, *r};
  }
  return best;
}

std::vector<PredictorRow> predictor_rows(const std::vector<const CsvRow*>& group) {
  std::vector<PredictorRow> out;
  std::vector<std::vector<const CsvRow*>> members;
  // Our traced rows: Embree's have no SAH cost, an invalid tree's no rays/s.
  auto ranked = [](const CsvRow& r) {
    return csv_number(r, "sah_cost") && csv_number(r, "trace_mrays_median");
  };
  std::optional<std::string> first_model;
  bool one_model = true;
  for (const CsvRow* r : group) {
    if (!ranked(*r)) continue;
    const std::string model = cost_model(*r);
    if (!first_model) first_model = model;
    one_model &= model == *first_model;
  }
  for (const CsvRow* r : group) {
    if (!ranked(*r)) continue;
    const std::string layout = field(*r, "layout"), ray_set = field(*r, "ray_set");
    const std::string model = one_model ? "" : cost_model(*r);
    auto it = std::find_if(out.begin(), out.end(), [&](const PredictorRow& p) {
      return p.layout == layout && p.ray_set == ray_set && p.model == model;
    });
    if (it == out.end()) {
      PredictorRow row;
      row.layout = layout;
      row.ray_set = ray_set;
      row.model = model;
      it = out.insert(out.end(), std::move(row));
      members.emplace_back();
    }
    members[static_cast<std::size_t>(it - out.begin())].push_back(r);
  }
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i].builders = members[i].size();
    for (std::size_t p = 0; p < kPredictorColumns.size(); ++p) {
      std::vector<double> speed, negated_cost;
      for (const CsvRow* r : members[i])
        if (const auto cost = csv_number(*r, kPredictorColumns[p])) {
          speed.push_back(*csv_number(*r, "trace_mrays_median"));
          negated_cost.push_back(-*cost);
        }
      if (speed.size() >= kMinRankedBuilders) out[i].rho[p] = spearman(speed, negated_cost);
    }
    std::vector<double> sah, epo, time_per_ray;
    for (const CsvRow* r : members[i])
      if (const auto e = csv_number(*r, "epo_cost")) {
        sah.push_back(*csv_number(*r, "sah_cost"));
        epo.push_back(*e);
        time_per_ray.push_back(1.0 / *csv_number(*r, "trace_mrays_median"));
      }
    out[i].epo_weight = fit_epo_weight(sah, epo, time_per_ray);
  }
  return out;
}

void render_predictors(const std::string& title, const std::vector<PredictorRow>& rows, ReportFormat format,
                       std::ostream& out) {
  if (rows.empty()) return;
  std::vector<const PredictorRow*> ranked;
  std::string too_few;
  for (const PredictorRow& r : rows) {
    if (r.builders >= kMinRankedBuilders)
      ranked.push_back(&r);
    else
      too_few +=
          fmt::format("{}{} {} ({})", too_few.empty() ? "" : "; ", r.layout, rays_label(r), r.builders);
  }
  const std::string explanation = fmt::format(
      "Spearman rank correlation across builders between rays/s and each cost, negated: 1 where the cost "
      "orders the builders exactly as their speed, -1 in reverse. SAH+EPO is (1 - w) SAH + w EPO with w = "
      "{} (tinybvh's); fitted w is the weight that best predicts the time per ray here, with its Pearson "
      "correlation r, fitted per scene and kind of ray as Aila, Karras and Laine 2013 do; cost/ray is "
      "c_trav nodes_per_ray + c_isect prims_per_ray from the counting kernel; '-' where fewer than {} "
      "rows have the cost or it orders nothing.",
      kEpoWeight, kMinRankedBuilders);
  const std::string skipped =
      too_few.empty() ? ""
                      : fmt::format("Not ranked, fewer than {} builders (layout, ray set, builders): {}.",
                                    kMinRankedBuilders, too_few);
  const bool latex = format == ReportFormat::kLatex;
  // Nothing to rank in this table: one short line rather than an empty section or a list of every
  // layout and ray set (a claim run's table has dozens, each with one builder).
  if (ranked.empty()) {
    std::size_t most = 0;
    for (const PredictorRow& r : rows) most = std::max(most, r.builders);
    fmt::print(out,
               "{}Costs against rays/s, {}: not ranked, no layout and ray set has {} builders or more (at "
               "most {}).\n\n",
               latex ? "% " : "", title, kMinRankedBuilders, most);
    return;
  }
  if (latex) {
    // In the style of the report's tables (table_fit.h): footnotesize, a short caption, the explanation
    // in a legend under the table, and each layout a heading row above its ray sets, so that the table
    // fits one column of a two-column page.
    fmt::print(
        out,
        "\\begin{{table}}[htbp]\n  \\centering\n  \\footnotesize\n  \\setlength{{\\tabcolsep}}{{3pt}}\n"
        "  \\caption{{How well the costs predict rays/s: {}.}}\n  \\begin{{tabular}}{{lrrrrr}}\n    "
        "\\toprule\n"
        "    Rays (builders) & SAH & EPO & \\begin{{tabular}}[b]{{@{{}}r@{{}}}}SAH+\\\\EPO\\end{{tabular}} & "
        "\\begin{{tabular}}[b]{{@{{}}r@{{}}}}Cost\\\\per ray\\end{{tabular}} & "
        "\\begin{{tabular}}[b]{{@{{}}r@{{}}}}Fitted\\\\$w$ ($r$)\\end{{tabular}} \\\\\n    \\midrule\n",
        latex_escape(title));
    // Each layout's ray sets together (and, where the rows have several, under each set of SAH
    // constants), in order of first appearance.
    auto heading_of = [](const PredictorRow* r) {
      return r->model.empty() ? r->layout : fmt::format("{} [{}]", r->layout, r->model);
    };
    std::vector<std::string> headings;
    for (const PredictorRow* r : ranked)
      if (std::find(headings.begin(), headings.end(), heading_of(r)) == headings.end())
        headings.push_back(heading_of(r));
    auto heading_index = [&](const PredictorRow* r) {
      return std::find(headings.begin(), headings.end(), heading_of(r)) - headings.begin();
    };
    std::stable_sort(ranked.begin(), ranked.end(), [&](const PredictorRow* a, const PredictorRow* b) {
      return heading_index(a) < heading_index(b);
    });
    std::string heading;
    for (const PredictorRow* r : ranked) {
      if (heading_of(r) != heading) {
        heading = heading_of(r);
        fmt::print(out, "    \\multicolumn{{6}}{{l}}{{{}}} \\\\\n", latex_escape(heading));
      }
      fmt::print(out, "    \\quad {} ({}) & {} & {} & {} & {} & {} \\\\\n", latex_escape(r->ray_set),
                 r->builders, rho_text(r->rho[0]), rho_text(r->rho[1]), rho_text(r->rho[2]),
                 rho_text(r->rho[3]), fit_text(r->epo_weight));
    }
    fmt::print(out,
               "    \\bottomrule\n  \\end{{tabular}}\n  \\par\\smallskip{{\\scriptsize "
               "{}{}\\par}}\n\\end{{table}}\n\n",
               latex_escape(explanation), skipped.empty() ? "" : " " + latex_escape(skipped));
    return;
  }
  fmt::print(out,
             "### How well the costs predict rays/s: {}\n\n"
             "| layout | ray set | builders | SAH | EPO | SAH+EPO | cost/ray | fitted w (r) |\n"
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n",
             title);
  for (const PredictorRow* r : ranked)
    fmt::print(out, "| {} | {} | {} | {} | {} | {} | {} | {} |\n", r->layout, rays_label(*r), r->builders,
               rho_text(r->rho[0]), rho_text(r->rho[1]), rho_text(r->rho[2]), rho_text(r->rho[3]),
               fit_text(r->epo_weight));
  fmt::print(out, "\n{}\n\n", explanation);
  if (!skipped.empty()) fmt::print(out, "{}\n\n", skipped);
}

}  // namespace sahbench
