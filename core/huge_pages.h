#pragma once
// An allocator for large arrays that a traversal reads all over, such as a BVH layout's nodes: arrays
// of 2 MiB or more get pages of their own (mmap), aligned to 2 MiB and advised to the kernel as
// candidates for transparent huge pages (madvise MADV_HUGEPAGE), so that random accesses into them miss
// the TLB less. This is what Embree does with its BVH memory (os_malloc and os_advise in its
// common/sys/alloc.cpp): on a system whose THP setting is "madvise" (Debian's default), Embree's trees
// get huge pages and a plain std::vector does not. The pages must be mapped apart from the heap: heap
// memory that was touched before keeps its small pages.
//
// Smaller arrays come from the aligned global operator new. Elements are default-initialised: a resize
// leaves them as uninitialised as `new T[n]` would, which saves zeroing arrays that are written in full
// right after. Mapped arrays count as heap in the harness's tracker (core/memory_tracker.h).
//
// Builders use it for their large per-primitive arrays too (bounds and references), as
// Embree's builders get theirs from os_malloc: each 2 MiB page costs the kernel one page fault instead
// of 512; in a profile of builds of the 1M-triangle terrain, page faults had been a tenth of the samples.
// Freed mappings under 28 MiB are kept for the next array (core/mapping_cache.h), so that a build after
// the first reuses pages that are already mapped, as heap memory is reused.

#include <cstddef>
#include <cstdint>
#include <new>
#include <span>
#include <type_traits>
#include <utility>

#include "core/mapping_cache.h"
#include "core/memory_tracker.h"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace sahbench {

inline constexpr std::size_t kHugePageBytes = std::size_t{2} << 20;

template <class T>
class HugePageAllocator {
 public:
  using value_type = T;

  HugePageAllocator() = default;
  template <class U>
  HugePageAllocator(const HugePageAllocator<U>&) noexcept {}

  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (bytes >= kHugePageBytes) {
      const std::size_t size = rounded(bytes);
      if (void* kept = mapping_cache().take(size)) {
        note_mapped(static_cast<int64_t>(size));
        return static_cast<T*>(kept);
      }
      // Map one huge page more than needed, then unmap the parts before and after the aligned range. Where
      // memory runs short, the kept ranges go back to the kernel first.
      void* mapped = map(size + kHugePageBytes);
      if (mapped == MAP_FAILED) {
        mapping_cache().release_all();
        mapped = map(size + kHugePageBytes);
      }
      if (mapped == MAP_FAILED) throw std::bad_alloc();
      char* const start = static_cast<char*>(mapped);
      const std::uintptr_t address = reinterpret_cast<std::uintptr_t>(start);
      char* const aligned = start + ((kHugePageBytes - address % kHugePageBytes) % kHugePageBytes);
      if (aligned != start) munmap(start, static_cast<std::size_t>(aligned - start));
      if (aligned + size != start + size + kHugePageBytes)
        munmap(aligned + size, static_cast<std::size_t>(start + size + kHugePageBytes - (aligned + size)));
      madvise(aligned, size, MADV_HUGEPAGE);  // a hint: where THP is off it fails, and nothing changes
      note_mapped(static_cast<int64_t>(size));
      return reinterpret_cast<T*>(aligned);
    }
#endif
    return static_cast<T*>(::operator new (bytes, std::align_val_t{kAlignment}));
  }

  void deallocate(T* p, std::size_t n) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (n * sizeof(T) >= kHugePageBytes) {
      mapping_cache().give(p, rounded(n * sizeof(T)));
      note_unmapped(static_cast<int64_t>(rounded(n * sizeof(T))));
      return;
    }
#endif
    ::operator delete (p, std::align_val_t{kAlignment});
  }

  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    if constexpr (sizeof...(Args) == 0)
      ::new (static_cast<void*>(p)) U;
    else
      ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }

  friend bool operator==(const HugePageAllocator&, const HugePageAllocator&) {
    return true;
  }

 private:
  static constexpr std::size_t kAlignment = alignof(T) > 64 ? alignof(T) : 64;
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  static void* map(std::size_t bytes) {
    return mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  }
#endif
  static constexpr std::size_t rounded(std::size_t bytes) {
    return (bytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
  }
};

/// A fixed-size array on HugePageAllocator's memory whose elements are left uninitialised: the caller
/// writes each one (std::construct_at), typically in a parallel loop, so the memory is written once and
/// its pages are first touched by all threads. T must be trivially destructible.
template <class T>
class HugePageArray {
  static_assert(std::is_trivially_destructible_v<T>);

 public:
  HugePageArray() = default;
  explicit HugePageArray(std::size_t size)
      : data_(size ? HugePageAllocator<T>().allocate(size) : nullptr), size_(size) {}
  ~HugePageArray() {
    if (data_) HugePageAllocator<T>().deallocate(data_, size_);
  }
  HugePageArray(HugePageArray&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)) {}
  HugePageArray& operator=(HugePageArray&& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
    return *this;
  }

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  T* data() { return data_; }
  const T* data() const { return data_; }
  T* begin() { return data_; }
  const T* begin() const { return data_; }
  T* end() { return data_ + size_; }
  const T* end() const { return data_ + size_; }
  T& operator[](std::size_t i) { return data_[i]; }
  const T& operator[](std::size_t i) const { return data_[i]; }
  std::span<T> span() { return {data_, size_}; }
  std::span<const T> span() const { return {data_, size_}; }
  operator std::span<const T>() const { return {data_, size_}; }

 private:
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace sahbench
