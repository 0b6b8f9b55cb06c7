#include "traversal/wide_layout.h"

#include <algorithm>
#include <string>
#include <vector>

#include "core/error.h"
#include "traversal/bvh2_traversal.h"
#include "traversal/ray_chunks.h"
#include "traversal/wide_bvh.h"

namespace sahbench {
namespace {

// Rays per kernel call: their WideRay set-ups (80 bytes each) stay in L1, as kBinaryRayChunk's rays do
// for the binary layouts.
constexpr std::size_t kWideChunk = 256;
static_assert(kWideChunk % kMaxWidePacket == 0, "chunks hold whole packets");

template <uint32_t N>
class WideLayout final : public CompiledLayout {
 public:
  WideLayout(WideBvh<N> bvh, std::size_t triangle_count, KernelIsa isa, const KernelVariant& variant,
             AnyHitOrder any_hit_order, uint32_t packet, bool shadow_cache)
      : bvh_(std::move(bvh)),
        triangle_count_(triangle_count),
        isa_(isa),
        shear_(variant.triangle == TriangleTestKind::kWatertight),
        box_(variant.box),
        any_hit_order_(any_hit_order),
        shadow_cache_(shadow_cache) {
    if (bvh_.form != block_form_for(variant.triangle))
      throw Error("layout bvh" + std::to_string(N) + ": blocks compiled in the wrong form for the " +
                  std::string(to_string(variant.triangle)) + " test");
    // The counting kernels are the single-ray ones for packets too: the counts describe the tree and the
    // rays, not the order in which a packet visits nodes.
    closest_ = packet == 1 ? find_wide_kernel(isa, N, variant, false, false)
                           : find_wide_packet_kernel(isa, N, variant, false, packet);
    any_ = packet == 1 ? find_wide_kernel(isa, N, variant, true, false)
                       : find_wide_packet_kernel(isa, N, variant, true, packet);
    count_closest_ = find_wide_kernel(KernelIsa::kScalar, N, variant, false, true);
    count_any_ = find_wide_kernel(KernelIsa::kScalar, N, variant, true, true);
    if (!closest_ || !any_ || !count_closest_ || !count_any_)
      throw Error("layout bvh" + std::to_string(N) + ": no " + std::string(to_string(isa)) +
                  (packet == 1 ? "" : " " + std::to_string(packet) + "-ray packet") + " kernels compiled in" +
                  (packet == 1 ? "" : " (packet=8: isa avx2 or avx512; packet=16: isa avx512)"));
  }

  void trace_closest(std::span<const Ray> rays, std::span<Hit> hits) const override {
    if (bvh_.empty()) return std::fill(hits.begin(), hits.end(), Hit{});  // no triangles
    run(rays, [&](const WideBatch& batch, std::size_t begin) {
      WideBatch b = batch;
      b.hits = hits.data() + begin;
      closest_(b);
    });
  }
  void trace_any(std::span<const Ray> rays, std::span<uint8_t> occluded) const override {
    if (bvh_.empty()) return std::fill(occluded.begin(), occluded.end(), uint8_t{0});
    run(rays, [&](const WideBatch& batch, std::size_t begin) {
      WideBatch b = batch;
      b.occluded = occluded.data() + begin;
      any_(b);
    });
  }
  TraceCounts count_closest(std::span<const Ray> rays) const override { return count(rays, count_closest_); }
  TraceCounts count_any(std::span<const Ray> rays) const override { return count(rays, count_any_); }
  std::size_t bytes() const override { return bvh_.bytes(); }
  void refit(std::span<const Triangle> triangles) override {
    if (triangles.size() != triangle_count_)
      throw Error("layout bvh" + std::to_string(N) + ": refit with " + std::to_string(triangles.size()) +
                  " triangles, compiled over " + std::to_string(triangle_count_));
    refit_wide(bvh_, triangles);
  }
  std::string isa() const override { return std::string(to_string(isa_)); }

 private:
  // Sets up chunks of rays and hands each to `kernel(batch, first ray index)`, in parallel.
  template <class Kernel>
  void run(std::span<const Ray> rays, Kernel kernel) const {
    for_each_ray_chunk(rays.size(), kWideChunk, [&](std::size_t begin, std::size_t end) {
      WideRay setup[kWideChunk];
      for (std::size_t i = begin; i < end; i += kWideChunk) {
        const std::size_t n = std::min(kWideChunk, end - i);
        const WideRaysInfo info = make_wide_rays(rays.subspan(i, n), setup, shear_, box_);
        kernel(WideBatch{bvh_.root_planes, bvh_.arena.data(), setup, n, nullptr, nullptr, nullptr,
                         any_hit_order_, info.int_order, info.robust_box, shadow_cache_},
               i);
      }
    });
  }

  TraceCounts count(std::span<const Ray> rays, WideKernel kernel) const {
    if (bvh_.empty()) return {rays.size(), 0, 0};
    return sum_over_ray_chunks(rays.size(), kWideChunk, [&](std::size_t begin, std::size_t end) {
      WideRay setup[kWideChunk];
      std::vector<Hit> hits(kWideChunk);
      std::vector<uint8_t> occluded(kWideChunk);
      TraceCounts sum;
      for (std::size_t i = begin; i < end; i += kWideChunk) {
        const std::size_t n = std::min(kWideChunk, end - i);
        const WideRaysInfo info = make_wide_rays(rays.subspan(i, n), setup, shear_, box_);
        WideCounts c;
        kernel(WideBatch{bvh_.root_planes, bvh_.arena.data(), setup, n, hits.data(), occluded.data(), &c,
                         any_hit_order_, info.int_order, info.robust_box});
        sum.rays += c.rays;
        sum.nodes_visited += c.inner_visits + c.leaf_visits;
        sum.prims_tested += c.prim_tests;
        sum.leaves_visited += c.leaf_visits;
      }
      return sum;
    });
  }

  WideBvh<N> bvh_;
  std::size_t triangle_count_;
  KernelIsa isa_;
  bool shear_;  // the rays need the watertight shear (make_wide_ray)
  BoxTestKind box_;
  AnyHitOrder any_hit_order_;  // resolved (bvh2_traversal.h: resolve_any_hit_order)
  bool shadow_cache_;          // LayoutSpec::shadow_cache
  WideKernel closest_ = nullptr, any_ = nullptr, count_closest_ = nullptr, count_any_ = nullptr;
};

}  // namespace

std::unique_ptr<CompiledLayout> compile_wide_layout(uint32_t width, const Bvh& bvh,
                                                    std::span<const Triangle> triangles,
                                                    const LayoutSpec& spec) {
  const KernelIsa isa = layout_kernel_isa(spec);
  const AnyHitOrder any_hit_order = resolve_any_hit_order(bvh, spec.variant.any_hit);
  const BlockForm form = block_form_for(spec.variant.triangle);
  if (width == 4)
    return std::make_unique<WideLayout<4>>(compile_wide<4>(bvh, triangles, form), triangles.size(), isa,
                                           spec.variant, any_hit_order, spec.packet, spec.shadow_cache);
  if (width == 8)
    return std::make_unique<WideLayout<8>>(compile_wide<8>(bvh, triangles, form), triangles.size(), isa,
                                           spec.variant, any_hit_order, spec.packet, spec.shadow_cache);
  throw Error("no " + std::to_string(width) + "-wide layout");
}

}  // namespace sahbench
