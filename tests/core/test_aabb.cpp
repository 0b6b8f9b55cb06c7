#include <gtest/gtest.h>

#include "core/aabb.h"
#include "core/sah.h"
#include "core/triangle.h"

namespace sahbench {
namespace {

TEST(CoreAabb, EmptyBoxHasZeroAreaAndAbsorbsAnyExtension) {
  Aabb box;
  EXPECT_TRUE(box.is_empty());
  EXPECT_EQ(box.half_area(), 0.0f);
  box.extend(Vec3{1, 2, 3});
  EXPECT_FALSE(box.is_empty());
  EXPECT_EQ(box, Aabb::from_point({1, 2, 3}));
  EXPECT_EQ(box.half_area(), 0.0f);
}

TEST(CoreAabb, HalfAreaOfUnitCubeIsThree) {
  const Aabb box{{0, 0, 0}, {1, 1, 1}};
  EXPECT_FLOAT_EQ(box.half_area(), 3.0f);
  EXPECT_EQ(box.center(), (Vec3{0.5f, 0.5f, 0.5f}));
  EXPECT_TRUE(box.contains(Aabb{{0.25f, 0, 0}, {1, 0.5f, 1}}));
  EXPECT_FALSE(box.contains(Aabb{{0.25f, 0, 0}, {1.5f, 0.5f, 1}}));
}

TEST(CoreTriangle, BoundsCentroidAndArea) {
  const Triangle t{{0, 0, 0}, {2, 0, 0}, {0, 2, 0}};
  EXPECT_EQ(t.bounds(), (Aabb{{0, 0, 0}, {2, 2, 0}}));
  EXPECT_FLOAT_EQ(t.area(), 2.0f);
  EXPECT_EQ(t.normal(), (Vec3{0, 0, 4}));
}

TEST(CoreSah, SplitCostWeighsChildrenByAreaRatio) {
  const SahCost cost{1.0f, 2.0f};
  EXPECT_FLOAT_EQ(cost.leaf_cost(3), 6.0f);
  // Two children each of half the parent's area with 2 primitives: 1 + 2 * (0.5*2 + 0.5*2) = 5.
  EXPECT_FLOAT_EQ(cost.split_cost(4.0f, 2.0f, 2, 2.0f, 2), 5.0f);
}

}  // namespace
}  // namespace sahbench
