#pragma once
// How well the cost models predict the measured speed: for the rows of one report table (a scene, thread
// count and frame), per layout and ray set, Spearman's rank correlation across our builders between
// rays/s and each cost (SAH, EPO, their blend, and the cost per ray measured by the counting kernel),
// each negated so that 1 means the cost orders the builders exactly as their speed. Aila, Karras and
// Laine 2013 ("On Quality Metrics of Bounding Volume Hierarchies") ask the same question of SAH and EPO.

#include <array>
#include <cstddef>
#include <iosfwd>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "harness/report/report.h"
#include "harness/run/csv.h"

namespace sahbench {

/// Spearman's rank correlation of the pairs (x[i], y[i]): Pearson's correlation of their ranks, tied
/// values taking the mean of the ranks they span. Nullopt for fewer than 2 pairs, for spans of different
/// sizes, or where all x or all y are equal (no order to compare).
std::optional<double> spearman(std::span<const double> x, std::span<const double> y);

/// Pearson's correlation of the pairs (x[i], y[i]); nullopt as spearman().
std::optional<double> pearson(std::span<const double> x, std::span<const double> y);

/// The weight of EPO in the blend (1 - w) SAH + w EPO that best predicts the measured time per ray
/// (1 / rays/s) across builders, as Aila, Karras and Laine 2013 fit it for each scene and kind of ray
/// (section 5): w from 0 to 1 in steps of kEpoWeightStep, the one of the largest Pearson correlation r
/// (the smallest such w on ties).
struct EpoWeightFit {
  double weight = 0.0;
  double r = 0.0;
};
inline constexpr double kEpoWeightStep = 0.01;

/// The fit over the builders (sah[i], epo[i], time_per_ray[i]); nullopt for fewer than kMinRankedBuilders,
/// for spans of different sizes, or where no weight gives a correlation.
std::optional<EpoWeightFit> fit_epo_weight(std::span<const double> sah, std::span<const double> epo,
                                           std::span<const double> time_per_ray);

/// Fewest builders a correlation is computed over: with two, any cost either agrees or disagrees.
inline constexpr std::size_t kMinRankedBuilders = 3;

/// The costs correlated, as the CSV names them: sah_cost, epo_cost, sah_epo_cost, cost_per_ray.
inline constexpr std::array<const char*, 4> kPredictorColumns = {"sah_cost", "epo_cost", "sah_epo_cost",
                                                                 "cost_per_ray"};

/// One layout and ray set of a table: how many of our builders were traced with it (rows with rays/s and
/// an SAH cost), and the correlation of rays/s with each negated cost of kPredictorColumns, over the rows
/// that have that cost; empty where fewer than kMinRankedBuilders have it (or it orders nothing).
struct PredictorRow {
  std::string layout, ray_set;
  /// The SAH constants of these rows ("c_trav=3, c_isect=1, block=4") where the table's rows have more
  /// than one set: costs under different constants are on different scales, so each set is ranked apart.
  std::string model = {};
  std::size_t builders = 0;
  std::array<std::optional<double>, kPredictorColumns.size()> rho{};
  std::optional<EpoWeightFit> epo_weight;  ///< over the rows with an SAH and an EPO cost
};

/// The rows of `group` (one report table's) by layout, ray set and SAH constants, in order of first
/// appearance.
/// Embree's rows, with no cost of ours, take no part.
std::vector<PredictorRow> predictor_rows(const std::vector<const CsvRow*>& group);

/// The section after a report table: a heading naming `title`, the correlations of the layouts and ray
/// sets with at least kMinRankedBuilders builders, and a line naming those with fewer; only that line
/// where none has enough. Nothing where no row has an SAH cost and rays/s.
void render_predictors(const std::string& title, const std::vector<PredictorRow>& rows, ReportFormat format,
                       std::ostream& out);

}  // namespace sahbench
