#pragma once
// Freed huge-page mappings (core/huge_pages.h), kept for the next large array instead of being returned
// to the kernel. A fresh mapping costs a page fault per page touched and the kernel's zeroing of each
// page (2 MiB at a time on huge pages); a builder that maps its scratch arrays anew on every build spent
// a sixth of its time in the kernel's clear_page at 2 threads. Allocators that keep freed memory hand it
// out again unzeroed: glibc's malloc does so below its mmap threshold, which is where Embree's build
// arrays come from, and a renderer rebuilding every frame keeps its buffers. The cache does the same for
// the arrays that bypass malloc to get huge pages.
//
// The harness's mem_peak_bytes counts memory in use, as it does for the heap: a kept mapping is counted
// when it is handed out, not while it waits. What the cache holds is bounded (MappingCache::limit), the
// oldest mappings returned to the kernel first.

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <vector>

namespace sahbench {

class MappingCache {
 public:
  /// Keeps at most `limit_bytes` of freed mappings.
  explicit MappingCache(std::size_t limit_bytes) : limit_(limit_bytes) {}
  ~MappingCache();
  MappingCache(const MappingCache&) = delete;
  MappingCache& operator=(const MappingCache&) = delete;

  /// `bytes` (a multiple of the page size) of a kept mapping: the front of the smallest one that large,
  /// whose rest stays kept; nullptr when none is. The memory holds what it last held.
  void* take(std::size_t bytes);
  /// Keeps `bytes` at `p` (a range that take() or mmap returned); returns the oldest kept ranges to the
  /// kernel while more than the limit is kept.
  void give(void* p, std::size_t bytes) noexcept;

  std::size_t kept_bytes() const;
  std::size_t limit() const { return limit_; }

 private:
  struct Range {
    char* begin;
    std::size_t bytes;
    uint64_t age;  ///< when it was given; the smallest is the oldest
  };
  static void unmap(const Range& range);

  mutable std::mutex mutex_;
  std::vector<Range> kept_;
  std::size_t limit_;
  std::size_t kept_bytes_ = 0;
  uint64_t clock_ = 0;
};

/// The process's cache, behind HugePageAllocator: 1 GiB or an eighth of the machine's memory, whichever
/// is less.
MappingCache& mapping_cache();

}  // namespace sahbench
