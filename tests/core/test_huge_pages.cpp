// The builders' uninitialised large arrays (core/huge_pages.h) and the build input that uses them.

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "core/build_input.h"
#include "core/huge_pages.h"
#include "core/mapping_cache.h"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace sahbench {
namespace {

TEST(HugePageArray, StartsOnAHugePageAndKeepsItsElementsWhenMoved) {
  HugePageArray<uint64_t> a(kHugePageBytes / sizeof(uint64_t) + 3);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(a.data()) % kHugePageBytes, 0u);
  for (std::size_t i = 0; i < a.size(); ++i) std::construct_at(&a[i], uint64_t{i} * 7);
  const uint64_t* data = a.data();
  HugePageArray<uint64_t> b(std::move(a));
  EXPECT_TRUE(a.empty());
  EXPECT_EQ(b.data(), data);
  HugePageArray<uint64_t> c(5);
  c = std::move(b);
  ASSERT_EQ(c.size(), kHugePageBytes / sizeof(uint64_t) + 3);
  for (std::size_t i = 0; i < c.size(); ++i) ASSERT_EQ(c[i], uint64_t{i} * 7) << i;
  EXPECT_TRUE(HugePageArray<int>().empty());
}

#if defined(__linux__)
// A fresh anonymous mapping of `pages` huge-page sizes, as HugePageAllocator makes them.
char* map_pages(std::size_t pages) {
  void* p = mmap(nullptr, pages * kHugePageBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  EXPECT_NE(p, MAP_FAILED);
  return static_cast<char*>(p);
}

TEST(MappingCache, HandsOutTheSmallestKeptRangeThatFitsAndSplitsLargerOnes) {
  MappingCache cache(16 * kHugePageBytes);
  EXPECT_EQ(cache.take(kHugePageBytes), nullptr);
  char* const four = map_pages(4);
  char* const one = map_pages(1);
  four[0] = 17;
  cache.give(four, 4 * kHugePageBytes);
  cache.give(one, kHugePageBytes);
  EXPECT_EQ(cache.kept_bytes(), 5 * kHugePageBytes);
  EXPECT_EQ(cache.take(kHugePageBytes), one);  // the exact fit, not the front of the larger range
  EXPECT_EQ(cache.take(8 * kHugePageBytes), nullptr);
  char* const front = static_cast<char*>(cache.take(3 * kHugePageBytes));
  EXPECT_EQ(front, four);
  EXPECT_EQ(front[0], 17);  // what it held: nothing zeroes a kept range
  EXPECT_EQ(cache.take(kHugePageBytes), four + 3 * kHugePageBytes);
  EXPECT_EQ(cache.kept_bytes(), 0u);
  cache.give(four, 4 * kHugePageBytes);  // the destructor unmaps what is kept
  munmap(one, kHugePageBytes);
}

TEST(MappingCache, ReturnsTheOldestRangesBeyondItsLimit) {
  MappingCache cache(2 * kHugePageBytes);
  char* const first = map_pages(1);
  char* const second = map_pages(1);
  char* const third = map_pages(1);
  cache.give(first, kHugePageBytes);
  cache.give(second, kHugePageBytes);
  cache.give(third, kHugePageBytes);  // over the limit: `first` goes back to the kernel
  EXPECT_EQ(cache.kept_bytes(), 2 * kHugePageBytes);
  const void* a = cache.take(kHugePageBytes);
  const void* b = cache.take(kHugePageBytes);
  EXPECT_TRUE((a == second && b == third) || (a == third && b == second));
  EXPECT_EQ(cache.take(kHugePageBytes), nullptr);
  munmap(second, kHugePageBytes);
  munmap(third, kHugePageBytes);
  // A range larger than the limit is not kept at all.
  cache.give(map_pages(3), 3 * kHugePageBytes);
  EXPECT_EQ(cache.kept_bytes(), 0u);
}

TEST(MappingCache, KeepsOnlyWhatEmbreesBuildArraysTakeFromTheHeap) {
  MappingCache cache(64 * kHugePageBytes);
  cache.give(map_pages(14), 14 * kHugePageBytes);  // 28 MiB: Embree maps such an array afresh
  EXPECT_EQ(cache.kept_bytes(), 0u);
  char* const below = map_pages(13);
  cache.give(below, 13 * kHugePageBytes);
  EXPECT_EQ(cache.kept_bytes(), 13 * kHugePageBytes);
  cache.release_all();
  EXPECT_EQ(cache.kept_bytes(), 0u);
  EXPECT_EQ(cache.take(kHugePageBytes), nullptr);
}

TEST(MappingCache, HandsOutTheMostRecentOfEqualRanges) {
  MappingCache cache(16 * kHugePageBytes);
  char* const older = map_pages(1);
  char* const newer = map_pages(1);
  cache.give(older, kHugePageBytes);
  cache.give(newer, kHugePageBytes);
  EXPECT_EQ(cache.take(kHugePageBytes), newer);
  EXPECT_EQ(cache.take(kHugePageBytes), older);
  munmap(older, kHugePageBytes);
  munmap(newer, kHugePageBytes);
}

TEST(HugePageArray, ReusesTheMappingOfAFreedArray) {
  // A size no other test allocates, so the process's cache holds no other range of it.
  const std::size_t size = (7 * kHugePageBytes + 5) / sizeof(uint32_t);
  const void* freed = nullptr;
  {
    HugePageArray<uint32_t> a(size);
    std::construct_at(&a[size - 1], 42u);
    freed = a.data();
  }
  const std::size_t kept = mapping_cache().kept_bytes();
  EXPECT_GE(kept, 8 * kHugePageBytes);
  HugePageArray<uint32_t> b(size);
  EXPECT_EQ(b.data(), freed);
  EXPECT_EQ(mapping_cache().kept_bytes(), kept - 8 * kHugePageBytes);
}
#endif

TEST(BuildInput, HoldsEachTrianglesBounds) {
  const std::vector<Triangle> tris = {{{0, 0, 0}, {1, 0, 0}, {0, 2, 0}},
                                      {{-1, -1, -1}, {3, 0, 1}, {0, 0, 5}}};
  const BuildInput input = BuildInput::from_triangles(tris);
  ASSERT_EQ(input.size(), 2u);
  EXPECT_EQ(input.bounds[0], tris[0].bounds());
  EXPECT_EQ(input.bounds[1], tris[1].bounds());
  // Large enough for the parallel loop and for huge pages.
  const std::vector<Triangle> many(200000, tris[1]);
  const BuildInput large = BuildInput::from_triangles(many);
  ASSERT_EQ(large.size(), many.size());
  for (std::size_t i = 0; i < large.size(); ++i) ASSERT_EQ(large.bounds[i], many[i].bounds()) << i;
}

}  // namespace
}  // namespace sahbench
