#pragma once
// Ratios to Embree from timing samples paired by round, with a 95% interval, and the change of such a
// ratio between two runs. `compare` gates on them and `report` prints them.
//
// Method. Sample r of every cell of one run, scene, thread count and frame is taken in the same round r
// (the cells of a round run in a shuffled order), so a slow spell of the machine moves ours and Embree's
// sample r together and cancels in their ratio q_r = ours_r / embree_r. The estimate is the geometric mean
// of q_r over the rounds both have, and its 95% interval is
//   exp(mean(log q) +- t(0.975, n - 1) * sd(log q) / sqrt(n)),
// Student's t on the log ratios. Ratios are compared on a log scale because that is where they are
// symmetric: 0.5 and 2 are the same distance from 1, and the mean of logs is the only average of ratios
// that does not depend on which side is the numerator (Fleming and Wallace 1986, "How not to lie with
// statistics: the correct way to summarize benchmark results", CACM 29(3)).
//
// The change between a baseline run and a new run is unpaired (different runs, different rounds):
// d = mean(log q_new) - mean(log q_base), with Welch's standard error and Welch-Satterthwaite degrees of
// freedom (Welch 1947, Biometrika 34), and its 95% interval taken to exp(d).

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace sahbench {

/// A ratio with its 95% interval. Built by paired_ratio, ratio_change or ratio_of_medians.
struct RatioInterval {
  double estimate = 1.0;
  std::optional<double> lo, hi;  ///< both or neither: none from one round, or from medians
  int n = 0;                     ///< rounds paired (a change: the fewer of its two); 0: from medians
  double mean_log = 0.0;         ///< mean of the log ratios (for a change: d)
  double sd_log =
      0.0;          ///< their sample standard deviation (0 with one round); for a change, d's standard error
  double df = 0.0;  ///< degrees of freedom of the interval's t quantile
  bool has_interval() const { return lo.has_value(); }
};

/// The samples of a `*_samples` column: semicolon-separated decimal numbers ("12.5;12.7;12.4"), in round
/// order; an empty text gives none. A value that is not a number, or is NaN, infinite or negative, is an
/// Error naming it (callers add the file, column and line).
std::vector<double> parse_samples(std::string_view text);

/// The median of `samples` (the mean of the middle two for an even count), as timing.h's summarize
/// computes the `*_median` columns; an empty list is an Error.
double median_of(std::span<const double> samples);

/// t(0.975, df), the two-sided 95% quantile of Student's t: a table for df 1..30, the Cornish-Fisher
/// expansion beyond (accurate to 1e-6 there). A fractional df below 30 (Welch's) is rounded down, the
/// conservative side. df below 1 or NaN is an Error.
double t_quantile_975(double df);

/// The ratio ours / anchor from samples paired by index (see the top of this file). Samples of different
/// counts (rounds that cannot be paired), none, or a sample that is not positive is an Error naming it.
RatioInterval paired_ratio(std::span<const double> ours, std::span<const double> anchor);

/// ours / anchor from medians alone (CSVs without samples): an estimate without an interval, n = 0. A
/// median that is not positive is an Error.
RatioInterval ratio_of_medians(double ours, double anchor);

/// How `now` changed against `base`: exp(d) with Welch's 95% interval (see the top of this file).
/// Without samples in either (n < 2) there is no interval.
RatioInterval ratio_change(const RatioInterval& base, const RatioInterval& now);

/// "1.08 [1.03, 1.12]"; "1.08 [n=1]" from one round; "1.08 [medians]" for a ratio of medians.
std::string format_ratio(const RatioInterval& ratio, int decimals = 2);

/// The two-sided p-value of "no change" for a change from ratio_change: the probability under Student's
/// t with the change's Welch degrees of freedom of a mean log at least as far from 0 as its mean_log.
/// 1 without an interval; 0 for a non-zero change between runs without spread.
double p_value_of_no_change(const RatioInterval& change);

/// Holm's step-down procedure (Holm 1979, "A simple sequentially rejective multiple test procedure",
/// Scand. J. Statist. 6(2)): which of the hypotheses with p-values `p` are rejected so that the chance of
/// rejecting any true one stays at most `alpha`, and each one's adjusted p-value (the smallest alpha at
/// which it would be rejected). Without it, each of a file's hundred timing changes would be flagged by
/// chance 5% of the time, and an unchanged build most of the time somewhere.
struct HolmResult {
  std::vector<bool> rejected;
  std::vector<double> adjusted;
};
HolmResult holm(std::span<const double> p, double alpha = 0.05);

enum class Verdict { kAhead, kBehind, kWithinNoise };

/// Ahead when the interval lies wholly on the better side of 1 (above it where larger is better, as
/// rays/s; below it for times), behind when wholly on the worse side, within noise when it contains 1
/// or there is no interval.
Verdict verdict(const RatioInterval& ratio, bool larger_is_better = true);

}  // namespace sahbench
