#include "traversal/packed_bvh2.h"

#include <tbb/parallel_for.h>

#include <utility>

#include "core/error.h"
#include "traversal/binary_layout.h"
#include "traversal/ray_chunks.h"
#include "traversal/variant_dispatch.h"
#include "traversal/wide_kernels_isa.h"

namespace sahbench {

PackedBvh2 PackedBvh2::compile(const Bvh& bvh, std::span<const Triangle> triangles) {
  PackedBvh2 out;
  if (bvh.nodes.empty()) return out;
  out.empty = false;
  out.triangles.reserve(bvh.prim_refs.size());
  out.ids.reserve(bvh.prim_refs.size());
  out.nodes.reserve(bvh.nodes.size() / 2);
  out.root_box = bvh.root().bounds;

  // A child of the common format as a PairNode child: a leaf's triangles are appended when it is met,
  // an inner node gets the next PairNode and is expanded later (depth first, left child first).
  std::vector<std::pair<uint32_t, uint32_t>> stack;  // (common-format node, its PairNode)
  auto place = [&](uint32_t from, uint32_t& child, uint32_t& count) {
    const Node& node = bvh.nodes[from];
    if (node.is_leaf()) {
      child = static_cast<uint32_t>(out.ids.size());
      count = node.prim_count;
      for (uint32_t r = node.first; r < node.first + node.prim_count; ++r) {
        out.ids.push_back(bvh.prim_refs[r]);
        out.triangles.push_back(triangles[bvh.prim_refs[r]]);
      }
    } else {
      child = static_cast<uint32_t>(out.nodes.size());
      count = 0;
      out.nodes.emplace_back();
      stack.push_back({from, child});
    }
  };
  place(0, out.root, out.root_count);
  while (!stack.empty()) {
    const auto [from, to] = stack.back();
    stack.pop_back();
    const Node& node = bvh.nodes[from];
    for (uint32_t c = 0; c < 2; ++c)
      out.nodes[to].set_box(static_cast<int>(c), bvh.nodes[node.first + c].bounds);
    uint32_t child[2], count[2];
    place(node.first, child[0], count[0]);
    place(node.first + 1, child[1], count[1]);
    // Both inner: the left one on top of the stack, so its subtree is laid out first.
    if (count[0] == 0 && count[1] == 0) std::swap(stack[stack.size() - 2], stack.back());
    for (uint32_t c = 0; c < 2; ++c) {
      out.nodes[to].child[c] = child[c];
      out.nodes[to].count[c] = count[c];
    }
  }
  return out;
}

void PackedBvh2::refit(std::span<const Triangle> scene_triangles) {
  if (empty) return;
  tbb::parallel_for(std::size_t{0}, ids.size(),
                    [&](std::size_t i) { triangles[i] = scene_triangles[ids[i]]; });
  auto leaf_box = [&](uint32_t first, uint32_t count) {
    Aabb box;
    for (uint32_t i = first; i < first + count; ++i) box.extend(triangles[i].bounds());
    return box;
  };
  auto union_of = [](const PairNode& n) { return n.box(0).extend(n.box(1)); };
  // Children come after their parent, so a pass from the back sees every inner child refitted first.
  for (std::size_t i = nodes.size(); i-- > 0;) {
    PairNode& node = nodes[i];
    for (int c = 0; c < 2; ++c)
      node.set_box(
          c, node.count[c] != 0 ? leaf_box(node.child[c], node.count[c]) : union_of(nodes[node.child[c]]));
  }
  root_box = root_count != 0 ? leaf_box(root, root_count) : union_of(nodes[root]);
}

namespace {

// The packet kernels of `isa` (AVX2 or AVX-512) for `variant`; nullptr where none are compiled in.
PairPacketKernel find_pair_packet_kernel([[maybe_unused]] KernelIsa isa,
                                         [[maybe_unused]] const KernelVariant& variant,
                                         [[maybe_unused]] bool any_hit, [[maybe_unused]] uint32_t packet) {
#if defined(SAHBENCH_HAVE_X86_KERNELS)
  if (isa == KernelIsa::kAvx2) return detail::pair_packet_kernel_avx2(variant, any_hit, packet);
  if (isa == KernelIsa::kAvx512) return detail::pair_packet_kernel_avx512(variant, any_hit, packet);
#endif
  return nullptr;
}

template <class Tri, class Box>
class PackedBvh2Layout final : public detail::BinaryLayout<PackedBvh2Layout<Tri, Box>, Box> {
  using Base = detail::BinaryLayout<PackedBvh2Layout<Tri, Box>, Box>;
  friend Base;

 public:
  /// `packet` 1: the single-ray kernel; 8 or 16: the packet kernels of `isa`.
  PackedBvh2Layout(const Bvh& bvh, std::span<const Triangle> triangles, const KernelVariant& variant,
                   uint32_t packet, KernelIsa isa)
      : Base(packet, isa),
        tree_(PackedBvh2::compile(bvh, triangles)),
        scene_triangles_(triangles.size()),
        order_(resolve_any_hit_order(bvh, variant.any_hit)) {
    if (packet == 1) return;
    closest_packet_ = find_pair_packet_kernel(isa, variant, false, packet);
    any_packet_ = find_pair_packet_kernel(isa, variant, true, packet);
    if (!closest_packet_ || !any_packet_)
      throw Error("layout bvh2_packed: no " + std::string(to_string(isa)) + " " + std::to_string(packet) +
                  "-ray packet kernels compiled in");
  }

  TraceCounts count_closest(std::span<const Ray> rays) const override { return count<false>(rays); }
  TraceCounts count_any(std::span<const Ray> rays) const override { return count<true>(rays); }

  void refit(std::span<const Triangle> triangles) override {
    if (triangles.size() != scene_triangles_)
      throw Error("refit with " + std::to_string(triangles.size()) + " triangles, compiled over " +
                  std::to_string(scene_triangles_));
    tree_.refit(triangles);
  }

  std::size_t bytes() const override { return tree_.bytes(); }

 private:
  template <bool kAnyHit>
  TraceCounts count(std::span<const Ray> rays) const {
    return sum_over_ray_chunks(rays.size(), detail::kBinaryRayChunk, [&](std::size_t begin, std::size_t end) {
      TraversalCounters counters;
      for (std::size_t i = begin; i != end; ++i)
        detail::traverse_packed<Tri, Box, kAnyHit, true>(tree_, rays[i], &counters, order_);
      return TraceCounts{end - begin, counters.nodes_visited(), counters.prim_tests, counters.leaf_visits};
    });
  }

  // What detail::BinaryLayout asks of a binary layout.
  template <bool kAnyHit, class Index, class Put>
  void trace_alone(std::span<const Ray> rays, std::size_t n, Index&& index, Put&& put) const {
    using Walk = detail::PackedWalk<Tri, Box, kAnyHit, false>;
    detail::trace_walks<Walk, Box>(
        rays, n, index,
        [&](std::optional<Walk>& walk, const Ray& ray) { walk.emplace(tree_, ray, nullptr, order_); },
        [&](const Ray& ray) {
          return detail::traverse_packed<Tri, Box, kAnyHit, false>(tree_, ray, nullptr, order_);
        },
        put);
  }
  template <bool kAnyHit>
  void trace_packet(const Ray* packet, uint32_t n, uint32_t mask, Hit* hits, uint8_t* occluded) const {
    (kAnyHit ? any_packet_ : closest_packet_)(tree_, packet, n, mask, order_, hits, occluded);
  }
  bool root_is_inner() const { return !tree_.empty && tree_.root_count == 0; }
  // The kernels answer with packed triangle indices.
  void finish_closest(std::span<Hit> hits) const {
    for (Hit& hit : hits)
      if (hit.found()) hit.prim = tree_.ids[hit.prim];
  }

  PackedBvh2 tree_;
  std::size_t scene_triangles_;  // for refit's check
  AnyHitOrder order_;
  PairPacketKernel closest_packet_ = nullptr, any_packet_ = nullptr;
};

}  // namespace

std::unique_ptr<CompiledLayout> compile_packed_bvh2(const Bvh& bvh, std::span<const Triangle> triangles,
                                                    const LayoutSpec& spec) {
  const KernelIsa isa = spec.packet == 1 ? KernelIsa::kScalar : layout_kernel_isa(spec);
  return with_test_types(spec.variant, [&]<class Tri, class Box>() -> std::unique_ptr<CompiledLayout> {
    return std::make_unique<PackedBvh2Layout<Tri, Box>>(bvh, triangles, spec.variant, spec.packet, isa);
  });
}

}  // namespace sahbench
