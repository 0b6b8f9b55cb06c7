#pragma once
// The 4- and 8-wide SIMD layouts (traversal/wide_bvh.h) behind the CompiledLayout interface.

#include <memory>
#include <optional>
#include <span>
#include <string>

#include "traversal/layout.h"

namespace sahbench {

/// The instruction set a wide layout's kernels run with: `spec.isa`, or for kAuto the preferred one
/// (preferred_kernel_isa), capped at `widest`: what the CPU is taken to have (kAuto: no cap), so that a
/// test can ask what a CPU without AVX-512 would do.
KernelIsa wide_layout_isa(const LayoutSpec& spec, KernelIsa widest = KernelIsa::kAuto);

/// Why this CPU and build (capped at `widest`) cannot run the wide layout `spec`: its instruction set,
/// or its packet width's, is missing. Nullopt when it can.
std::optional<std::string> wide_layout_unavailable(const LayoutSpec& spec,
                                                   KernelIsa widest = KernelIsa::kAuto);

/// Compiles `bvh` into a `width`-wide layout (4 or 8) whose kernels use `spec`'s variant and ISA
/// (kAuto: the widest available). Throws Error when the ISA is not available here, naming it.
std::unique_ptr<CompiledLayout> compile_wide_layout(uint32_t width, const Bvh& bvh,
                                                    std::span<const Triangle> triangles,
                                                    const LayoutSpec& spec);

}  // namespace sahbench
