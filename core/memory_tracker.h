#pragma once
// Heap bytes in use and their peak, for the `mem_peak_bytes` column. Counting happens only in the
// sahbench executable, which replaces the global operator new/delete (cli/memory_tracker_new.cpp);
// in other programs (tests) the tracker reports tracking_enabled() == false and zeros. Memory mapped by
// HugePageAllocator (core/huge_pages.h) is counted too, through note_mapped and note_unmapped.

#include <cstdint>

namespace sahbench {

bool tracking_enabled();
int64_t heap_bytes();
/// Starts a new peak window at the current usage; heap_peak_bytes() is the most in use since.
void reset_heap_peak();
int64_t heap_peak_bytes();

/// Counts memory allocated outside operator new (mmap) as heap in use.
void note_mapped(int64_t bytes);
void note_unmapped(int64_t bytes);

}  // namespace sahbench
