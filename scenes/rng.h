#pragma once
// Deterministic random numbers for the procedural generators: SplitMix64 (Steele, Lea and Flood,
// "Fast Splittable Pseudorandom Number Generators", OOPSLA 2014), with its own mapping to [0, 1).
// The standard distributions are not used because their output differs between standard libraries.
//
// Each generated item (triangle, object, lattice point) gets its own generator derived from
// (seed, item index), so the result does not depend on the order or thread in which items are made.

#include <cmath>
#include <cstdint>

#include "core/vec3.h"

namespace sahbench {

/// The SplitMix64 output function: a bijective 64-bit mixer.
constexpr uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

class SplitMix64 {
 public:
  explicit constexpr SplitMix64(uint64_t state) : state_(state) {}

  /// Generator for item `item` of the stream `seed`: both are mixed so that neighbouring items (and
  /// neighbouring seeds) start far apart in the sequence.
  static constexpr SplitMix64 for_item(uint64_t seed, uint64_t item) {
    return SplitMix64(mix64(mix64(seed ^ kSeedSalt) ^ (item * kGamma)));
  }

  constexpr uint64_t next() {
    state_ += kGamma;
    return mix64(state_);
  }

  /// Uniform in [0, 1): the top 53 bits as a double, exact and identical on every platform.
  constexpr double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  constexpr double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

  /// Uniform direction, by rejection from the cube (no trigonometry, so bit-identical everywhere).
  Vec3 unit_vector() {
    for (;;) {
      const double x = uniform(-1.0, 1.0), y = uniform(-1.0, 1.0), z = uniform(-1.0, 1.0);
      const double len2 = x * x + y * y + z * z;
      // The lower bound keeps the normalisation well conditioned; it rejects a 1e-9 fraction.
      if (len2 <= 1.0 && len2 > 1e-6) {
        const double inv = 1.0 / std::sqrt(len2);
        return {static_cast<float>(x * inv), static_cast<float>(y * inv), static_cast<float>(z * inv)};
      }
    }
  }

 private:
  static constexpr uint64_t kGamma = 0x9E3779B97F4A7C15ull;     // 2^64 / golden ratio, SplitMix64's step
  static constexpr uint64_t kSeedSalt = 0x5AB8E7C4D1F20369ull;  // arbitrary: keeps seed 0 from mixing to 0

  uint64_t state_;
};

}  // namespace sahbench
