#pragma once
// The order in which one round of interleaved repetitions takes its cells (builds or traces): a fresh
// shuffle per round, so that no cell always follows the same neighbour and a cache or frequency effect
// of the cell before falls on every cell alike. Seeded, so a run's order can be computed again from its
// CSV (the order_seed column), and written out here rather than with std::shuffle, whose algorithm the
// standard leaves to each library.

#include <cstdint>
#include <numeric>
#include <string_view>
#include <vector>

namespace sahbench {

/// SplitMix64 (Steele, Lea and Flood 2014): a full-period 64-bit generator, enough to shuffle by.
inline uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

/// The seed of one group of interleaved cells (a scene and thread count, and the phase: "build" or
/// "trace"), from the run's seed.
inline uint64_t order_seed(uint64_t run_seed, std::string_view scene, int threads, std::string_view phase) {
  uint64_t h = 14695981039346656037ull ^ run_seed;  // FNV-1a over the scene and phase names
  for (const char c : scene) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ull;
  for (const char c : phase) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ull;
  return h ^ (static_cast<uint64_t>(threads) << 40);
}

/// The cell indices 0..n-1 in the order of round `round` (Fisher–Yates over SplitMix64 seeded with
/// `seed` and the round; the modulo's bias is below 2^-40 for any n a run has).
inline std::vector<std::size_t> round_order(uint64_t seed, std::size_t n, int round) {
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  uint64_t state = seed + 0x632b'e59b'd9b4'e019ull * static_cast<uint64_t>(round + 1);
  for (std::size_t i = n; i > 1; --i) std::swap(order[i - 1], order[splitmix64(state) % i]);
  return order;
}

}  // namespace sahbench
