#pragma once
// Turns a run-time KernelVariant into the compile-time test types of the scalar kernels, so that each
// combination is its own instantiation with no indirect call per ray or per node (STYLE.md).

#include "traversal/kernel_variant.h"
#include "traversal/ray_box.h"
#include "traversal/triangle_tests.h"

namespace sahbench {

/// Calls `f.template operator()<TriangleTest, BoxTest>()` for the types `variant` names and returns its
/// result.
template <class F>
decltype(auto) with_test_types(const KernelVariant& variant, F&& f) {
  auto with_box = [&]<class Tri>() -> decltype(auto) {
    if (variant.box == BoxTestKind::kFast) return f.template operator()<Tri, FastRayBox>();
    if (variant.box == BoxTestKind::kFma) return f.template operator()<Tri, FmaRayBox>();
    return f.template operator()<Tri, RobustRayBox>();
  };
  switch (variant.triangle) {
    case TriangleTestKind::kMollerTrumbore:
      return with_box.template operator()<MollerTrumboreTest>();
    case TriangleTestKind::kMollerTrumboreNoEpsilon:
      return with_box.template operator()<MollerTrumboreNoEpsilonTest>();
    case TriangleTestKind::kMollerTrumboreNormal:
      return with_box.template operator()<MollerTrumboreNormalTest>();
    case TriangleTestKind::kWatertight:
      break;
  }
  return with_box.template operator()<WatertightTriangleTest>();
}

}  // namespace sahbench
