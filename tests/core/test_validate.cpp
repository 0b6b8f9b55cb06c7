#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/validate.h"

namespace sahbench {
namespace {

std::vector<Aabb> prim_boxes() {
  return {{{0, 0, 0}, {0.5f, 0.5f, 0.5f}}, {{0.5f, 0.5f, 0.5f}, {1, 1, 1}}, {{1, 1, 1}, {2, 2, 2}}};
}

Bvh valid_tree() {
  Bvh bvh;
  bvh.nodes = {{{{0, 0, 0}, {2, 2, 2}}, 1, 2, 0},
               {{{0, 0, 0}, {1, 1, 1}}, 0, 0, 2},
               {{{1, 1, 1}, {2, 2, 2}}, 2, 0, 1}};
  bvh.prim_refs = {0, 1, 2};
  return bvh;
}

void expect_error(const Bvh& bvh, const std::string& fragment) {
  const auto report = validate(bvh, prim_boxes());
  ASSERT_FALSE(report.ok()) << "expected an error containing '" << fragment << "'";
  EXPECT_NE(report.summary().find(fragment), std::string::npos) << report.summary();
}

TEST(CoreValidate, AcceptsValidTree) { EXPECT_TRUE(validate(valid_tree(), prim_boxes()).ok()); }

TEST(CoreValidate, AcceptsEmptyTreeOnlyWithoutPrimitives) {
  EXPECT_TRUE(validate(Bvh{}, std::span<const Aabb>{}).ok());
  expect_error(Bvh{}, "no nodes");
}

TEST(CoreValidate, ChildOutsideParent) {
  Bvh bvh = valid_tree();
  bvh.nodes[0].bounds.max.x = 1.5f;
  expect_error(bvh, "not inside its parent");
}

TEST(CoreValidate, Cycle) {
  Bvh bvh = valid_tree();
  bvh.nodes[2] = {bvh.nodes[0].bounds, 0, 2, 0};  // points back at the root's children... and the root
  bvh.nodes[2].first = 1;
  expect_error(bvh, "reached twice");
}

TEST(CoreValidate, MissingPrimitive) {
  Bvh bvh = valid_tree();
  bvh.prim_refs[2] = 1;
  expect_error(bvh, "not referenced");
}

TEST(CoreValidate, ReferenceOutOfRange) {
  Bvh bvh = valid_tree();
  bvh.prim_refs[0] = 7;
  expect_error(bvh, "references primitive 7");
}

TEST(CoreValidate, LeafRangeOutsideReferences) {
  Bvh bvh = valid_tree();
  bvh.nodes[2].prim_count = 5;
  expect_error(bvh, "outside the 3 references");
}

TEST(CoreValidate, NaNInBounds) {
  Bvh bvh = valid_tree();
  bvh.nodes[1].bounds.min.y = std::nanf("");
  expect_error(bvh, "NaN");
}

TEST(CoreValidate, BothCountsSetOrNeither) {
  Bvh bvh = valid_tree();
  bvh.nodes[1].child_count = 2;
  expect_error(bvh, "exactly one must be non-zero");
  bvh = valid_tree();
  bvh.nodes[1].prim_count = 0;
  expect_error(bvh, "exactly one must be non-zero");
}

TEST(CoreValidate, TooManyChildrenForArity) {
  Bvh bvh = valid_tree();
  bvh.nodes[0].child_count = 3;
  bvh.nodes.push_back({{{1, 1, 1}, {2, 2, 2}}, 2, 0, 1});
  expect_error(bvh, "3 children, arity is 2");
}

TEST(CoreValidate, LeafDoesNotContainItsPrimitive) {
  Bvh bvh = valid_tree();
  bvh.prim_refs = {0, 2, 1};
  expect_error(bvh, "does not contain primitive");
}

TEST(CoreValidate, OrphanNodes) {
  Bvh bvh = valid_tree();
  bvh.nodes.push_back({{{0, 0, 0}, {1, 1, 1}}, 0, 0, 1});
  expect_error(bvh, "not reachable");
}

}  // namespace
}  // namespace sahbench
