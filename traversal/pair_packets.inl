// Packet kernels on bvh2_packed: K rays go down the binary tree together, each PairNode read once for
// all of them and each of its two child boxes tested against the K rays in one K-lane slab test, the
// packet traversal of binary BVHs of Wald, Boulos and Shirley 2007 ("Ray Tracing Deformable Scenes Using
// Dynamic Bounding Volume Hierarchies"), without its frustum test. A binary tree takes several times as
// many node visits per ray as a wide one, and one ray's visit is a chain of a dependent load, a box test
// and a branch; a packet pays that chain once for K rays. Compiled for AVX2 and AVX-512 only
// (wide_kernels_avx2.cpp, wide_kernels_avx512.cpp include it after wide_packets.inl, whose lanes, packet
// rays and box test it uses).
//
// Packets are the batch's rays K at a time, in the ray set's own order, as for the wide packet kernels. A
// packet goes down the tree together only when its rays agree on the sign of each direction component
// (one near and one far plane per axis serve all K) and (box=fma) every ray is in that test's domain;
// otherwise its rays are traced two at a time by the single-ray kernel (packed_bvh2.cpp). Each lane
// computes the single-ray kernel's slab test (PairSlabs: the same products, the far distances scaled the
// same way, the same NaN rule) and every leaf's triangles are tested ray by ray with the layout's
// triangle test, so every ray gets the hit it gets alone, up to a tie within a rounding that the other
// order of the visits breaks the other way.

// The BoxTestKind of a box test class of ray_box.h.
template <class Box>
inline constexpr BoxTestKind kBoxKindOf = std::is_same_v<Box, FmaRayBox>    ? BoxTestKind::kFma
                                          : std::is_same_v<Box, FastRayBox> ? BoxTestKind::kFast
                                                                            : BoxTestKind::kRobust;

// The packet's slab constants from each ray's SlabSetup, as PairSlabs takes them. The planes a packet
// reads are those of PairNode::planes seen two floats apart (min x, max x, min y, ... of one child), so
// that plane i of a child is 2 * axis + (0 for min, 1 for max).
template <class P>
SAHBENCH_KERNEL_INLINE PacketRays<P> make_pair_packet(const Ray* rays, uint32_t n, uint32_t lead) {
  alignas(64) float lanes[13][P::kWidth];
  PacketRays<P> p;
  p.mtn_in_double = 0;
  for (uint32_t j = 0; j < P::kWidth; ++j) {
    const Ray& r = rays[j < n ? j : 0];  // unused lanes copy ray 0 and are never active
    const detail::SlabSetup setup(r);
    const float dir[3] = {r.dir.x, r.dir.y, r.dir.z};
    for (uint32_t axis = 0; axis < 3; ++axis) {
      lanes[axis][j] = setup.org[axis];
      lanes[3 + axis][j] = dir[axis];
      lanes[6 + axis][j] = setup.inv_dir[axis];
      lanes[9 + axis][j] = setup.org[axis] * setup.inv_dir[axis];
    }
    lanes[12][j] = r.tmin;
  }
  const detail::SlabSetup first(rays[lead]);
  for (uint32_t axis = 0; axis < 3; ++axis) {
    p.org[axis] = P::load(lanes[axis]);
    p.dir[axis] = P::load(lanes[3 + axis]);
    p.inv[axis] = P::load(lanes[6 + axis]);
    p.org_inv[axis] = P::load(lanes[9 + axis]);
    p.near_plane[axis] = 2 * axis + (first.negative[axis] ? 1 : 0);
    p.far_plane[axis] = 2 * axis + (first.negative[axis] ? 0 : 1);
  }
  p.tmin = P::load(lanes[12]);
  return p;
}

// The rays of `mask` among rays [0, n) as one packet (of one direction octant, detail::pair_octant),
// closest hits (packed triangle indices) into hits[j] or occlusion into occluded[j] for each j of `mask`. The
// tree's root is an inner node. Flattened: the single-ray code it calls (the triangle tests, the ray set-up)
// is inlined here, compiled for this instruction set, and leaves no out-of-line copy that the linker could
// pick for the baseline callers. Closest hit goes first to the child whose nearest ray enters it nearer and
// skips, per lane, entries beyond that ray's closest hit so far; any hit takes `order` as the single-ray walk
// does, by the packet's nearest entries, and drops each ray at its first hit.
template <class P, class Tri, class Box, bool kAnyHit>
[[gnu::flatten]] void trace_pair_packet(const PackedBvh2& tree, const Ray* rays, uint32_t n, uint32_t mask,
                                        AnyHitOrder order, Hit* hits, uint8_t* occluded) {
  using V = typename P::V;
  constexpr uint32_t K = P::kWidth;
  constexpr BoxTestKind kBox = kBoxKindOf<Box>;
  const PacketRays<P> p = make_pair_packet<P>(rays, n, static_cast<uint32_t>(__builtin_ctz(mask)));
  const V nan = P::set1(__builtin_nanf(""));
  alignas(64) float best_t[K];
  float tmin[K];
  for (uint32_t j = 0; j < K; ++j) {
    best_t[j] = mask >> j & 1u ? far_limit(rays[j]) : __builtin_nanf("");
    tmin[j] = rays[j < n ? j : 0].tmin;
  }
  Hit best[K];
  // Each ray's triangle test, set up once (the watertight test's shear, for one).
  union Tests {
    Tests() {}
    Tri lane[K];
  } tests;
  for (uint32_t j = 0; j < K; ++j) new (&tests.lane[j]) Tri(rays[j < n ? j : 0]);
  static_assert(std::is_trivially_destructible_v<Tri>);

  const Aabb& box = tree.root_box;
  const float root_planes[6] = {box.min[0], box.max[0], box.min[1], box.max[1], box.min[2], box.max[2]};
  uint32_t root_mask;
  const V t_root = packet_enter<P, kBox>(root_planes, 1, p, P::load(best_t), root_mask);
  const bool nearest_first =
      !kAnyHit || order == AnyHitOrder::kNearest || order == AnyHitOrder::kNearestStored;
  const bool farthest_first = kAnyHit && order == AnyHitOrder::kFarthestStored;

  PacketEntry<P> stack[detail::kStackCapacity];
  uint32_t size = 0;
  PacketEntry<P> entry{P::select(root_mask, t_root, nan), tree.root, 0};
  while (root_mask != 0) {
    const V tmax = P::load(best_t);
    const uint32_t lanes = P::le(entry.t_entry, tmax);
    if (lanes != 0) {
      if (entry.count != 0) {
        const uint32_t end = entry.child + entry.count;
        uint32_t active = lanes;
        for (uint32_t prim = entry.child; prim < end && active; ++prim) {
          const Triangle& tri = tree.triangles[prim];
          for (uint32_t m = active; m; m &= m - 1) {
            const uint32_t j = static_cast<uint32_t>(__builtin_ctz(m));
            float t, u, v;
            const bool hit = kAnyHit ? intersect_any(tests.lane[j], tri, tmin[j], best_t[j], t, u, v)
                                     : tests.lane[j].intersect(tri, tmin[j], best_t[j], t, u, v);
            if (!hit) continue;
            if constexpr (kAnyHit) {
              best[j] = {prim, t, u, v};
              best_t[j] = __builtin_nanf("");
              active &= ~(1u << j);
            } else if (t < best_t[j] || !best[j].found() || tree.ids[prim] < tree.ids[best[j].prim]) {
              // On a tie the lowest scene index wins, as in the single-ray walk.
              best[j] = {prim, t, u, v};
              best_t[j] = t;
            }
          }
        }
        if constexpr (kAnyHit) {
          if (P::ordered(P::load(best_t)) == 0) break;
        }
      } else {
        const PairNode& node = tree.nodes[entry.child];
        const V active_tmax = P::select(lanes, tmax, nan);
        uint32_t mask[2];
        const V t0 = packet_enter<P, kBox>(&node.planes[0][0], 2, p, active_tmax, mask[0]);
        const V t1 = packet_enter<P, kBox>(&node.planes[0][1], 2, p, active_tmax, mask[1]);
        const PacketEntry<P> child[2] = {{P::select(mask[0], t0, nan), node.child[0], node.count[0]},
                                         {P::select(mask[1], t1, nan), node.child[1], node.count[1]}};
        if (mask[0] != 0 && mask[1] != 0) {
          int first = 0;
          if (nearest_first || farthest_first) {
            const V inf = P::set1(__builtin_inff());
            const float near0 = P::min_lane(P::select(mask[0], t0, inf));
            const float near1 = P::min_lane(P::select(mask[1], t1, inf));
            first = (farthest_first ? near1 > near0 : near1 < near0) ? 1 : 0;
          }
          if (size == detail::kStackCapacity) [[unlikely]]
            detail::throw_stack_overflow(entry.child, 2);
          stack[size++] = child[1 - first];
          entry = child[first];
          continue;
        }
        if ((mask[0] | mask[1]) != 0) {
          entry = child[mask[0] != 0 ? 0 : 1];
          continue;
        }
      }
    }
    if (size == 0) break;
    entry = stack[--size];
  }
  for (uint32_t m = mask; m; m &= m - 1) {
    const uint32_t j = static_cast<uint32_t>(__builtin_ctz(m));
    if constexpr (kAnyHit)
      occluded[j] = best[j].found();
    else
      hits[j] = best[j];
  }
}

// The bvh2_packed packet kernel of this instruction set for `variant` and packets of `packet` rays: 8,
// or (AVX-512) 16; nullptr for a width this set has no kernels for.
inline PairPacketKernel select_pair_packet_kernel(const KernelVariant& variant, bool any_hit,
                                                  uint32_t packet) {
  auto table = [&]<class P>() {
    return with_test_types(variant, [&]<class Tri, class Box>() -> PairPacketKernel {
      return any_hit ? &trace_pair_packet<P, Tri, Box, true> : &trace_pair_packet<P, Tri, Box, false>;
    });
  };
  if (packet == Lanes8::kWidth) return table.template operator()<Lanes8>();
#if defined(SAHBENCH_WIDE_AVX512)
  if (packet == Lanes16::kWidth) return table.template operator()<Lanes16>();
#endif
  return nullptr;
}
