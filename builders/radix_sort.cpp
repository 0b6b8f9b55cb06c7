#include "builders/radix_sort.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include "core/threads.h"

namespace sahbench {
namespace {

// The top digit is sorted first, in parallel over the whole array; each of its buckets is then small
// enough to be sorted by the remaining digits in the cache, least significant first (the hybrid of
// MSD and LSD radix sorts: the 1M-triangle terrain's and Sponza's 30-bit codes fill some 280 buckets of
// at most 14K). Eleven bits for the top digit (2048 buckets), ten for the others, so that the 19 bits
// below it take two passes; on the terrain that sorted 10-20% faster than eight-bit digits.
constexpr uint32_t kTopBits = 11;
constexpr uint32_t kDigitBits = 10;
// Elements per chunk of the parallel passes over arrays larger than the cache: some tens of microseconds
// of work. The sorted order never depends on the chunks (the sort is stable).
constexpr std::size_t kChunk = std::size_t{1} << 15;
// Buckets of more elements than this are sorted by the parallel passes too (clustered codes).
constexpr std::size_t kLocalLimit = std::size_t{1} << 17;

template <class Key>
uint32_t digit(Key key, uint32_t shift, uint32_t mask) {
  return static_cast<uint32_t>(key >> shift) & mask;
}

template <class Key>
struct Pairs {
  Key* keys;
  uint32_t* values;
};

// One stable counting pass over [begin, end) on the digit of `bits` bits at `shift`, from `in` to
// `out` (same positions), in parallel over fixed chunks. Returns false, writing nothing, where every key
// has the same digit (the pass would copy). `first_of` receives each digit's first position. The chunks
// are `chunk` elements long (fixed by the caller; the order never depends on them).
template <class Key>
bool parallel_pass(Pairs<Key> in, Pairs<Key> out, std::size_t begin, std::size_t end, uint32_t shift,
                   uint32_t bits, std::vector<uint32_t>* first_of = nullptr, std::size_t chunk = kChunk) {
  const uint32_t digits = 1u << bits, mask = digits - 1;
  const std::size_t n = end - begin, chunks = (n + chunk - 1) / chunk;
  std::vector<uint32_t> offsets(chunks * digits);  // [chunk][digit]
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    uint32_t* counts = &offsets[c * digits];
    const std::size_t last = std::min(end, begin + (c + 1) * chunk);
    for (std::size_t i = begin + c * chunk; i < last; ++i) ++counts[digit(in.keys[i], shift, mask)];
  });
  // Output positions: digit by digit, and within a digit chunk by chunk, which keeps the sort stable.
  auto position = static_cast<uint32_t>(begin);
  if (first_of) first_of->assign(digits + 1, 0);
  for (uint32_t d = 0; d < digits; ++d) {
    if (first_of) (*first_of)[d] = position;
    uint32_t total = 0;
    for (std::size_t c = 0; c < chunks; ++c) {
      const uint32_t count = offsets[c * digits + d];
      offsets[c * digits + d] = position + total;
      total += count;
    }
    if (total == n && !first_of) return false;
    position += total;
  }
  if (first_of) (*first_of)[digits] = position;
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    uint32_t* next = &offsets[c * digits];
    const std::size_t last = std::min(end, begin + (c + 1) * chunk);
    for (std::size_t i = begin + c * chunk; i < last; ++i) {
      const uint32_t at = next[digit(in.keys[i], shift, mask)]++;
      out.keys[at] = in.keys[i];
      out.values[at] = in.values[i];
    }
  });
  return true;
}

// Every digit's counts for a serial sort of [begin, end) by kPasses digits of kBits, in one read of the
// keys: a stable pass leaves each digit's counts as they were. The number of passes is a constant so
// that the loop over them unrolls; a loop over a variable count was slower.
template <uint32_t kBits, uint32_t kPasses, class Key, class Counts>
void count_digits(const Key* keys, std::size_t begin, std::size_t end, Counts& counts) {
  for (std::size_t i = begin; i < end; ++i) {
    const Key key = keys[i];
    for (uint32_t p = 0; p < kPasses; ++p) ++counts[p][digit(key, p * kBits, (1u << kBits) - 1)];
  }
}

// count_digits for `passes` (1 to sizeof...(P)) known only at run time.
template <uint32_t kBits, class Key, class Counts, uint32_t... P>
void count_digits(uint32_t passes, const Key* keys, std::size_t begin, std::size_t end, Counts& counts,
                  std::integer_sequence<uint32_t, P...>) {
  ((passes == P + 1 ? count_digits<kBits, P + 1>(keys, begin, end, counts) : void()), ...);
}

// Sorts [begin, end) of `a` by the bits below `top_shift` in the cache, serially, least significant
// digit of kBits first, with `b` as working space over the same positions. Returns true where the
// result is in `a`, false where it is in `b`.
template <uint32_t kBits, class Key>
bool sort_serial(Pairs<Key> a, Pairs<Key> b, std::size_t begin, std::size_t end, uint32_t top_shift) {
  constexpr uint32_t kMaxPasses = (8 * sizeof(Key) + kBits - 1) / kBits;
  const uint32_t passes = (top_shift + kBits - 1) / kBits;
  std::array<std::array<uint32_t, 1u << kBits>, kMaxPasses> counts;
  for (uint32_t p = 0; p < passes; ++p) counts[p].fill(0);
  count_digits<kBits>(passes, a.keys, begin, end, counts, std::make_integer_sequence<uint32_t, kMaxPasses>());
  bool in_a = true;
  for (uint32_t p = 0; p < passes; ++p) {
    std::array<uint32_t, 1u << kBits>& next = counts[p];
    if (*std::max_element(next.begin(), next.end()) == end - begin) continue;  // one digit: nothing to move
    auto position = static_cast<uint32_t>(begin);
    for (uint32_t& count : next) position += std::exchange(count, position);
    const Pairs<Key> in = in_a ? a : b, out = in_a ? b : a;
    const uint32_t shift = p * kBits;
    for (std::size_t i = begin; i < end; ++i) {
      const uint32_t at = next[digit(in.keys[i], shift, (1u << kBits) - 1)]++;
      out.keys[at] = in.keys[i];
      out.values[at] = in.values[i];
    }
    in_a = !in_a;
  }
  return in_a;
}

// Sorts [begin, end) of `a` by the bits below `top_shift`, least significant digit first, with `b` as
// working space over the same positions: by the parallel passes where the range is large, or where more
// than one thread may run and it is large enough to share, serially otherwise. Returns true where the
// result is in `a`, false where it is in `b`.
template <class Key>
bool sort_low_digits(Pairs<Key> a, Pairs<Key> b, std::size_t begin, std::size_t end, uint32_t top_shift) {
  const std::size_t n = end - begin;
  if (n < 2) return true;
  const int threads = n >= 2 * kChunk ? caller_threads() : 1;
  if (n > kLocalLimit || threads > 1) {
    // A range held in the cache in one chunk per thread: each chunk writes a slice of every digit's
    // output, and neighbouring slices share a cache line, so fewer chunks share fewer (on 100k codes at
    // 2 threads, 0.76 ms for the three passes in 2 chunks against 0.86 in 4).
    const std::size_t chunk = n > kLocalLimit ? kChunk : (n + threads - 1) / threads;
    bool in_a = true;
    for (uint32_t shift = 0; shift < top_shift; shift += kDigitBits) {
      const Pairs<Key> in = in_a ? a : b, out = in_a ? b : a;
      if (parallel_pass(in, out, begin, end, shift, std::min(kDigitBits, top_shift - shift), nullptr, chunk))
        in_a = !in_a;
    }
    return in_a;
  }
  return sort_serial<kDigitBits>(a, b, begin, end, top_shift);
}

// Copies [begin, end) of `from` to `to`.
template <class Key>
void copy(Pairs<Key> from, Pairs<Key> to, std::size_t begin, std::size_t end) {
  std::memcpy(to.keys + begin, from.keys + begin, (end - begin) * sizeof(Key));
  std::memcpy(to.values + begin, from.values + begin, (end - begin) * sizeof(uint32_t));
}

}  // namespace

template <class Key>
void radix_sort_pairs(HugePageArray<Key>& keys, HugePageArray<uint32_t>& values,
                      HugePageArray<Key>& key_scratch, HugePageArray<uint32_t>& value_scratch,
                      uint32_t key_bits) {
  const std::size_t n = keys.size();
  const Pairs<Key> a{keys.data(), values.data()}, b{key_scratch.data(), value_scratch.data()};
  if (key_bits <= kTopBits || n <= kLocalLimit) {
    if (!sort_low_digits(a, b, 0, n, key_bits)) copy(b, a, 0, n);
    return;
  }
  // The top digit into the scratch arrays, then every bucket back into the caller's by the low digits.
  const uint32_t top_shift = key_bits - kTopBits;
  std::vector<uint32_t> first_of;
  parallel_pass(a, b, 0, n, top_shift, kTopBits, &first_of);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, 1u << kTopBits, 1), [&](const auto& r) {
    for (uint32_t d = r.begin(); d != r.end(); ++d) {
      const std::size_t begin = first_of[d], end = first_of[d + 1];
      if (sort_low_digits(b, a, begin, end, top_shift)) copy(b, a, begin, end);
    }
  });
}

template void radix_sort_pairs<uint32_t>(HugePageArray<uint32_t>&, HugePageArray<uint32_t>&,
                                         HugePageArray<uint32_t>&, HugePageArray<uint32_t>&, uint32_t);
template void radix_sort_pairs<uint64_t>(HugePageArray<uint64_t>&, HugePageArray<uint32_t>&,
                                         HugePageArray<uint64_t>&, HugePageArray<uint32_t>&, uint32_t);

}  // namespace sahbench
