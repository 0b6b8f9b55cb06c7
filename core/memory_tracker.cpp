#include "core/memory_tracker.h"

#include <atomic>

namespace sahbench {
namespace detail {
std::atomic<int64_t> g_heap_bytes{0};
std::atomic<int64_t> g_heap_peak{0};
std::atomic<bool> g_tracking{false};

// Called by the replaced operator new/delete.
void note_allocation(int64_t bytes) {
  const int64_t now = g_heap_bytes.fetch_add(bytes, std::memory_order_relaxed) + bytes;
  int64_t peak = g_heap_peak.load(std::memory_order_relaxed);
  while (now > peak && !g_heap_peak.compare_exchange_weak(peak, now, std::memory_order_relaxed)) {
  }
}
void note_free(int64_t bytes) {
  g_heap_bytes.fetch_sub(bytes, std::memory_order_relaxed);
}
}  // namespace detail

bool tracking_enabled() {
  return detail::g_tracking.load();
}
int64_t heap_bytes() {
  return detail::g_heap_bytes.load();
}
void reset_heap_peak() {
  detail::g_heap_peak.store(detail::g_heap_bytes.load());
}
int64_t heap_peak_bytes() {
  return detail::g_heap_peak.load();
}
// Only where operator new is counted too, so that tests (no tracking) still see zeros.
void note_mapped(int64_t bytes) {
  if (tracking_enabled()) detail::note_allocation(bytes);
}
void note_unmapped(int64_t bytes) {
  if (tracking_enabled()) detail::note_free(bytes);
}

}  // namespace sahbench
