#pragma once
// What the two binary layouts, bvh2 (layouts.cpp) and bvh2_packed (packed_bvh2.cpp), do alike with a
// batch of rays: chunks of kBinaryRayChunk rays, a few to a task (ray_chunks.h), each traced one ray at a
// time with several walks in flight (detail::trace_walks) or in packets of 8 or 16 rays
// (detail::trace_in_packets). They differ in the walk, the packet kernel and what a closest hit's triangle
// is.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "core/ray.h"
#include "traversal/bvh2_traversal.h"
#include "traversal/kernel_variant.h"
#include "traversal/layout.h"
#include "traversal/ray_chunks.h"

namespace sahbench::detail {

/// Rays handed to one task: enough to amortise scheduling, few enough to balance incoherent rays. A chunk
/// starts at a multiple of it, so packets are cut at the same rays whatever the thread count.
inline constexpr std::size_t kBinaryRayChunk = 256;

/// The batch side of a binary layout whose box test is `Box`. `Derived` provides
///   template <bool kAnyHit, class Index, class Put>
///   void trace_alone(std::span<const Ray> rays, std::size_t n, Index&& index, Put&& put) const;
///     rays[index(j)], j in [0, n), one at a time; `put(i, hit)` takes ray i's answer;
///   template <bool kAnyHit>
///   void trace_packet(const Ray* packet, uint32_t n, uint32_t mask, Hit* hits, uint8_t* occluded) const;
///     the rays of `mask` among packet[0, n) by the packet kernel of its `isa`;
///   bool root_is_inner() const;  whether packets apply (not a tree that is one leaf, or none);
///   void finish_closest(std::span<Hit> hits) const;  a chunk's answers made the scene's triangles.
template <class Derived, class Box>
class BinaryLayout : public CompiledLayout {
 public:
  void trace_closest(std::span<const Ray> rays, std::span<Hit> hits) const final {
    for_each_ray_chunk(rays.size(), kBinaryRayChunk, [&](std::size_t begin, std::size_t end) {
      trace_chunk<false>(rays, begin, end, hits.data(), nullptr);
      self().finish_closest(hits.subspan(begin, end - begin));
    });
  }
  void trace_any(std::span<const Ray> rays, std::span<uint8_t> occluded) const final {
    for_each_ray_chunk(rays.size(), kBinaryRayChunk, [&](std::size_t begin, std::size_t end) {
      trace_chunk<true>(rays, begin, end, nullptr, occluded.data());
    });
  }
  std::string isa() const final { return std::string(to_string(isa_)); }

 protected:
  /// `packet` 1: the single-ray kernel (whose ISA is reported as scalar); 8 or 16: packets of `isa`.
  BinaryLayout(uint32_t packet, KernelIsa isa)
      : packet_(packet), isa_(packet == 1 ? KernelIsa::kScalar : isa) {}

  uint32_t packet() const { return packet_; }

 private:
  const Derived& self() const { return static_cast<const Derived&>(*this); }

  // Rays [begin, end) into hits (closest hit) or occluded (any hit).
  template <bool kAnyHit>
  void trace_chunk(std::span<const Ray> rays, std::size_t begin, std::size_t end, Hit* hits,
                   uint8_t* occluded) const {
    auto alone = [&](std::size_t n, auto&& index, auto&& put) {
      self().template trace_alone<kAnyHit>(rays, n, index, put);
    };
    if (packet_ == 1) {
      alone(
          end - begin, [&](std::size_t j) { return begin + j; },
          [&](std::size_t i, const Hit& hit) {
            if constexpr (kAnyHit)
              occluded[i] = hit.found();
            else
              hits[i] = hit;
          });
      return;
    }
    trace_in_packets<Box, kAnyHit>(
        rays, begin, end, packet_, self().root_is_inner(), hits, occluded,
        [&](const Ray* packet, uint32_t n, uint32_t mask, Hit* h, uint8_t* o) {
          self().template trace_packet<kAnyHit>(packet, n, mask, h, o);
        },
        alone);
  }

  uint32_t packet_;
  KernelIsa isa_;  // of the packet kernels; scalar for the single-ray kernel
};

}  // namespace sahbench::detail
