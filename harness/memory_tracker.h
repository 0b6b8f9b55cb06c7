#pragma once
// Heap bytes in use and their peak, for the `mem_peak_bytes` column. Counting happens only in the
// sahbench executable, which replaces the global operator new/delete (memory_tracker_new.cpp); in
// other programs (tests) the tracker reports tracking_enabled() == false and zeros.

#include <cstdint>

namespace sahbench {

bool tracking_enabled();
int64_t heap_bytes();
/// Starts a new peak window at the current usage; peak_bytes_since_reset() is the most in use since.
void reset_heap_peak();
int64_t heap_peak_bytes();

}  // namespace sahbench
