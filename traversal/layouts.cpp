// The binary layouts, and compile_layout for every layout of the registry (layout_spec.cpp).

#include "core/error.h"
#include "core/refit.h"
#include "traversal/binary_layout.h"
#include "traversal/bvh2_traversal.h"
#include "traversal/layout.h"
#include "traversal/packed_bvh2.h"
#include "traversal/ray_chunks.h"
#include "traversal/variant_dispatch.h"
#include "traversal/wide_kernels_isa.h"
#include "traversal/wide_layout.h"

namespace sahbench {
namespace {

// The counters of `trace(i, counters)` summed over rays [0, count), in the binary layouts' chunks.
template <class Trace>
TraceCounts count_rays(std::size_t count, Trace trace) {
  return sum_over_ray_chunks(count, detail::kBinaryRayChunk, [&](std::size_t begin, std::size_t end) {
    TraversalCounters counters;
    for (std::size_t i = begin; i != end; ++i) trace(i, counters);
    return TraceCounts{end - begin, counters.nodes_visited(), counters.prim_tests, counters.leaf_visits};
  });
}

// The packet kernels of bvh2 for `isa` (AVX2 or AVX-512); nullptr where none are compiled in.
BinaryPacketKernel find_binary_packet_kernel([[maybe_unused]] KernelIsa isa,
                                             [[maybe_unused]] const KernelVariant& variant,
                                             [[maybe_unused]] bool any_hit,
                                             [[maybe_unused]] uint32_t packet) {
#if defined(SAHBENCH_HAVE_X86_KERNELS)
  if (isa == KernelIsa::kAvx2) return detail::binary_packet_kernel_avx2(variant, any_hit, packet);
  if (isa == KernelIsa::kAvx512) return detail::binary_packet_kernel_avx512(variant, any_hit, packet);
#endif
  return nullptr;
}

/// A binary tree in the common format as built, traversed by the traversal/ kernels, its triangles reached
/// through the references. The triangle and box tests are template parameters (variant_dispatch.h).
template <class Tri, class Box>
class Bvh2Layout final : public detail::BinaryLayout<Bvh2Layout<Tri, Box>, Box> {
  using Base = detail::BinaryLayout<Bvh2Layout<Tri, Box>, Box>;
  friend Base;

 public:
  /// `bvh` and `triangles` must outlive the layout. Any hit visits children in `variant.any_hit`;
  /// `packet` 1: the single-ray kernel; 8 or 16: the packet kernels of `isa`.
  Bvh2Layout(const Bvh& bvh, std::span<const Triangle> triangles, const KernelVariant& variant,
             uint32_t packet, KernelIsa isa)
      : Base(packet, isa), bvh_(&bvh), triangles_(triangles), order_(variant.any_hit) {
    if (packet == 1) return;
    closest_packet_ = find_binary_packet_kernel(isa, variant, false, packet);
    any_packet_ = find_binary_packet_kernel(isa, variant, true, packet);
    if (!closest_packet_ || !any_packet_)
      throw Error("layout bvh2: no " + std::string(to_string(isa)) + " " + std::to_string(packet) +
                  "-ray packet kernels compiled in");
  }

  TraceCounts count_closest(std::span<const Ray> rays) const override {
    return count_rays(rays.size(), [&](std::size_t i, TraversalCounters& c) {
      closest_hit_counted<Tri, Box>(*bvh_, triangles_, rays[i], c);
    });
  }
  TraceCounts count_any(std::span<const Ray> rays) const override {
    return count_rays(rays.size(), [&](std::size_t i, TraversalCounters& c) {
      any_hit_counted<Tri, Box>(*bvh_, triangles_, rays[i], c, order_);
    });
  }
  // Refit (core/refit.h): a copy of the borrowed tree is made the first time, and the new triangles are
  // borrowed like the old ones.
  void refit(std::span<const Triangle> triangles) override {
    if (triangles.size() != triangles_.size())
      throw Error("refit with " + std::to_string(triangles.size()) + " triangles, compiled over " +
                  std::to_string(triangles_.size()));
    if (bvh_ != &owned_) {
      owned_ = *bvh_;
      bvh_ = &owned_;
    }
    triangles_ = triangles;
    sahbench::refit(owned_, triangles_);
  }

  std::size_t bytes() const override { return bvh_->bytes(); }

 private:
  // What detail::BinaryLayout asks of a binary layout.
  template <bool kAnyHit, class Index, class Put>
  void trace_alone(std::span<const Ray> rays, std::size_t n, Index&& index, Put&& put) const {
    using Walk = detail::BinaryWalk<Tri, Box, kAnyHit, false>;
    const AnyHitOrder any_order = kAnyHit ? resolve_any_hit_order(*bvh_, order_) : AnyHitOrder::kNearest;
    detail::trace_walks<Walk, Box>(
        rays, n, index,
        [&](std::optional<Walk>& walk, const Ray& ray) {
          walk.emplace(*bvh_, triangles_.data(), ray, nullptr, any_order);
        },
        [&](const Ray& ray) {
          return detail::traverse<Tri, Box, kAnyHit, false>(*bvh_, triangles_, ray, nullptr, order_);
        },
        put);
  }
  template <bool kAnyHit>
  void trace_packet(const Ray* packet, uint32_t n, uint32_t mask, Hit* hits, uint8_t* occluded) const {
    (kAnyHit ? any_packet_ : closest_packet_)(*bvh_, triangles_.data(), packet, n, mask,
                                              resolve_any_hit_order(*bvh_, order_), hits, occluded);
  }
  bool root_is_inner() const { return !bvh_->nodes.empty() && !bvh_->root().is_leaf(); }
  void finish_closest(std::span<Hit>) const {}  // the hits are the scene's triangles already

  const Bvh* bvh_ = nullptr;
  std::span<const Triangle> triangles_;
  Bvh owned_;  // once refitted
  AnyHitOrder order_ = AnyHitOrder::kAuto;
  BinaryPacketKernel closest_packet_ = nullptr, any_packet_ = nullptr;
};

std::unique_ptr<CompiledLayout> compile_bvh2(const Bvh& bvh, std::span<const Triangle> tris,
                                             const LayoutSpec& spec) {
  const KernelIsa isa = spec.packet == 1 ? KernelIsa::kScalar : layout_kernel_isa(spec);
  return with_test_types(spec.variant, [&]<class Tri, class Box>() -> std::unique_ptr<CompiledLayout> {
    return std::make_unique<Bvh2Layout<Tri, Box>>(bvh, tris, spec.variant, spec.packet, isa);
  });
}

// How each layout of the registry (layout_spec.cpp) is compiled.
using CompileFn = std::unique_ptr<CompiledLayout> (*)(const Bvh&, std::span<const Triangle>,
                                                      const LayoutSpec&);
CompileFn compiler(const std::string& name) {
  if (name == "bvh2") return compile_bvh2;
  if (name == "bvh2_packed") return compile_packed_bvh2;
  if (name == "bvh4")
    return [](const Bvh& bvh, std::span<const Triangle> tris, const LayoutSpec& spec) {
      return compile_wide_layout(4, bvh, tris, spec);
    };
  if (name == "bvh8")
    return [](const Bvh& bvh, std::span<const Triangle> tris, const LayoutSpec& spec) {
      return compile_wide_layout(8, bvh, tris, spec);
    };
  throw Error("layout '" + name + "' is registered but has no compiler");
}

}  // namespace

void CompiledLayout::refit(std::span<const Triangle>) {
  throw Error("this layout does not refit");
}

std::unique_ptr<CompiledLayout> compile_layout(const LayoutSpec& spec, const Bvh& bvh,
                                               std::span<const Triangle> triangles) {
  // Kernels this CPU or build lacks (a packet width, an ISA): refused here, for every layout.
  if (const auto why = layout_unavailable(spec)) throw Error("layout '" + spec.text() + "': " + *why);
  // A tree wider than the layout's nodes: refused here, for every layout (narrower trees compile).
  const LayoutInfo& info = find_layout(spec.name);
  if (bvh.arity > info.arity)
    throw Error("layout '" + spec.text() + "' takes trees of arity " + std::to_string(info.arity) +
                " or less; the builder gave arity " + std::to_string(bvh.arity));
  return compiler(info.name)(bvh, triangles, spec);
}

std::unique_ptr<CompiledLayout> compile_layout(std::string_view spec, const Bvh& bvh,
                                               std::span<const Triangle> triangles) {
  return compile_layout(parse_layout_spec(spec), bvh, triangles);
}

}  // namespace sahbench
