// The builders' uninitialised large arrays (core/huge_pages.h) and the build input that uses them.

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "core/build_input.h"
#include "core/huge_pages.h"

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
