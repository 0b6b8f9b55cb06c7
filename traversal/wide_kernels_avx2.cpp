// The wide kernels for AVX2 (x86-64-v3): 8-wide nodes in one 256-bit register, 4-wide triangle blocks.
// traversal/CMakeLists.txt compiles this file alone with the matching -march level; the program only
// calls it after kernel_isa_available() has checked the CPU.
#define SAHBENCH_WIDE_AVX2
#include <immintrin.h>

#include "traversal/variant_dispatch.h"
#include "traversal/wide_kernels_isa.h"

namespace sahbench::wide_avx2 {
#include "traversal/wide_kernels.inl"
#include "traversal/wide_packets.inl"
// After the two above, whose lanes, packet rays and box test it uses.
#include "traversal/pair_packets.inl"
}  // namespace sahbench::wide_avx2

namespace sahbench::detail {

WideKernel wide_kernel_avx2(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit) {
  return wide_avx2::select_kernel<false>(width, tri, box, any_hit);
}

WideKernel wide_packet_kernel_avx2(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit,
                                   uint32_t packet) {
  return wide_avx2::select_packet_kernel(width, tri, box, any_hit, packet);
}

PairPacketKernel pair_packet_kernel_avx2(const KernelVariant& variant, bool any_hit, uint32_t packet) {
  return wide_avx2::select_pair_packet_kernel(variant, any_hit, packet);
}

BinaryPacketKernel binary_packet_kernel_avx2(const KernelVariant& variant, bool any_hit, uint32_t packet) {
  return wide_avx2::select_binary_packet_kernel(variant, any_hit, packet);
}

WideBenchLoops wide_bench_loops_avx2(uint32_t width, TriangleTestKind tri, BoxTestKind box) {
  return wide_avx2::select_bench_loops(width, tri, box);
}

}  // namespace sahbench::detail
