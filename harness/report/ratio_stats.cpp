#include "harness/report/ratio_stats.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <boost/math/distributions/students_t.hpp>
#include <charconv>
#include <cmath>
#include <numeric>

#include "core/error.h"
#include "harness/run/timing.h"

namespace sahbench {
namespace {

// t(0.975, df) for df = 1..30, to 7 digits (Abramowitz and Stegun 1964, table 26.10; the same values as
// R's qt(0.975, df)).
constexpr std::array<double, 30> kT975 = {12.7062047, 4.3026527, 3.1824463, 2.7764451, 2.5705818, 2.4469119,
                                          2.3646243,  2.3060041, 2.2621572, 2.2281389, 2.2009852, 2.1788128,
                                          2.1603687,  2.1447867, 2.1314495, 2.1199053, 2.1098155, 2.1009220,
                                          2.0930241,  2.0859634, 2.0796138, 2.0738731, 2.0686576, 2.0638986,
                                          2.0595386,  2.0555294, 2.0518305, 2.0484071, 2.0452296, 2.0422725};

// z(0.975), the normal quantile the expansion starts from.
constexpr double kZ975 = 1.959963984540054;

// The Cornish-Fisher expansion of Student's t in powers of 1/df (Abramowitz and Stegun 26.7.5, the
// series Hill 1970, CACM algorithm 396, also uses). Its terms to 1/df^4 are within 1e-6 of the exact
// quantile from df = 30 on; below that the table is exact where the series is not (11.3 at df = 1).
double cornish_fisher_t(double z, double df) {
  const double z2 = z * z, z3 = z2 * z, z5 = z3 * z2, z7 = z5 * z2, z9 = z7 * z2;
  const double g1 = (z3 + z) / 4.0;
  const double g2 = (5 * z5 + 16 * z3 + 3 * z) / 96.0;
  const double g3 = (3 * z7 + 19 * z5 + 17 * z3 - 15 * z) / 384.0;
  const double g4 = (79 * z9 + 776 * z7 + 1482 * z5 - 1920 * z3 - 945 * z) / 92160.0;
  return z + g1 / df + g2 / (df * df) + g3 / (df * df * df) + g4 / (df * df * df * df);
}

struct LogStats {
  double mean = 0.0, sd = 0.0;
};

LogStats log_stats(std::span<const double> logs) {
  LogStats s;
  for (const double v : logs) s.mean += v;
  s.mean /= static_cast<double>(logs.size());
  if (logs.size() < 2) return s;
  double ss = 0.0;
  for (const double v : logs) ss += (v - s.mean) * (v - s.mean);
  s.sd = std::sqrt(ss / static_cast<double>(logs.size() - 1));
  return s;
}

}  // namespace

std::vector<double> parse_samples(std::string_view text) {
  std::vector<double> out;
  if (text.empty()) return out;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = std::min(text.find(';', start), text.size());
    const std::string_view item = text.substr(start, end - start);
    double value = 0.0;
    const auto [ptr, ec] = std::from_chars(item.data(), item.data() + item.size(), value);
    if (item.empty() || ec != std::errc() || ptr != item.data() + item.size())
      throw Error("sample '" + std::string(item) + "' is not a number");
    if (!std::isfinite(value)) throw Error("sample '" + std::string(item) + "' is not finite");
    if (value < 0) throw Error("sample '" + std::string(item) + "' is negative");
    out.push_back(value);
    if (end == text.size()) break;
    start = end + 1;
  }
  return out;
}

double median_of(std::span<const double> samples) {
  if (samples.empty()) throw Error("median of no samples");
  return summarize(std::vector<double>(samples.begin(), samples.end())).median;
}

double t_quantile_975(double df) {
  if (!(df >= 1.0)) throw Error(fmt::format("t quantile: {} degrees of freedom (at least 1)", df));
  if (df < static_cast<double>(kT975.size())) return kT975[static_cast<std::size_t>(df) - 1];
  return cornish_fisher_t(kZ975, df);
}

RatioInterval paired_ratio(std::span<const double> ours, std::span<const double> anchor) {
  // Sample r of both was taken in round r: lists of different lengths were not taken in the same rounds.
  if (ours.size() != anchor.size())
    throw Error(fmt::format("{} samples against the anchor's {}: not taken in the same rounds", ours.size(),
                            anchor.size()));
  const std::size_t n = ours.size();
  if (n == 0) throw Error("no round has samples of both");
  std::vector<double> logs(n);
  for (std::size_t r = 0; r < n; ++r) {
    if (!(ours[r] > 0) || !(anchor[r] > 0))
      throw Error(fmt::format("round {}: samples {} and {} (a ratio needs both positive)", r + 1, ours[r],
                              anchor[r]));
    logs[r] = std::log(ours[r] / anchor[r]);
  }
  const LogStats s = log_stats(logs);
  RatioInterval out;
  out.estimate = std::exp(s.mean);
  out.n = static_cast<int>(n);
  out.mean_log = s.mean;
  out.sd_log = s.sd;
  if (n < 2) return out;
  out.df = static_cast<double>(n - 1);
  const double half = t_quantile_975(out.df) * s.sd / std::sqrt(static_cast<double>(n));
  out.lo = std::exp(s.mean - half);
  out.hi = std::exp(s.mean + half);
  return out;
}

RatioInterval ratio_of_medians(double ours, double anchor) {
  if (!(ours > 0) || !(anchor > 0))
    throw Error(fmt::format("medians {} and {} (a ratio needs both positive)", ours, anchor));
  RatioInterval out;
  out.estimate = ours / anchor;
  out.mean_log = std::log(out.estimate);
  return out;
}

RatioInterval ratio_change(const RatioInterval& base, const RatioInterval& now) {
  RatioInterval out;
  out.mean_log = now.mean_log - base.mean_log;
  out.estimate = std::exp(out.mean_log);
  out.n = std::min(base.n, now.n);
  if (base.n < 2 || now.n < 2) return out;
  // Welch's standard error of the difference of two means, and Welch-Satterthwaite's degrees of freedom.
  const double vb = base.sd_log * base.sd_log / base.n, vn = now.sd_log * now.sd_log / now.n;
  const double se = std::sqrt(vb + vn);
  out.sd_log = se;
  // Both runs without spread: no noise to allow for, a zero-width interval (the df does not matter).
  out.df = se > 0 ? (vb + vn) * (vb + vn) / (vb * vb / (base.n - 1) + vn * vn / (now.n - 1))
                  : static_cast<double>(base.n + now.n - 2);
  const double half = t_quantile_975(out.df) * se;
  out.lo = std::exp(out.mean_log - half);
  out.hi = std::exp(out.mean_log + half);
  return out;
}

double p_value_of_no_change(const RatioInterval& change) {
  if (!change.has_interval()) return 1.0;
  if (change.sd_log == 0.0) return change.mean_log == 0.0 ? 1.0 : 0.0;
  // Below 30 degrees of freedom at their floor, as t_quantile_975 takes them for the printed interval, so
  // that p < 0.05 exactly where that interval excludes no change.
  const boost::math::students_t t(change.df < 30.0 ? std::max(1.0, std::floor(change.df)) : change.df);
  return 2.0 * boost::math::cdf(boost::math::complement(t, std::fabs(change.mean_log) / change.sd_log));
}

HolmResult holm(std::span<const double> p, double alpha) {
  std::vector<std::size_t> order(p.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p[a] < p[b]; });
  HolmResult out{std::vector<bool>(p.size(), false), std::vector<double>(p.size(), 1.0)};
  const std::size_t m = p.size();
  double running = 0.0;  // adjusted p-values never fall along the order
  bool still_rejecting = true;
  for (std::size_t k = 0; k < m; ++k) {
    const std::size_t i = order[k];
    const double scaled = std::min(1.0, static_cast<double>(m - k) * p[i]);
    running = std::max(running, scaled);
    out.adjusted[i] = running;
    still_rejecting = still_rejecting && p[i] <= alpha / static_cast<double>(m - k);
    out.rejected[i] = still_rejecting;
  }
  return out;
}

std::string format_ratio(const RatioInterval& ratio, int decimals) {
  if (ratio.has_interval())
    return fmt::format("{:.{}f} [{:.{}f}, {:.{}f}]", ratio.estimate, decimals, *ratio.lo, decimals, *ratio.hi,
                       decimals);
  if (ratio.n == 0) return fmt::format("{:.{}f} [medians]", ratio.estimate, decimals);
  return fmt::format("{:.{}f} [n={}]", ratio.estimate, decimals, ratio.n);
}

Verdict verdict(const RatioInterval& ratio, bool larger_is_better) {
  if (!ratio.has_interval()) return Verdict::kWithinNoise;
  if (*ratio.lo > 1.0) return larger_is_better ? Verdict::kAhead : Verdict::kBehind;
  if (*ratio.hi < 1.0) return larger_is_better ? Verdict::kBehind : Verdict::kAhead;
  return Verdict::kWithinNoise;
}

}  // namespace sahbench
