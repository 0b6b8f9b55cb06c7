#include "core/mapping_cache.h"

#include <algorithm>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

// Kept ranges are poisoned under AddressSanitizer, so that a use after free of a large array is still
// reported although the memory stays mapped.
#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/asan_interface.h>
#define SAHBENCH_POISON(p, n) ASAN_POISON_MEMORY_REGION(p, n)
#define SAHBENCH_UNPOISON(p, n) ASAN_UNPOISON_MEMORY_REGION(p, n)
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#include <sanitizer/asan_interface.h>
#define SAHBENCH_POISON(p, n) ASAN_POISON_MEMORY_REGION(p, n)
#define SAHBENCH_UNPOISON(p, n) ASAN_UNPOISON_MEMORY_REGION(p, n)
#endif
#endif
#if !defined(SAHBENCH_POISON)
#define SAHBENCH_POISON(p, n) ((void)(p), (void)(n))
#define SAHBENCH_UNPOISON(p, n) ((void)(p), (void)(n))
#endif

namespace sahbench {

MappingCache::~MappingCache() {
  release_all();
}

void MappingCache::unmap([[maybe_unused]] const Range& range) noexcept {
  SAHBENCH_UNPOISON(range.begin, range.bytes);
#if defined(__linux__)
  munmap(range.begin, range.bytes);
#endif
}

void* MappingCache::take(std::size_t bytes) {
  const std::lock_guard lock(mutex_);
  auto best = kept_.end();
  for (auto it = kept_.begin(); it != kept_.end(); ++it)
    if (it->bytes >= bytes &&
        (best == kept_.end() || it->bytes < best->bytes || (it->bytes == best->bytes && it->age > best->age)))
      best = it;
  if (best == kept_.end()) return nullptr;
  char* const p = best->begin;
  if (best->bytes == bytes) {
    kept_.erase(best);
  } else {
    best->begin += bytes;
    best->bytes -= bytes;
  }
  kept_bytes_ -= bytes;
  SAHBENCH_UNPOISON(p, bytes);
  return p;
}

void MappingCache::give(void* p, std::size_t bytes) noexcept {
  const Range range{static_cast<char*>(p), bytes, 0};
  if (bytes > kMaxKeptBytes || bytes > limit_) return unmap(range);
  bool kept = false;
  std::vector<Range> released;
  {
    const std::lock_guard lock(mutex_);
    try {
      if (kept_.size() == kept_.capacity()) kept_.reserve(std::max<std::size_t>(16, 2 * kept_.capacity()));
      released.reserve(kept_.size() + 1);
      kept = true;
    } catch (const std::bad_alloc&) {  // deallocations may not throw: without room, not kept
    }
    if (kept) {
      kept_.push_back({range.begin, bytes, clock_++});
      SAHBENCH_POISON(p, bytes);
      kept_bytes_ += bytes;
      while (kept_bytes_ > limit_) {
        const auto oldest = std::min_element(kept_.begin(), kept_.end(),
                                             [](const Range& a, const Range& b) { return a.age < b.age; });
        released.push_back(*oldest);
        kept_bytes_ -= oldest->bytes;
        kept_.erase(oldest);
      }
    }
  }
  if (!kept) unmap(range);
  for (const Range& r : released) unmap(r);
}

void MappingCache::release_all() noexcept {
  std::vector<Range> released;
  {
    const std::lock_guard lock(mutex_);
    released.swap(kept_);
    kept_bytes_ = 0;
  }
  for (const Range& r : released) unmap(r);
}

std::size_t MappingCache::kept_bytes() const {
  const std::lock_guard lock(mutex_);
  return kept_bytes_;
}

MappingCache& mapping_cache() {
  // Never destroyed: arrays in static objects may be freed after any static destructor has run.
  static MappingCache* const cache = new MappingCache([] {
    std::size_t limit = std::size_t{1} << 30;
#if defined(__linux__)
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages > 0 && page > 0) limit = std::min(limit, static_cast<std::size_t>(pages) * page / 8);
#endif
    return limit;
  }());
  return *cache;
}

}  // namespace sahbench
