#include "builders/radix_sort.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

namespace sahbench {
namespace {

// Eight-bit digits: the 256 output streams of a scatter stay within the L1 cache's lines and the TLB's
// reach, where eleven-bit digits (one pass fewer for 30-bit keys) thrash both on a 2-core Zen.
constexpr uint32_t kDigitBits = 8;
constexpr uint32_t kDigits = 1u << kDigitBits;
// Elements per chunk: a chunk's counting and scattering is a task of some tens of microseconds. Fixed,
// so the chunks (and the tasks' work) do not depend on the thread count; the order never does.
constexpr std::size_t kChunk = std::size_t{1} << 15;

using Counts = std::array<uint32_t, kDigits>;

template <class Key>
uint32_t digit(Key key, uint32_t shift) {
  return static_cast<uint32_t>(key >> shift) & (kDigits - 1);
}

// One stable counting pass on the digit at `shift`: from (keys, values) into (out_keys, out_values).
// Returns false, writing nothing, when every key has the same digit there (the pass would copy).
template <class Key>
bool sort_pass(const Key* keys, const uint32_t* values, Key* out_keys, uint32_t* out_values, std::size_t n,
               uint32_t shift, std::vector<Counts>& offsets) {
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  offsets.resize(chunks);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    Counts& counts = offsets[c];
    counts.fill(0);
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) ++counts[digit(keys[i], shift)];
  });
  // Output positions: digit by digit, and within a digit chunk by chunk, which keeps the sort stable.
  uint32_t position = 0;
  for (uint32_t d = 0; d < kDigits; ++d) {
    uint32_t total = 0;
    for (std::size_t c = 0; c < chunks; ++c) {
      const uint32_t count = offsets[c][d];
      offsets[c][d] = position + total;
      total += count;
    }
    if (total == n) return false;
    position += total;
  }
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    Counts& next = offsets[c];
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const uint32_t at = next[digit(keys[i], shift)]++;
      out_keys[at] = keys[i];
      out_values[at] = values[i];
    }
  });
  return true;
}

}  // namespace

template <class Key>
void radix_sort_pairs(HugePageArray<Key>& keys, HugePageArray<uint32_t>& values,
                      HugePageArray<Key>& key_scratch, HugePageArray<uint32_t>& value_scratch,
                      uint32_t key_bits) {
  const std::size_t n = keys.size();
  std::vector<Counts> offsets;
  for (uint32_t shift = 0; shift < key_bits; shift += kDigitBits) {
    if (sort_pass(keys.data(), values.data(), key_scratch.data(), value_scratch.data(), n, shift, offsets)) {
      std::swap(keys, key_scratch);
      std::swap(values, value_scratch);
    }
  }
}

template void radix_sort_pairs<uint32_t>(HugePageArray<uint32_t>&, HugePageArray<uint32_t>&,
                                         HugePageArray<uint32_t>&, HugePageArray<uint32_t>&, uint32_t);
template void radix_sort_pairs<uint64_t>(HugePageArray<uint64_t>&, HugePageArray<uint32_t>&,
                                         HugePageArray<uint64_t>&, HugePageArray<uint32_t>&, uint32_t);

}  // namespace sahbench
