// Ratios to Embree from samples paired by round: the samples field parses (and its median is the median
// column's), the t quantiles are right, the 95% interval covers a known true ratio about 95% of the time
// and narrows with more rounds, the change between two runs covers a known change, and result rows
// carry the line they start on.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "core/error.h"
#include "harness/report/ratio_stats.h"
#include "harness/report/result_cells.h"
#include "harness/run/csv.h"
#include "tests/support/error_of.h"
#include "tests/support/process_temp_dir.h"

namespace sahbench {
namespace {

std::filesystem::path temp_csv(const std::string& name) {
  const auto dir = test::process_temp_dir("ratio_stats");
  return dir / name;
}

using test::error_of;

TEST(RatioStats, SamplesParseInRoundOrder) {
  EXPECT_EQ(parse_samples("12.5;12.7;12.4"), (std::vector<double>{12.5, 12.7, 12.4}));
  EXPECT_EQ(parse_samples("3"), (std::vector<double>{3.0}));
  EXPECT_EQ(parse_samples("0;1e-3"), (std::vector<double>{0.0, 1e-3}));
  EXPECT_TRUE(parse_samples("").empty());
}

TEST(RatioStats, BadSamplesAreErrorsNamingTheValue) {
  EXPECT_NE(error_of([] { parse_samples("12.5;abc;12.4"); }).find("'abc' is not a number"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_samples("12.5;nan"); }).find("'nan' is not finite"), std::string::npos);
  EXPECT_NE(error_of([] { parse_samples("inf;1"); }).find("'inf' is not finite"), std::string::npos);
  EXPECT_NE(error_of([] { parse_samples("1;-2.5"); }).find("'-2.5' is negative"), std::string::npos);
  EXPECT_NE(error_of([] { parse_samples("1;;2"); }).find("'' is not a number"), std::string::npos);
  EXPECT_NE(error_of([] { parse_samples("1;2;"); }).find("'' is not a number"), std::string::npos);
  EXPECT_NE(error_of([] { parse_samples("1.5x"); }).find("'1.5x' is not a number"), std::string::npos);
  EXPECT_NE(error_of([] { parse_samples("1, 2"); }).find("'1, 2' is not a number"), std::string::npos);
}

// Rows written by hand as the runner writes them: samples in round order, the median beside them.
TEST(RatioStats, RowSamplesParseAndTheirMedianIsTheMedianColumn) {
  const auto path = temp_csv("samples.csv");
  std::filesystem::remove(path);
  {
    CsvWriter w(path, {"builder", "build_ms_median", "build_ms_samples", "trace_mrays_median",
                       "trace_mrays_samples", "notes"});
    w.append({{"builder", "a"},
              {"build_ms_median", "12.5000"},
              {"build_ms_samples", "12.7000;12.5000;12.4000"},
              {"trace_mrays_median", "3.0500"},
              {"trace_mrays_samples", "3.2000;2.9000;3.0000;3.1000"},
              {"notes", "a note\nover two lines"}});
    w.append({{"builder", "old"}, {"build_ms_median", "4.0000"}});  // a row without samples
    w.append({{"builder", "bad"},
              {"build_ms_median", "12.9000"},
              {"build_ms_samples", "12.7000;12.5000;12.4000"}});
    w.append({{"builder", "worse"}, {"build_ms_median", "1"}, {"build_ms_samples", "1;x"}});
  }
  const ResultFile file = read_result_file(path);
  ASSERT_EQ(file.rows.size(), 4u);
  // The first row's quoted note spans two lines, so the next row starts on line 4, not 3.
  EXPECT_EQ(file.lines, (std::vector<std::size_t>{2, 4, 5, 6}));
  EXPECT_EQ(file.where(1), path.string() + ":4");

  const auto build = timing_samples(file, 0, "build_ms");
  EXPECT_EQ(build, (std::vector<double>{12.7, 12.5, 12.4}));
  EXPECT_DOUBLE_EQ(median_of(build), *csv_number(file.rows[0], "build_ms_median"));
  const auto trace = timing_samples(file, 0, "trace_mrays");
  EXPECT_EQ(trace.size(), 4u);
  EXPECT_NEAR(median_of(trace), *csv_number(file.rows[0], "trace_mrays_median"), 1e-12);
  EXPECT_TRUE(timing_samples(file, 1, "build_ms").empty());

  const std::string off = error_of([&] { timing_samples(file, 2, "build_ms"); });
  EXPECT_NE(off.find(path.string() + ":5: column 'build_ms_samples'"), std::string::npos) << off;
  EXPECT_NE(off.find("12.5000 is not build_ms_median '12.9000'"), std::string::npos) << off;
  const std::string bad = error_of([&] { timing_samples(file, 3, "build_ms"); });
  EXPECT_NE(bad.find(path.string() + ":6: column 'build_ms_samples': sample 'x' is not a number"),
            std::string::npos)
      << bad;
}

TEST(RatioStats, RowsKeepTheirLinesPastBlankLinesAndQuotes) {
  const auto path = temp_csv("lines.csv");
  std::ofstream(path) << "a,b\n1,2\n\n\"x\"\"y\",\"p\nq\nr\"\n3,4\n\"\"\n5,6\npartial";
  const ResultFile file = read_result_file(path);
  ASSERT_EQ(file.rows.size(), 4u);
  EXPECT_EQ(file.lines, (std::vector<std::size_t>{2, 4, 7, 9}));
  EXPECT_EQ(file.rows[3].at("a"), "5");
}

TEST(RatioStats, CheckedNumbersTakeTheWholeField) {
  const auto path = temp_csv("numbers.csv");
  std::ofstream(path) << "sah_cost,threads\n38.5,2\n12abc,x\nnan,\n";
  const ResultFile file = read_result_file(path);
  EXPECT_EQ(checked_number(file, 0, "sah_cost"), 38.5);
  EXPECT_EQ(checked_integer(file, 0, "threads"), 2);
  EXPECT_EQ(checked_number(file, 0, "absent"), std::nullopt);
  EXPECT_NE(error_of([&] {
              checked_number(file, 1, "sah_cost");
            }).find(path.string() + ":3: column 'sah_cost': '12abc' is not a number"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              checked_number(file, 2, "sah_cost");
            }).find(":4: column 'sah_cost': 'nan' is not finite"),
            std::string::npos);
  EXPECT_NE(error_of([&] { checked_integer(file, 1, "threads"); }).find(":3: column 'threads': 'x'"),
            std::string::npos);
  EXPECT_NE(error_of([&] { checked_integer(file, 2, "threads"); }).find(":4: column 'threads': ''"),
            std::string::npos);
}

TEST(RatioStats, TQuantilesMatchTheTables) {
  // Two-sided 95% quantiles of Student's t (R: qt(0.975, df)).
  EXPECT_NEAR(t_quantile_975(1), 12.706, 1e-3);
  EXPECT_NEAR(t_quantile_975(2), 4.303, 1e-3);
  EXPECT_NEAR(t_quantile_975(4), 2.776, 1e-3);
  EXPECT_NEAR(t_quantile_975(10), 2.228, 1e-3);
  EXPECT_NEAR(t_quantile_975(29), 2.045, 1e-3);
  EXPECT_NEAR(t_quantile_975(30), 2.042, 1e-3);
  // Beyond the table, the Cornish-Fisher expansion.
  EXPECT_NEAR(t_quantile_975(31), 2.0395, 1e-4);
  EXPECT_NEAR(t_quantile_975(40), 2.0211, 1e-4);
  EXPECT_NEAR(t_quantile_975(60), 2.0003, 1e-4);
  EXPECT_NEAR(t_quantile_975(100), 1.984, 1e-3);
  EXPECT_NEAR(t_quantile_975(120), 1.9799, 1e-4);
  EXPECT_NEAR(t_quantile_975(1e6), 1.95996, 1e-4);
  // Welch's fractional df below the table's end is rounded down (a wider interval).
  EXPECT_EQ(t_quantile_975(10.7), t_quantile_975(10));
  for (double df = 1; df < 200; ++df) EXPECT_GT(t_quantile_975(df), t_quantile_975(df + 1)) << df;
  EXPECT_THROW(t_quantile_975(0.5), Error);
  EXPECT_THROW(t_quantile_975(std::nan("")), Error);
}

TEST(RatioStats, PairedRatioIsTheGeometricMeanWithAStudentInterval) {
  // log ratios ln 2 and ln 4: mean 1.5 ln 2, sd ln 2 / sqrt 2, half width t(1) * sd / sqrt 2.
  const std::vector<double> ours = {2, 4}, anchor = {1, 1};
  const RatioInterval r = paired_ratio(ours, anchor);
  // Lists of different lengths were not taken in the same rounds.
  EXPECT_NE(error_of([] {
              paired_ratio(std::vector<double>{2, 4, 9}, std::vector<double>{1, 1});
            }).find("3 samples against the anchor's 2"),
            std::string::npos);
  EXPECT_EQ(r.n, 2);
  EXPECT_NEAR(r.estimate, std::pow(2.0, 1.5), 1e-12);
  const double half = 12.7062047 * std::log(2.0) / 2.0;
  ASSERT_TRUE(r.has_interval());
  EXPECT_NEAR(*r.lo, std::exp(1.5 * std::log(2.0) - half), 1e-6);
  EXPECT_NEAR(*r.hi, std::exp(1.5 * std::log(2.0) + half), 1e-3);
  // Embree's sample r moves with ours: the same slow round in both cancels.
  const RatioInterval drift =
      paired_ratio(std::vector<double>{1.2, 2.4, 0.6}, std::vector<double>{1, 2, 0.5});
  EXPECT_NEAR(drift.estimate, 1.2, 1e-12);
  EXPECT_NEAR(*drift.lo, 1.2, 1e-9);
  EXPECT_NEAR(*drift.hi, 1.2, 1e-9);

  const RatioInterval one = paired_ratio(std::vector<double>{1.08}, std::vector<double>{1.0});
  EXPECT_FALSE(one.has_interval());
  EXPECT_EQ(format_ratio(one), "1.08 [n=1]");
  EXPECT_NE(error_of([] {
              paired_ratio(std::vector<double>{1, 0}, std::vector<double>{1, 1});
            }).find("round 2"),
            std::string::npos);
  EXPECT_THROW(paired_ratio(std::vector<double>{}, std::vector<double>{1}), Error);
}

TEST(RatioStats, FormatAndVerdict) {
  RatioInterval r;
  r.estimate = 1.0812;
  r.lo = 1.0291;
  r.hi = 1.1234;
  r.n = 5;
  EXPECT_EQ(format_ratio(r), "1.08 [1.03, 1.12]");
  EXPECT_EQ(format_ratio(r, 3), "1.081 [1.029, 1.123]");
  EXPECT_EQ(verdict(r), Verdict::kAhead);
  EXPECT_EQ(verdict(r, false), Verdict::kBehind);  // a time 8% above Embree's is behind
  r.lo = 0.98;
  EXPECT_EQ(verdict(r), Verdict::kWithinNoise);
  r.lo = 0.8;
  r.hi = 0.9;
  EXPECT_EQ(verdict(r), Verdict::kBehind);
  EXPECT_EQ(verdict(r, false), Verdict::kAhead);
  EXPECT_EQ(verdict(paired_ratio(std::vector<double>{2.0}, std::vector<double>{1.0})), Verdict::kWithinNoise);
  EXPECT_EQ(format_ratio(ratio_of_medians(3.0, 2.0)), "1.50 [medians]");
  EXPECT_THROW(ratio_of_medians(1.0, 0.0), Error);
}

// Rounds of a cell and its anchor: a drift of the machine common to both in each round (up to 30%, which
// pairing cancels), and lognormal noise of each sample's own.
struct Rounds {
  std::vector<double> ours, anchor;
};
Rounds simulate(std::mt19937_64& rng, int rounds, double true_ratio, double sigma) {
  std::normal_distribution<double> noise(0.0, sigma);
  std::uniform_real_distribution<double> drift(0.7, 1.3);
  Rounds r;
  for (int i = 0; i < rounds; ++i) {
    const double machine = drift(rng);
    r.anchor.push_back(4.0 * machine * std::exp(noise(rng)));
    r.ours.push_back(4.0 * true_ratio * machine * std::exp(noise(rng)));
  }
  return r;
}

TEST(RatioStats, IntervalCoversTheTrueRatioAbout95PercentOfTheTime) {
  std::mt19937_64 rng(20261201);
  constexpr int kTrials = 2000;
  constexpr double kTrue = 1.2;
  int covered = 0;
  for (int t = 0; t < kTrials; ++t) {
    const Rounds s = simulate(rng, 8, kTrue, 0.05);
    const RatioInterval r = paired_ratio(s.ours, s.anchor);
    covered += *r.lo <= kTrue && kTrue <= *r.hi;
  }
  const double coverage = static_cast<double>(covered) / kTrials;
  EXPECT_GT(coverage, 0.92);
  EXPECT_LT(coverage, 0.98);
}

TEST(RatioStats, IntervalNarrowsWithMoreRounds) {
  std::mt19937_64 rng(7);
  auto mean_width = [&](int rounds) {
    double width = 0.0;
    for (int t = 0; t < 200; ++t) {
      const Rounds s = simulate(rng, rounds, 1.2, 0.05);
      const RatioInterval r = paired_ratio(s.ours, s.anchor);
      width += std::log(*r.hi / *r.lo);
    }
    return width / 200;
  };
  const double w5 = mean_width(5), w20 = mean_width(20), w80 = mean_width(80);
  EXPECT_GT(w5, w20);
  EXPECT_GT(w20, w80);
  // The width goes as t(n - 1) / sqrt(n): four times the rounds, about half the width.
  EXPECT_GT(w20 / w80, 1.7);
  EXPECT_LT(w20 / w80, 2.4);
}

TEST(RatioStats, ChangeBetweenRunsCoversTheTrueChange) {
  std::mt19937_64 rng(11);
  constexpr int kTrials = 2000;
  constexpr double kChange = 1.1;
  int covered = 0;
  for (int t = 0; t < kTrials; ++t) {
    // Unequal rounds and noise in the two runs: Welch's case.
    const Rounds b = simulate(rng, 6, 1.2, 0.03), n = simulate(rng, 12, 1.2 * kChange, 0.08);
    const RatioInterval c = ratio_change(paired_ratio(b.ours, b.anchor), paired_ratio(n.ours, n.anchor));
    covered += *c.lo <= kChange && kChange <= *c.hi;
  }
  const double coverage = static_cast<double>(covered) / kTrials;
  EXPECT_GT(coverage, 0.92);
  EXPECT_LT(coverage, 0.98);
}

TEST(RatioStats, ChangeUsesWelchSatterthwaiteDegreesOfFreedom) {
  RatioInterval base, now;
  base.n = 10;
  base.sd_log = 1.0;
  base.mean_log = 0.1;
  now.n = 20;
  now.sd_log = 2.0;
  now.mean_log = 0.3;
  const RatioInterval c = ratio_change(base, now);
  // (0.1 + 0.2)^2 / (0.1^2 / 9 + 0.2^2 / 19)
  EXPECT_NEAR(c.df, 0.09 / (0.01 / 9 + 0.04 / 19), 1e-9);
  EXPECT_NEAR(c.estimate, std::exp(0.2), 1e-12);
  EXPECT_NEAR(std::log(*c.hi) - 0.2, t_quantile_975(27) * std::sqrt(0.3), 1e-9);  // df 27.98 rounds down
  base.n = 1;
  EXPECT_FALSE(ratio_change(base, now).has_interval());
}

TEST(RatioStats, PValueOfNoChangeIsStudentsTwoSidedTail) {
  RatioInterval change;
  change.n = 11;
  change.df = 10.0;
  change.sd_log = 0.5;
  change.mean_log = 1.0;  // t = 2
  change.lo = 0.9;
  change.hi = 8.0;
  // Two-sided P(|T| >= 2) at 10 degrees of freedom: 0.07339 (R: 2 * pt(-2, 10)).
  EXPECT_NEAR(p_value_of_no_change(change), 0.073388, 1e-5);
  change.mean_log = -1.0;
  EXPECT_NEAR(p_value_of_no_change(change), 0.073388, 1e-5);
  change.df = 10.7;  // Welch's fractional df, taken at its floor as the printed interval takes it
  EXPECT_NEAR(p_value_of_no_change(change), 0.073388, 1e-5);
  change.df = 10.0;
  // At the edge of the 95% interval the p-value is 0.05.
  change.mean_log = t_quantile_975(10.0) * change.sd_log;
  EXPECT_NEAR(p_value_of_no_change(change), 0.05, 1e-6);
  EXPECT_EQ(p_value_of_no_change(RatioInterval{}), 1.0) << "no interval, no evidence";
}

// Holm 1979's step-down: sorted p-values are held to alpha / m, alpha / (m - 1), ..., and the first
// that fails stops the rejections.
TEST(RatioStats, HolmRejectsStepDownAndAdjustsMonotonically) {
  const std::vector<double> p = {0.04, 0.001, 0.03, 0.012};
  const HolmResult h = holm(p, 0.05);
  // Sorted: 0.001 <= 0.05/4, 0.012 <= 0.05/3, 0.03 > 0.05/2: stop; 0.04 is not rejected either.
  EXPECT_EQ(h.rejected, (std::vector<bool>{false, true, false, true}));
  EXPECT_NEAR(h.adjusted[1], 0.004, 1e-12);
  EXPECT_NEAR(h.adjusted[3], 0.036, 1e-12);
  EXPECT_NEAR(h.adjusted[2], 0.06, 1e-12);
  EXPECT_NEAR(h.adjusted[0], 0.06, 1e-12) << "never below an earlier adjusted p-value";
  EXPECT_TRUE(holm(std::vector<double>{}).rejected.empty());
  // Each p-value alone at 0.049 is below 0.05, but not twenty of them together.
  const HolmResult many = holm(std::vector<double>(20, 0.049));
  EXPECT_EQ(std::count(many.rejected.begin(), many.rejected.end(), true), 0);
}

}  // namespace
}  // namespace sahbench
