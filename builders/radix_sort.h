#pragma once
// Parallel radix sort of keys with 32-bit values, the sort that linear BVH builders use on Morton codes
// (Lauterbach et al. 2009, "Fast BVH Construction on GPUs"; Karras 2012). The most significant digit is
// sorted first, over the whole array, by counting fixed chunks in parallel, turning the counts into each
// chunk's output positions and scattering the chunks in parallel; then each of its buckets, in parallel, by
// the other digits, least significant first, within the cache. Every pass is stable, so the whole sort is:
// equal keys keep their input order, and the result does not depend on the thread count or the chunking.

#include <cstdint>

#include "core/huge_pages.h"

namespace sahbench {

/// Sorts `keys` by their low `key_bits` bits (higher bits must be zero), moving `values` along, stably.
/// `key_scratch` and `value_scratch` are working space of the same sizes, and the arrays are swapped
/// with them where that saves a copy: the result is in `keys` and `values` on return.
template <class Key>
void radix_sort_pairs(HugePageArray<Key>& keys, HugePageArray<uint32_t>& values,
                      HugePageArray<Key>& key_scratch, HugePageArray<uint32_t>& value_scratch,
                      uint32_t key_bits);

extern template void radix_sort_pairs<uint32_t>(HugePageArray<uint32_t>&, HugePageArray<uint32_t>&,
                                                HugePageArray<uint32_t>&, HugePageArray<uint32_t>&, uint32_t);
extern template void radix_sort_pairs<uint64_t>(HugePageArray<uint64_t>&, HugePageArray<uint32_t>&,
                                                HugePageArray<uint64_t>&, HugePageArray<uint32_t>&, uint32_t);

}  // namespace sahbench
