#pragma once
// Repetition statistics: the harness quotes medians with their spread, never single timings.

#include <algorithm>
#include <chrono>
#include <vector>

namespace sahbench {

/// The median, extremes and count of a cell's repetitions, and the samples themselves in the order they
/// were taken (round r of every cell of a scene and thread count is its r-th sample), so that ratios can
/// be paired by round.
struct TimingSummary {
  double median = 0.0, min = 0.0, max = 0.0;
  std::size_t reps = 0;
  std::vector<double> samples;
};

inline TimingSummary summarize(std::vector<double> samples) {
  TimingSummary s;
  s.reps = samples.size();
  s.samples = samples;
  if (samples.empty()) return s;
  std::sort(samples.begin(), samples.end());
  const std::size_t n = samples.size();
  s.median = n % 2 ? samples[n / 2] : 0.5 * (samples[n / 2 - 1] + samples[n / 2]);
  s.min = samples.front();
  s.max = samples.back();
  return s;
}

/// Milliseconds `f` takes.
template <class F>
double time_ms(F&& f) {
  const auto start = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

/// Times `trace` (one pass of a kernel over `rays` rays): `warmup` untimed passes, then `reps` timed
/// ones; the summary is of Mrays/s, one sample per pass.
template <class Trace>
TimingSummary time_trace(int warmup, int reps, std::size_t rays, Trace&& trace) {
  for (int w = 0; w < warmup; ++w) trace();
  std::vector<double> mrays;
  for (int r = 0; r < reps; ++r) mrays.push_back(static_cast<double>(rays) / (time_ms(trace) * 1e3));
  return summarize(mrays);
}

}  // namespace sahbench
