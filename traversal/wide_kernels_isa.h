#pragma once
// The kernel tables of each instruction set (wide_kernels_*.cpp), looked up by find_wide_kernel()
// (wide_bvh.cpp). Internal to traversal/.

#include <bit>
#include <cstdint>

#include "core/bvh.h"
#include "traversal/kernel_variant.h"
#include "traversal/packed_bvh2.h"
#include "traversal/ray_box.h"
#include "traversal/triangle_tests.h"
#include "traversal/wide_bvh.h"

namespace sahbench::detail {

WideBenchLoops wide_bench_loops_scalar(uint32_t width, TriangleTestKind tri, BoxTestKind box);
#if defined(SAHBENCH_HAVE_X86_KERNELS)
WideBenchLoops wide_bench_loops_sse(uint32_t width, TriangleTestKind tri, BoxTestKind box);
WideBenchLoops wide_bench_loops_avx2(uint32_t width, TriangleTestKind tri, BoxTestKind box);
WideBenchLoops wide_bench_loops_avx512(uint32_t width, TriangleTestKind tri, BoxTestKind box);
#endif
WideKernel wide_kernel_scalar(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit,
                              bool counting);
#if defined(SAHBENCH_HAVE_X86_KERNELS)
WideKernel wide_kernel_sse(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit);
WideKernel wide_kernel_avx2(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit);
WideKernel wide_kernel_avx512(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit);
WideKernel wide_packet_kernel_avx2(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit,
                                   uint32_t packet);
WideKernel wide_packet_kernel_avx512(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit,
                                     uint32_t packet);
PairPacketKernel pair_packet_kernel_avx2(const KernelVariant& variant, bool any_hit, uint32_t packet);
PairPacketKernel pair_packet_kernel_avx512(const KernelVariant& variant, bool any_hit, uint32_t packet);
BinaryPacketKernel binary_packet_kernel_avx2(const KernelVariant& variant, bool any_hit, uint32_t packet);
BinaryPacketKernel binary_packet_kernel_avx512(const KernelVariant& variant, bool any_hit, uint32_t packet);
#endif

}  // namespace sahbench::detail
