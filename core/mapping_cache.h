#pragma once
// Freed huge-page mappings (core/huge_pages.h), kept for the next large array instead of being returned
// to the kernel. A fresh mapping costs a page fault per page touched and the kernel's zeroing of each
// page, on every build; memory an allocator keeps is handed out again unzeroed.
//
// The policy is the one Embree 3's build arrays get, so that build times compare like for like: its
// aligned_monitored_allocator (the allocator of its mvector: primitive references, Morton codes) takes
// arrays under 14 huge pages (28 MiB) from the heap, which glibc's malloc reuses, and maps larger ones
// afresh each time (os_malloc). Ranges under kMaxKeptBytes are kept here; larger ones go back to the
// kernel as before.
//
// The harness's mem_peak_bytes counts memory in use, as it does for the heap: a kept range is counted
// when it is handed out, not while it waits. What the cache holds is bounded (the constructor's limit), the
// oldest ranges returned to the kernel first.

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <vector>

namespace sahbench {

class MappingCache {
 public:
  /// The largest range kept: 14 huge pages less one byte, Embree's threshold for mapping afresh.
  static constexpr std::size_t kMaxKeptBytes = (std::size_t{14} << 21) - 1;

  /// Keeps at most `limit_bytes` of freed ranges.
  explicit MappingCache(std::size_t limit_bytes) : limit_(limit_bytes) {}
  ~MappingCache();
  MappingCache(const MappingCache&) = delete;
  MappingCache& operator=(const MappingCache&) = delete;

  /// `bytes` (a multiple of the page size) of a kept range: the front of the smallest one that large
  /// (the most recently kept among equals), whose rest stays kept; nullptr when none is. The memory
  /// holds what it last held.
  void* take(std::size_t bytes);
  /// Keeps `bytes` at `p` (a range that take() or mmap returned), or unmaps it where it is larger than
  /// kMaxKeptBytes or the limit; then returns the oldest kept ranges to the kernel while more than the
  /// limit is kept.
  void give(void* p, std::size_t bytes) noexcept;
  /// Returns every kept range to the kernel (when a mapping fails for want of memory).
  void release_all() noexcept;

  std::size_t kept_bytes() const;

 private:
  struct Range {
    char* begin;
    std::size_t bytes;
    uint64_t age;  ///< when it was kept; the smallest is the oldest
  };
  static void unmap(const Range& range) noexcept;

  mutable std::mutex mutex_;
  std::vector<Range> kept_;
  std::size_t limit_;
  std::size_t kept_bytes_ = 0;
  uint64_t clock_ = 0;
};

/// The process's cache, behind HugePageAllocator: it keeps 1 GiB or an eighth of the machine's memory,
/// whichever is less.
MappingCache& mapping_cache();

}  // namespace sahbench
