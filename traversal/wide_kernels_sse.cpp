// The wide kernels for SSE4.2 (x86-64-v2): 4-wide boxes and triangles; 8-wide nodes in two halves.
// traversal/CMakeLists.txt compiles this file alone with the matching -march level; the program only
// calls it after kernel_isa_available() has checked the CPU.
#define SAHBENCH_WIDE_SSE
#include <immintrin.h>

#include "traversal/wide_kernels_isa.h"

namespace sahbench::wide_sse {
#include "traversal/wide_kernels.inl"
}  // namespace sahbench::wide_sse

namespace sahbench::detail {

WideKernel wide_kernel_sse(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit) {
  return wide_sse::select_kernel<false>(width, tri, box, any_hit);
}

WideBenchLoops wide_bench_loops_sse(uint32_t width, TriangleTestKind tri, BoxTestKind box) {
  return wide_sse::select_bench_loops(width, tri, box);
}

}  // namespace sahbench::detail
