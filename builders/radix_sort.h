#pragma once
// Parallel least-significant-digit radix sort of keys with 32-bit values (the sort that LBVH builders
// use on Morton codes: Karras 2012, section 5; Embree's Morton builder). Each pass counts the digits of
// fixed chunks of the input in parallel, turns the counts into each chunk's output positions (digit by
// digit, chunk by chunk) and scatters every chunk in parallel. LSD radix sort is stable, so equal keys
// keep their input order, and the result is the same for any thread count and chunking.

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
