#pragma once
// The 4- and 8-wide SIMD layouts (traversal/wide_bvh.h) behind the CompiledLayout interface.

#include <memory>
#include <span>

#include "traversal/layout.h"

namespace sahbench {

/// Compiles `bvh` into a `width`-wide layout (4 or 8) whose kernels use `spec`'s variant and ISA
/// (kAuto: the widest available), which must be available here (compile_layout refuses a spec whose
/// kernels this CPU or build lacks, naming them).
std::unique_ptr<CompiledLayout> compile_wide_layout(uint32_t width, const Bvh& bvh,
                                                    std::span<const Triangle> triangles,
                                                    const LayoutSpec& spec);

}  // namespace sahbench
