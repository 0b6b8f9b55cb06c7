// Morton codes and the parallel radix sort under the linear builders: codes against a bit-by-bit
// interleave, the sort against std::stable_sort, and the sorted order of primitives.

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

#include "builders/morton.h"
#include "builders/radix_sort.h"
#include "core/build_input.h"
#include "tests/support/test_scenes.h"

namespace sahbench {
namespace {

// Bit i of x at 3i + 2, of y at 3i + 1, of z at 3i, one bit at a time.
uint64_t interleave(uint32_t x, uint32_t y, uint32_t z, uint32_t bits) {
  uint64_t code = 0;
  for (uint32_t i = 0; i < bits; ++i) {
    code |= uint64_t{(x >> i) & 1u} << (3 * i + 2);
    code |= uint64_t{(y >> i) & 1u} << (3 * i + 1);
    code |= uint64_t{(z >> i) & 1u} << (3 * i);
  }
  return code;
}

TEST(Morton, CodesInterleaveTheBitsOfEachAxis) {
  std::mt19937 rng(5);
  for (int k = 0; k < 10000; ++k) {
    const uint32_t x = rng(), y = rng(), z = rng();
    EXPECT_EQ(morton30(x, y, z), interleave(x & 0x3FFu, y & 0x3FFu, z & 0x3FFu, 10));
    EXPECT_EQ(morton63(x, y, z), interleave(x & 0x1FFFFFu, y & 0x1FFFFFu, z & 0x1FFFFFu, 21));
  }
  EXPECT_EQ(morton30(0x3FF, 0x3FF, 0x3FF), (1u << 30) - 1);
  EXPECT_EQ(morton63(0x1FFFFF, 0x1FFFFF, 0x1FFFFF), (uint64_t{1} << 63) - 1);
}

template <class Key>
void expect_sorts_like_stable_sort(std::size_t n, uint32_t key_bits, Key mask, uint64_t seed) {
  std::mt19937_64 rng(seed);
  HugePageArray<Key> keys(n), key_scratch(n);
  HugePageArray<uint32_t> values(n), value_scratch(n);
  std::vector<std::pair<Key, uint32_t>> expected(n);
  for (std::size_t i = 0; i < n; ++i) {
    // Few distinct high bits, so that equal keys are common and stability is tested.
    keys[i] = static_cast<Key>(rng()) & mask & ~Key{0xF0};
    values[i] = static_cast<uint32_t>(i);
    expected[i] = {keys[i], values[i]};
  }
  std::stable_sort(expected.begin(), expected.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  radix_sort_pairs(keys, values, key_scratch, value_scratch, key_bits);
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(keys[i], expected[i].first) << i;
    ASSERT_EQ(values[i], expected[i].second) << i;
  }
}

TEST(RadixSort, SortsStablyLikeStdStableSort) {
  // Sizes sorted in the cache at once, and sizes sorted by the top digit first (over 2^17), on one and
  // on two threads.
  for (int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    for (std::size_t n : {0u, 1u, 2u, 1000u, 32768u, 100001u, 400000u}) {
      SCOPED_TRACE(n);
      expect_sorts_like_stable_sort<uint32_t>(n, 30, (1u << 30) - 1, n + 1);
      expect_sorts_like_stable_sort<uint64_t>(n, 63, (uint64_t{1} << 63) - 1, n + 2);
    }
    // Every key in one bucket of the top digit: the bucket is too large to sort in the cache.
    expect_sorts_like_stable_sort<uint32_t>(400000, 30, (1u << 19) - 1, 3);
    expect_sorts_like_stable_sort<uint64_t>(400000, 63, (uint64_t{1} << 40) - 1, 4);
    // Four buckets of the top digit of about 100k keys each, three of them starting inside the array:
    // each is sorted in the cache, on two threads by the parallel passes.
    expect_sorts_like_stable_sort<uint32_t>(400000, 30, (1u << 21) - 1, 5);
    expect_sorts_like_stable_sort<uint64_t>(400000, 63, (uint64_t{1} << 54) - 1, 6);
  }
}

TEST(RadixSort, KeysThatAgreeOnADigitSkipItsPass) {
  // All keys equal in their low byte and in two of the middle ones: those passes would only copy.
  const std::size_t n = 5000;
  HugePageArray<uint32_t> keys(n), key_scratch(n), values(n), value_scratch(n);
  for (std::size_t i = 0; i < n; ++i)
    keys[i] = static_cast<uint32_t>(((n - i) % 7) << 24 | 0x5A), values[i] = i;
  radix_sort_pairs(keys, values, key_scratch, value_scratch, 30);
  for (std::size_t i = 1; i < n; ++i) {
    ASSERT_LE(keys[i - 1], keys[i]);
    if (keys[i - 1] == keys[i]) {
      ASSERT_LT(values[i - 1], values[i]);
    }
  }
}

template <class Code>
void expect_sorted_by_code(const std::vector<Triangle>& tris) {
  const BuildInput input = BuildInput::from_triangles(tris);
  const MortonOrder<Code> order = sort_by_morton<Code>(input.bounds.span());
  ASSERT_EQ(order.ids.size(), tris.size());
  std::vector<uint32_t> seen(order.ids.begin(), order.ids.end());
  std::sort(seen.begin(), seen.end());
  std::vector<uint32_t> all(tris.size());
  std::iota(all.begin(), all.end(), 0u);
  EXPECT_EQ(seen, all);
  for (std::size_t i = 1; i < tris.size(); ++i) {
    ASSERT_LE(order.codes[i - 1], order.codes[i]);
    if (order.codes[i - 1] == order.codes[i]) {
      ASSERT_LT(order.ids[i - 1], order.ids[i]);
    }
  }
}

TEST(Morton, PrimitivesComeSortedByCodeThenIndex) {
  expect_sorted_by_code<uint32_t>(test::random_triangles(50000, 3));
  expect_sorted_by_code<uint64_t>(test::random_triangles(50000, 4));
  // Identical triangles: one code, the primitives in index order.
  expect_sorted_by_code<uint32_t>(std::vector<Triangle>(3000, Triangle{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
}

TEST(Morton, CellsAreCubesOverTheCentresBox) {
  // Centres spanning 1024 units in x and 1 in y: the grid's cells are one unit wide on every axis, so
  // y takes only cells 0 and 1 while x takes all 1024.
  std::vector<Triangle> tris;
  for (int i = 0; i <= 1024; ++i) {
    const float x = static_cast<float>(i), y = static_cast<float>(i % 2);
    tris.push_back({{x - 0.25f, y - 0.25f, 0}, {x + 0.25f, y + 0.25f, 0}, {x, y, 0}});
  }
  const BuildInput input = BuildInput::from_triangles(tris);
  const MortonOrder<uint32_t> order = sort_by_morton<uint32_t>(input.bounds.span());
  for (std::size_t k = 0; k < tris.size(); ++k) {
    const uint32_t i = order.ids[k];
    const uint32_t x = std::min(i, 1023u), y = i % 2;
    EXPECT_EQ(order.codes[k], morton30(x, y, 0)) << i;
  }
}

}  // namespace
}  // namespace sahbench
