// The wide kernels in plain C++, one lane after another: the fallback where no SIMD set is available,
// and the counting kernels for every set (wide_bvh.h). Compiled without auto-vectorisation so that it
// is what its name says.
#define SAHBENCH_WIDE_SCALAR
#include "traversal/wide_kernels_isa.h"

namespace sahbench::wide_scalar {
#include "traversal/wide_kernels.inl"
}  // namespace sahbench::wide_scalar

namespace sahbench::detail {

WideKernel wide_kernel_scalar(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit,
                              bool counting) {
  return counting ? wide_scalar::select_kernel<true>(width, tri, box, any_hit)
                  : wide_scalar::select_kernel<false>(width, tri, box, any_hit);
}

WideBenchLoops wide_bench_loops_scalar(uint32_t width, TriangleTestKind tri, BoxTestKind box) {
  return wide_scalar::select_bench_loops(width, tri, box);
}

}  // namespace sahbench::detail
