// Packet kernels on the wide layouts: K rays traverse the tree together, each node fetched once for all
// of them and each child box tested against the K rays in one K-lane slab test (Wald, Slusallek, Benthin
// and Wagner 2001, "Interactive Rendering with Coherent Ray Tracing"; on wide nodes, Embree's
// BVHNIntersectorK, Wald et al. 2014, "Embree: A Kernel Framework for Efficient CPU Ray Tracing"). K is 8
// (an AVX register; AVX2 and AVX-512) or 16 (an AVX-512 register). Compiled for AVX2 and AVX-512 only
// (wide_kernels_avx2.cpp, wide_kernels_avx512.cpp include it after wide_kernels.inl, whose helpers it
// uses).
//
// Packets are the batch's rays K at a time, in the ray set's own order, as Embree's rtcIntersect8 and
// rtcIntersect16 are fed (primary rays in tiles of 4 x 4 pixels). A packet goes down the tree together only
// when its rays agree on the sign of each direction component, so that one near and one far plane per axis
// serve all K, and (box=fma) every ray is in that test's domain; otherwise its rays are traced one at a
// time by the single-ray kernel. Each lane computes the slab test of intersect_children with the same
// operations in the same order (with box=robust and box=fast, after an interval test of the whole packet
// has dropped the children no ray can enter: packet_cull), and leaves are tested ray by ray with
// intersect_leaf (tri=mtn: a triangle against all the rays at once where most of the packet enters the leaf,
// packet_leaf_mtn), so every ray gets a hit of the single-ray tests; only the order in which nodes and
// triangles are visited differs.

// A packet's rays go on one at a time below a node that this many or fewer of them enter: a packet's
// node visit tests every child against all K lanes in one register, which costs about what a single
// ray's visits of the node would cost for each active ray (for K = 16 too: one AVX-512 instruction does
// what one AVX instruction does for eight).
inline constexpr int kPacketSwitch = 3;

// The lanes of a packet of eight rays: one AVX register, masks as the low bits of an integer.
struct Lanes8 {
  static constexpr uint32_t kWidth = 8;
  using V = __m256;
  using Ops = Ops256;  // intersect_mtn_lanes's operations on the same vectors
  SAHBENCH_KERNEL_INLINE static V load(const float* p) { return _mm256_load_ps(p); }
  SAHBENCH_KERNEL_INLINE static void store(float* p, V v) { _mm256_store_ps(p, v); }
  SAHBENCH_KERNEL_INLINE static V set1(float x) { return _mm256_set1_ps(x); }
  SAHBENCH_KERNEL_INLINE static V broadcast(const float* p) { return _mm256_broadcast_ss(p); }
  SAHBENCH_KERNEL_INLINE static V sub(V a, V b) { return _mm256_sub_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static V mul(V a, V b) { return _mm256_mul_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static V fmsub(V a, V b, V c) { return _mm256_fmsub_ps(a, b, c); }
  SAHBENCH_KERNEL_INLINE static V max(V a, V b) { return _mm256_max_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static V min(V a, V b) { return _mm256_min_ps(a, b); }
  // The lanes where a <= b (false where either is NaN).
  SAHBENCH_KERNEL_INLINE static uint32_t le(V a, V b) {
    return static_cast<uint32_t>(_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LE_OQ)));
  }
  // The lanes that are not NaN.
  SAHBENCH_KERNEL_INLINE static uint32_t ordered(V a) {
    return static_cast<uint32_t>(_mm256_movemask_ps(_mm256_cmp_ps(a, a, _CMP_ORD_Q)));
  }
  // The lanes where a > b is false (true where either is NaN).
  SAHBENCH_KERNEL_INLINE static uint32_t not_greater(V a, V b) {
    return static_cast<uint32_t>(_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_NGT_UQ)));
  }
  // The lanes of `mask` as an all-ones vector mask.
  SAHBENCH_KERNEL_INLINE static V mask_vector(uint32_t mask) {
    const __m256i bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    const __m256i m = _mm256_and_si256(_mm256_set1_epi32(static_cast<int>(mask)), bits);
    return _mm256_castsi256_ps(_mm256_cmpeq_epi32(m, bits));
  }
  // `a` in the lanes of `mask`, `b` in the others.
  SAHBENCH_KERNEL_INLINE static V select(uint32_t mask, V a, V b) {
    return _mm256_blendv_ps(b, a, mask_vector(mask));
  }
  // The smallest lane (no NaN among them).
  SAHBENCH_KERNEL_INLINE static float min_lane(V t) {
    V m = _mm256_min_ps(t, _mm256_permute2f128_ps(t, t, 1));
    m = _mm256_min_ps(m, _mm256_permute_ps(m, _MM_SHUFFLE(1, 0, 3, 2)));
    m = _mm256_min_ps(m, _mm256_permute_ps(m, _MM_SHUFFLE(2, 3, 0, 1)));
    return _mm256_cvtss_f32(m);
  }
};

// The four child slots of a WideNode<4> in one SSE register, for packet_cull.
struct Lanes4 {
  using V = __m128;
  SAHBENCH_KERNEL_INLINE static V load(const float* p) { return _mm_load_ps(p); }
  SAHBENCH_KERNEL_INLINE static V set1(float x) { return _mm_set1_ps(x); }
  SAHBENCH_KERNEL_INLINE static V sub(V a, V b) { return _mm_sub_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static V mul(V a, V b) { return _mm_mul_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static V max(V a, V b) { return _mm_max_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static V min(V a, V b) { return _mm_min_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static uint32_t not_greater(V a, V b) {
    return static_cast<uint32_t>(_mm_movemask_ps(_mm_cmp_ps(a, b, _CMP_NGT_UQ)));
  }
};

#if defined(SAHBENCH_WIDE_AVX512)
// intersect_mtn_lanes's and watertight_in_lanes's operations on sixteen lanes. Its masks are vectors (all
// ones where true), as in Ops256, moved to and from the mask registers of AVX-512 (AVX-512DQ's vpmovm2d and
// vpmovd2m).
struct Ops512 {
  using V = __m512;
  SAHBENCH_KERNEL_INLINE static __m512 set1(float x) { return _mm512_set1_ps(x); }
  SAHBENCH_KERNEL_INLINE static __m512 add(__m512 a, __m512 b) { return _mm512_add_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m512 sub(__m512 a, __m512 b) { return _mm512_sub_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m512 mul(__m512 a, __m512 b) { return _mm512_mul_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m512 div(__m512 a, __m512 b) { return _mm512_div_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m512 fmadd(__m512 a, __m512 b, __m512 c) {
    return _mm512_fmadd_ps(a, b, c);
  }
  SAHBENCH_KERNEL_INLINE static __m512 fmsub(__m512 a, __m512 b, __m512 c) {
    return _mm512_fmsub_ps(a, b, c);
  }
  SAHBENCH_KERNEL_INLINE static __m512 and_(__m512 a, __m512 b) { return _mm512_and_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m512 xor_(__m512 a, __m512 b) { return _mm512_xor_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m512 or_(__m512 a, __m512 b) { return _mm512_or_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m512 andnot(__m512 a, __m512 b) { return _mm512_andnot_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m512 from_mask(__mmask16 m) {
    return _mm512_castsi512_ps(_mm512_movm_epi32(m));
  }
  SAHBENCH_KERNEL_INLINE static __m512 ge(__m512 a, __m512 b) {
    return from_mask(_mm512_cmp_ps_mask(a, b, _CMP_GE_OQ));
  }
  SAHBENCH_KERNEL_INLINE static __m512 le(__m512 a, __m512 b) {
    return from_mask(_mm512_cmp_ps_mask(a, b, _CMP_LE_OQ));
  }
  SAHBENCH_KERNEL_INLINE static __m512 lt(__m512 a, __m512 b) {
    return from_mask(_mm512_cmp_ps_mask(a, b, _CMP_LT_OQ));
  }
  SAHBENCH_KERNEL_INLINE static __m512 gt(__m512 a, __m512 b) {
    return from_mask(_mm512_cmp_ps_mask(a, b, _CMP_GT_OQ));
  }
  SAHBENCH_KERNEL_INLINE static __m512 neq(__m512 a, __m512 b) {
    return from_mask(_mm512_cmp_ps_mask(a, b, _CMP_NEQ_UQ));
  }
  SAHBENCH_KERNEL_INLINE static int movemask(__m512 a) {
    return static_cast<int>(_mm512_movepi32_mask(_mm512_castps_si512(a)));
  }
  SAHBENCH_KERNEL_INLINE static void store(float* p, __m512 a) { _mm512_storeu_ps(p, a); }
};

// The lanes of a packet of sixteen rays: one AVX-512 register, masks in mask registers.
struct Lanes16 {
  static constexpr uint32_t kWidth = 16;
  using V = __m512;
  using Ops = Ops512;
  SAHBENCH_KERNEL_INLINE static V load(const float* p) { return _mm512_load_ps(p); }
  SAHBENCH_KERNEL_INLINE static void store(float* p, V v) { _mm512_store_ps(p, v); }
  SAHBENCH_KERNEL_INLINE static V set1(float x) { return _mm512_set1_ps(x); }
  SAHBENCH_KERNEL_INLINE static V broadcast(const float* p) { return _mm512_set1_ps(*p); }
  SAHBENCH_KERNEL_INLINE static V sub(V a, V b) { return _mm512_sub_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static V mul(V a, V b) { return _mm512_mul_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static V fmsub(V a, V b, V c) { return _mm512_fmsub_ps(a, b, c); }
  // The zero-masked forms with every lane kept: GCC 12's unmasked ones pass an undefined vector as their
  // unused source, which -Wuninitialized reports.
  SAHBENCH_KERNEL_INLINE static V max(V a, V b) { return _mm512_maskz_max_ps(0xFFFF, a, b); }
  SAHBENCH_KERNEL_INLINE static V min(V a, V b) { return _mm512_maskz_min_ps(0xFFFF, a, b); }
  SAHBENCH_KERNEL_INLINE static uint32_t le(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
  SAHBENCH_KERNEL_INLINE static uint32_t ordered(V a) { return _mm512_cmp_ps_mask(a, a, _CMP_ORD_Q); }
  SAHBENCH_KERNEL_INLINE static V mask_vector(uint32_t mask) {
    return Ops512::from_mask(static_cast<__mmask16>(mask));
  }
  SAHBENCH_KERNEL_INLINE static V select(uint32_t mask, V a, V b) {
    return _mm512_mask_blend_ps(static_cast<__mmask16>(mask), b, a);
  }
  // Halves taken zero-masked too, for the reason above.
  SAHBENCH_KERNEL_INLINE static float min_lane(V t) {
    return Lanes8::min_lane(
        _mm256_min_ps(_mm512_maskz_extractf32x8_ps(0xFF, t, 0), _mm512_maskz_extractf32x8_ps(0xFF, t, 1)));
  }
};
#endif

// The K rays' slab constants, one lane each, and the planes they share.
template <class P>
struct PacketRays {
  using V = typename P::V;
  V org[3];
  V dir[3];
  V inv[3];
  V org_inv[3];
  V tmin;
  uint32_t near_plane[3];
  uint32_t far_plane[3];
  uint32_t mtn_in_double;  // tri=mtn: the lanes whose ray the float test cannot take (WideRay::mtn_in_double)
  // Per-lane planes (packet_enter's kPerLane, the binary layouts' packets): near_plane and far_plane are
  // then the min and max planes, and these the lanes whose direction is negative on each axis, which take
  // them the other way round.
  uint32_t negative[3];
};

// Bounds of the packet's slab constants over all its rays, for testing a node's children against the
// whole packet at once (packet_cull). Only where every ray's origin and reciprocal direction are finite
// and the reciprocal is not zero (`valid`): then no slab distance is NaN and each is monotonic in these
// constants, which is what makes the bounds hold (packet_cull).
struct PacketBounds {
  bool valid = false;
  float inv_lo[3], inv_hi[3];  // the reciprocal directions' range (one sign per axis in a packet)
  float o_near[3], o_far[3];   // the origin giving the lowest near and the highest far distance
  float tmin_lo, tmax_hi;      // the lowest tmin, the highest tmax
};

// Rays [0, n) of a coherent packet (packet_coherent: one sign per axis), bounded.
SAHBENCH_KERNEL_INLINE PacketBounds make_packet_bounds(const WideRay* rays, uint32_t n) {
  PacketBounds b;
  float o_lo[3], o_hi[3];
  for (uint32_t axis = 0; axis < 3; ++axis) {
    b.inv_lo[axis] = b.inv_hi[axis] = rays[0].inv_dir[axis];
    o_lo[axis] = o_hi[axis] = rays[0].org[axis];
  }
  b.tmin_lo = rays[0].tmin;
  b.tmax_hi = rays[0].tmax;
  for (uint32_t j = 0; j < n; ++j) {
    const WideRay& r = rays[j];
    // Builtins and plain comparisons rather than std::isfinite or std::min: this file is compiled once
    // per instruction set, and calls to shared inline functions may link to another set's copy
    // (wide_kernels.inl).
    for (uint32_t axis = 0; axis < 3; ++axis) {
      const float inv = r.inv_dir[axis], org = r.org[axis];
      if (!__builtin_isfinite(inv) || inv == 0.0f || !__builtin_isfinite(org)) return b;
      b.inv_lo[axis] = inv < b.inv_lo[axis] ? inv : b.inv_lo[axis];
      b.inv_hi[axis] = inv > b.inv_hi[axis] ? inv : b.inv_hi[axis];
      o_lo[axis] = org < o_lo[axis] ? org : o_lo[axis];
      o_hi[axis] = org > o_hi[axis] ? org : o_hi[axis];
    }
    if (__builtin_isnan(r.tmin) || __builtin_isnan(r.tmax)) return b;
    b.tmin_lo = r.tmin < b.tmin_lo ? r.tmin : b.tmin_lo;
    b.tmax_hi = r.tmax > b.tmax_hi ? r.tmax : b.tmax_hi;
  }
  for (uint32_t axis = 0; axis < 3; ++axis) {
    // (plane - org) * inv falls as org rises where inv > 0, and rises where inv < 0; the bounds need one
    // sign per axis, which packet_coherent gives (checked again here, as nothing else would catch it).
    const bool positive = b.inv_lo[axis] > 0.0f;
    if (positive != (b.inv_hi[axis] > 0.0f)) return b;
    b.o_near[axis] = positive ? o_hi[axis] : o_lo[axis];
    b.o_far[axis] = positive ? o_lo[axis] : o_hi[axis];
  }
  b.valid = true;
  return b;
}

// A child slot entered by some of the packet's rays: their entry distances, NaN in the other lanes (a
// NaN entry compares false with everything, so those lanes never take the entry up again).
template <class P>
struct PacketEntry {
  typename P::V t_entry;
  uint32_t child;
  uint32_t count;  // 0: inner node `child`; else a leaf of `count` blocks from `child`
};

// Whether rays [0, n) can go down the tree as one packet (the file's opening comment).
template <BoxTestKind kBox>
SAHBENCH_KERNEL_INLINE bool packet_coherent(const WideRay* rays, uint32_t n) {
  for (uint32_t j = 0; j < n; ++j) {
    if constexpr (kBox == BoxTestKind::kFma) {
      if (rays[j].robust_box) return false;
    }
    for (uint32_t axis = 0; axis < 3; ++axis)
      if (rays[j].near_plane[axis] != rays[0].near_plane[axis]) return false;
  }
  return true;
}

template <class P>
SAHBENCH_KERNEL_INLINE PacketRays<P> make_packet(const WideRay* rays, uint32_t n) {
  alignas(64) float lanes[13][P::kWidth];
  PacketRays<P> p;
  p.mtn_in_double = 0;
  p.negative[0] = p.negative[1] = p.negative[2] = 0;
  for (uint32_t j = 0; j < P::kWidth; ++j) {
    const WideRay& r = rays[j < n ? j : 0];  // unused lanes copy ray 0 and are never active
    for (uint32_t axis = 0; axis < 3; ++axis) {
      lanes[axis][j] = r.org[axis];
      lanes[3 + axis][j] = r.dir[axis];
      lanes[6 + axis][j] = r.inv_dir[axis];
      lanes[9 + axis][j] = r.org_inv[axis];
    }
    lanes[12][j] = r.tmin;
    p.mtn_in_double |= static_cast<uint32_t>(r.mtn_in_double) << j;
  }
  for (uint32_t axis = 0; axis < 3; ++axis) {
    p.org[axis] = P::load(lanes[axis]);
    p.dir[axis] = P::load(lanes[3 + axis]);
    p.inv[axis] = P::load(lanes[6 + axis]);
    p.org_inv[axis] = P::load(lanes[9 + axis]);
    p.near_plane[axis] = rays[0].near_plane[axis];
    p.far_plane[axis] = rays[0].far_plane[axis];
  }
  p.tmin = P::load(lanes[12]);
  return p;
}

// One box, given as six planes `stride` floats apart (min x, max x, min y, ...), against the packet's
// rays within [tmin, tmax] per lane: the entry distances, and in `mask` the lanes that enter it. A lane
// whose tmax is NaN enters nothing. With kPerLane each lane picks its near and far plane by the sign of
// its own direction (PacketRays::negative), a blend before the same arithmetic, so that rays of every
// octant can share a packet.
template <class P, BoxTestKind kBox, bool kPerLane = false>
SAHBENCH_KERNEL_INLINE typename P::V packet_enter(const float* planes, uint32_t stride,
                                                  const PacketRays<P>& p, typename P::V tmax,
                                                  uint32_t& mask) {
  using V = typename P::V;
  V t_near = p.tmin, t_far = tmax;
  for (uint32_t axis = 0; axis < 3; ++axis) {
    V near = P::broadcast(planes + p.near_plane[axis] * stride);
    V far = P::broadcast(planes + p.far_plane[axis] * stride);
    if constexpr (kPerLane) {
      const V lo = near;
      near = P::select(p.negative[axis], far, lo);
      far = P::select(p.negative[axis], lo, far);
    }
    V t0, t1;
    if constexpr (kBox == BoxTestKind::kFma) {
      t0 = P::fmsub(near, p.inv[axis], p.org_inv[axis]);
      t1 = P::fmsub(far, p.inv[axis], p.org_inv[axis]);
    } else {
      t0 = P::mul(P::sub(near, p.org[axis]), p.inv[axis]);
      t1 = P::mul(P::sub(far, p.org[axis]), p.inv[axis]);
      if constexpr (kBox == BoxTestKind::kRobust) t1 = P::mul(t1, P::set1(kWideFarScale));
    }
    t_near = P::max(t0, t_near);
    t_far = P::min(t1, t_far);
  }
  mask = P::le(t_near, t_far);
  return t_near;
}

// The slots of `node` that hold a child: an empty slot's box is inverted, its min x +inf (wide_bvh.h).
// Read from the planes, which the box tests load anyway, rather than from the child line.
template <uint32_t N>
SAHBENCH_KERNEL_INLINE uint32_t occupied_slots(const WideNode<N>& node) {
  const __m256 inf = _mm256_set1_ps(__builtin_inff());
  if constexpr (N == 8)
    return static_cast<uint32_t>(
        _mm256_movemask_ps(_mm256_cmp_ps(_mm256_load_ps(node.planes[0]), inf, _CMP_NEQ_UQ)));
  else
    return static_cast<uint32_t>(
        _mm_movemask_ps(_mm_cmp_ps(_mm_load_ps(node.planes[0]), _mm256_castps256_ps128(inf), _CMP_NEQ_UQ)));
}

// The slots of `node` whose box some ray of the packet may enter, all children at once in the lanes: an
// interval test of the whole packet (Boulos et al. 2006, "Geometric and Arithmetic Culling Methods for
// Entire Ray Packets"), in front of packet_enter's test of each child against each ray, as Embree's
// coherent packet traversal tests a frustum of the packet first (its node_intersector_frustum.h). The
// bounds are packet_enter's own float operations on the extreme constants: a rounded subtraction or
// product is monotonic in each operand of fixed sign, so every ray's near distance on an axis is at
// least the smaller of its bound's two products and its far distance (robust: scaled alike) at most the
// larger. A slot whose lowest entry lies beyond its highest exit is entered by no ray; every other is
// tested as before, so each ray enters exactly the children it entered without this test. Not taken by
// box=fma, whose test of a lane is one fused operation per plane: there the interval test cost more
// than it saved on the tuning scenes (README, "Packets").
template <uint32_t N, BoxTestKind kBox>
SAHBENCH_KERNEL_INLINE uint32_t packet_cull(const WideNode<N>& node, const uint32_t (&near_plane)[3],
                                            const uint32_t (&far_plane)[3], const PacketBounds& b) {
  static_assert(kBox != BoxTestKind::kFma, "the bounds follow the subtract-then-multiply slab test");
  using S = std::conditional_t<N == 8, Lanes8, Lanes4>;
  using V = typename S::V;
  V lo = S::set1(b.tmin_lo), hi = S::set1(b.tmax_hi);
  for (uint32_t axis = 0; axis < 3; ++axis) {
    const V near = S::load(node.planes[near_plane[axis]]);
    const V far = S::load(node.planes[far_plane[axis]]);
    const V inv_lo = S::set1(b.inv_lo[axis]), inv_hi = S::set1(b.inv_hi[axis]);
    const V d0 = S::sub(near, S::set1(b.o_near[axis]));
    const V d1 = S::sub(far, S::set1(b.o_far[axis]));
    const V t0 = S::min(S::mul(d0, inv_lo), S::mul(d0, inv_hi));
    V t1 = S::max(S::mul(d1, inv_lo), S::mul(d1, inv_hi));
    if constexpr (kBox == BoxTestKind::kRobust) t1 = S::mul(t1, S::set1(kWideFarScale));
    lo = S::max(t0, lo);
    hi = S::min(t1, hi);
  }
  return S::not_greater(lo, hi);
}

// tri=mtn: the triangles of a leaf against the packet's rays in `lanes`, one triangle at a time in eight
// lanes (intersect_mtn_lanes with the rays in the lanes), as Embree's packet intersectors test their
// Triangle4 against K rays. Each lane computes mtn_lane's operations, so a ray's hit is a hit of the
// single-ray test; a triangle the float test cannot take (NormalBlock::in_double) goes through mtn_lane
// ray by ray. Updates best and best_t as intersect_leaf does (any hit: a ray that hits gets a NaN
// best_t).
template <class P, bool kAnyHit>
SAHBENCH_KERNEL_INLINE void packet_leaf_mtn(const NormalBlock* blocks, uint32_t count, const WideRay* rays,
                                            const PacketRays<P>& p, uint32_t lanes, Hit* best,
                                            float* best_t) {
  for (uint32_t b = 0; b < count && lanes; ++b) {
    const NormalBlock& block = blocks[b];
    for (uint32_t i = 0; i < kBlockWidth && lanes; ++i) {
      const uint32_t prim = block.tri.prim[i];
      if (prim == kInvalidPrim) continue;
      alignas(64) float t[P::kWidth], u[P::kWidth], v[P::kWidth];
      uint32_t hits = 0;
      if (block.in_double >> i & 1u) [[unlikely]] {
        for (uint32_t m = lanes; m; m &= m - 1) {
          const uint32_t j = static_cast<uint32_t>(__builtin_ctz(m));
          if (mtn_lane(block, i, rays[j], rays[j].tmin, best_t[j], t[j], u[j], v[j])) hits |= 1u << j;
        }
      } else {
        auto load = [&](int part, int axis) __attribute__((always_inline)) {
          return P::broadcast(&mtn_part(block, part)[axis][i]);
        };
        const RayLanes<typename P::Ops> r{
            {p.org[0], p.org[1], p.org[2]}, {p.dir[0], p.dir[1], p.dir[2]}, p.tmin, P::load(best_t)};
        hits = intersect_mtn_lanes<typename P::V, typename P::Ops>(P::mask_vector(lanes), load, r, t, u, v);
      }
      for (; hits; hits &= hits - 1) {
        const uint32_t j = static_cast<uint32_t>(__builtin_ctz(hits));
        if constexpr (kAnyHit) {
          best[j] = {prim, t[j], 0.0f, 0.0f};
          best_t[j] = __builtin_nanf("");
          lanes &= ~(1u << j);
        } else if (t[j] < best_t[j] || (t[j] == best_t[j] && prim < best[j].prim)) {
          best[j] = {prim, t[j], u[j], v[j]};
          best_t[j] = t[j];
        }
      }
    }
  }
}

// Rays [0, n) of `rays` as one packet, answers into hits[0, n) or occluded[0, n). Closest hit visits the
// children the packet enters nearest first by their nearest ray's entry (ties to the higher slot), and
// skips, per lane, entries beyond that ray's closest hit so far; any hit visits them in slot order (the
// nearest or farthest of eight rays is not one child; a ray that goes on alone takes kOrder as descend()
// does), drops each ray from the packet at its first hit and, where `found` is given, puts where it found
// it in found[j] (Occluder: the leaf, and the last inner node the packet or the ray alone visited).
template <class P, uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, bool kAnyHit, AnyHitOrder kOrder>
inline void trace_packet(const float* root_planes, const WideUnit* arena, const WideRay* rays, uint32_t n,
                         Hit* hits, uint8_t* occluded, Occluder* found = nullptr) {
  using V = typename P::V;
  constexpr uint32_t K = P::kWidth;
  const PacketRays<P> p = make_packet<P>(rays, n);
  const V nan = P::set1(__builtin_nanf(""));
  alignas(64) float best_t[K];
  for (uint32_t j = 0; j < K; ++j) best_t[j] = j < n ? rays[j].tmax : __builtin_nanf("");
  Hit best[K];
  uint32_t root_mask;
  const V t_root = packet_enter<P, kBox>(root_planes, 1, p, P::load(best_t), root_mask);
  if (root_mask == 0) {
    for (uint32_t j = 0; j < n; ++j) {
      if constexpr (kAnyHit)
        occluded[j] = 0;
      else
        hits[j] = Hit{};
    }
    return;
  }
  [[maybe_unused]] uint32_t node = 0;  // any hit: the last inner node the packet visited
  const PacketBounds bounds = kBox == BoxTestKind::kFma ? PacketBounds{} : make_packet_bounds(rays, n);
  PacketEntry<P> stack[kWideStackCapacity];
  uint32_t size = 0;
  PacketEntry<P> entry{P::select(root_mask, t_root, nan), 0, 0};
  while (true) {
    // The lanes for which the entry is still worth visiting: entered, and (closest hit) not beyond the
    // closest hit so far; equal is kept for the tie rule. A ray dropped by any hit has a NaN best_t.
    const V tmax = P::load(best_t);
    const uint32_t lanes = P::le(entry.t_entry, tmax);
    if (lanes != 0) {
      if (entry.count == 0 && __builtin_popcount(lanes) <= kPacketSwitch) {
        // Few rays left in this subtree: each goes on alone (Embree's hybrid traversal), with its own
        // stack, from its entry into the node.
        alignas(64) float t_entry[K];
        P::store(t_entry, entry.t_entry);
        for (uint32_t m = lanes; m; m &= m - 1) {
          const uint32_t j = static_cast<uint32_t>(__builtin_ctz(m));
          if (trace_subtree<N, kTri, kBox, kAnyHit, false, kOrder, IntOrder::kNone>(
                  arena, rays[j], {entry.child, 0, t_entry[j]}, best[j], best_t[j], nullptr,
                  found ? &found[j] : nullptr))
            best_t[j] = __builtin_nanf("");
        }
      } else if (entry.count != 0) {
        const BlockOf<kTri>* blocks = &at<BlockOf<kTri>>(arena, entry.child);
        uint32_t alone = lanes;  // the rays that test the leaf one at a time
        if constexpr (kTri == TriangleTestKind::kMollerTrumboreNormal) {
          // A triangle against K lanes costs about what one ray against a block of four does, so the
          // packet test pays where more than half the packet is in the leaf.
          const uint32_t together = lanes & ~p.mtn_in_double;
          if (__builtin_popcount(together) > static_cast<int>(K / 2)) {
            packet_leaf_mtn<P, kAnyHit>(blocks, entry.count, rays, p, together, best, best_t);
            alone = lanes & p.mtn_in_double;
          }
        }
        for (uint32_t m = alone; m; m &= m - 1) {
          const uint32_t j = static_cast<uint32_t>(__builtin_ctz(m));
          if (intersect_leaf<kTri, kAnyHit, false>(blocks, entry.count, rays[j], best[j], best_t[j], nullptr))
            best_t[j] = __builtin_nanf("");
        }
        if constexpr (kAnyHit) {
          const uint32_t left = P::ordered(P::load(best_t));
          if (found) {
            for (uint32_t m = lanes & ~left; m; m &= m - 1)
              found[__builtin_ctz(m)] = {entry.child, entry.count, node};
          }
          if (left == 0) break;
        }
      } else {
        if constexpr (kAnyHit) node = entry.child;
        const WideNode<N>& wide = at<WideNode<N>>(arena, entry.child);
        const V active_tmax = P::select(lanes, tmax, nan);
        PacketEntry<P> entered[N];
        uint64_t keys[N < 4 ? 4 : N];
        uint32_t k = 0;
        uint32_t slots = occupied_slots(wide);
        if constexpr (kBox != BoxTestKind::kFma) {
          if (bounds.valid) slots &= packet_cull<N, kBox>(wide, p.near_plane, p.far_plane, bounds);
        }
        for (; slots; slots &= slots - 1) {
          const uint32_t i = static_cast<uint32_t>(__builtin_ctz(slots));
          uint32_t mask;
          const V t = packet_enter<P, kBox>(&wide.planes[0][i], N, p, active_tmax, mask);
          if (mask == 0) continue;
          entered[k] = {P::select(mask, t, nan), wide.child[i], wide.count[i]};
          if constexpr (kAnyHit && kOrder != AnyHitOrder::kNearest) {
            keys[k] = k;
          } else {
            const float nearest = P::min_lane(P::select(mask, t, P::set1(__builtin_inff())));
            keys[k] = (static_cast<uint64_t>(ordered_bits(nearest + 0.0f)) << 32) | (N - 1 - k);
          }
          ++k;
        }
        if (k != 0) {
          if (k > 1) {
            if constexpr (!kAnyHit || kOrder == AnyHitOrder::kNearest) {
              for (uint32_t j = k; j < (N < 4 ? 4 : N); ++j) keys[j] = kLastKey;
              sort_keys<N>(keys, k);
            }
            for (uint32_t j = k - 1; j > 0; --j) {
              const uint32_t i = (!kAnyHit || kOrder == AnyHitOrder::kNearest)
                                     ? N - 1 - static_cast<uint32_t>(keys[j])
                                     : static_cast<uint32_t>(keys[j]);
              stack[size++] = entered[i];
              // Closest hit fetches the children it pushes, as the single-ray kernel does (descend, in
              // wide_kernels.inl), and any hit does not, for the same reason: a shadow packet often ends
              // before it pops them.
              if constexpr (!kAnyHit) prefetch_slot<N>(arena, entered[i].child, entered[i].count);
            }
          }
          const uint32_t i = (!kAnyHit || kOrder == AnyHitOrder::kNearest)
                                 ? N - 1 - static_cast<uint32_t>(keys[0])
                                 : static_cast<uint32_t>(keys[0]);
          entry = entered[i];
          continue;
        }
      }
    }
    if (size == 0) break;
    entry = stack[--size];
  }
  for (uint32_t j = 0; j < n; ++j) {
    if constexpr (kAnyHit)
      occluded[j] = best[j].prim != kInvalidPrim;
    else
      hits[j] = best[j];
  }
}

// Rays [begin, end) of a packet batch one at a time, through the single-ray batch kernel (trace_batch) as
// the single-ray layout traces them: two walks stepped in turn and, box=fma, on the integer path where
// the rays allow it.
template <uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, bool kAnyHit>
void trace_alone(const WideBatch& batch, std::size_t begin, std::size_t end) {
  if (begin == end) return;
  WideBatch part = batch;
  part.rays = batch.rays + begin;
  part.count = end - begin;
  part.hits = kAnyHit ? nullptr : batch.hits + begin;
  part.occluded = kAnyHit ? batch.occluded + begin : nullptr;
  part.counts = nullptr;
  part.int_order = IntOrder::kFree;
  part.robust_box = false;
  // trace_packet_batch has run the batch through the shadow cache where it takes it.
  part.shadow_cache = false;
  // As make_wide_rays: a ray that takes the robust box test does not lower the others' path.
  for (std::size_t i = begin; i < end; ++i) {
    if (batch.rays[i].robust_box)
      part.robust_box = true;
    else
      part.int_order = std::min(part.int_order, batch.rays[i].int_order);
  }
  trace_batch<N, kTri, kBox, kAnyHit, false>(part);
}

// Any hit in packets through a ShadowCache (wide_kernels.inl), from the batch's first packet up to the
// first with a ray that ends at a point no slot takes (then the caller traces the rest, from the index
// this returns, a packet's first ray). A packet that can go down the tree together (packet_coherent) is
// settled whole or not at all: its rays are tested against their slots' leaves up to the first that
// fails, and if one fails the whole packet walks as without the cache. Its walk visits each node once for
// all its rays, so it costs each ray less than its own walk: a ray settled out of a packet that walks
// anyway saves little, and a packet of three rays or fewer left would go on ray by ray, which costs more
// than the packet walk. The rays of the other packets (rays to lights taken in turn often differ in the
// sign of a direction component) are each tested as trace_shadow_cached tests them, and those left go on
// two at a time (trace_ray_pair; box=fma on the float path, where trace_alone takes the integer path the
// rays allow). The walks' hits fill the slots for the next rays. The box=fma kernels take this only where
// no ray of the batch takes the robust box test (WideBatch::robust_box), as trace_batch does.
template <class P, uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, AnyHitOrder kOrder>
[[gnu::noinline]] std::size_t trace_packets_shadow_cached(const WideBatch& batch) {
  constexpr uint32_t K = P::kWidth;
  ShadowCache cache;
  std::size_t pending[2];
  int pending_slot[2], waiting = 0;
  auto trace_pending = [&] {
    Occluder found[2];
    Hit hit[2];
    if (waiting == 2)
      trace_ray_pair<N, kTri, kBox, true, false, kOrder, IntOrder::kNone>(
          batch.root_planes, batch.arena, batch.rays[pending[0]], batch.rays[pending[1]], nullptr, hit[0],
          hit[1], &found[0], &found[1]);
    else
      hit[0] = trace_ray<N, kTri, kBox, true, false, kOrder, IntOrder::kNone>(
          batch.root_planes, batch.arena, batch.rays[pending[0]], nullptr, &found[0]);
    for (int j = 0; j < waiting; ++j) {
      const bool occluded = hit[j].prim != kInvalidPrim;
      batch.occluded[pending[j]] = occluded;
      if (occluded) cache.remember(pending_slot[j], found[j]);
    }
    waiting = 0;
  };
  for (std::size_t first = 0; first < batch.count; first += K) {
    const uint32_t n = static_cast<uint32_t>(batch.count - first < K ? batch.count - first : K);
    const WideRay* rays = batch.rays + first;
    uint8_t* occluded = batch.occluded + first;
    int slot[K];
    for (uint32_t j = 0; j < n; ++j) {
      slot[j] = cache.slot(rays[j]);
      if (slot[j] >= 0) continue;
      if (waiting != 0) trace_pending();
      return first;
    }
    if (packet_coherent<kBox>(rays, n)) {
      uint32_t settled = 0;
      while (settled < n && cache.occluder(slot[settled]).count != 0) {
        const bool blocked = cache.test_leaf<kTri>(batch.arena, slot[settled], rays[settled]);
        cache.tested(slot[settled], blocked);
        if (!blocked) break;
        ++settled;
      }
      if (settled == n) {
        for (uint32_t j = 0; j < n; ++j) occluded[j] = 1;
        if (batch.shadow_cache_settled) batch.shadow_cache_settled[0] += n;
        continue;
      }
      Occluder found[K];
      trace_packet<P, N, kTri, kBox, true, kOrder>(batch.root_planes, batch.arena, rays, n, nullptr, occluded,
                                                   found);
      for (uint32_t j = 0; j < n; ++j)
        if (occluded[j]) cache.remember(slot[j], found[j]);
      continue;
    }
    for (uint32_t j = 0; j < n; ++j) {
      const ShadowCache::Settle s =
          cache.test<N, kTri, kBox, kOrder, IntOrder::kNone>(batch.arena, slot[j], rays[j]);
      if (s.settled) {
        occluded[j] = 1;
        if (batch.shadow_cache_settled) ++batch.shadow_cache_settled[s.by_subtree];
        continue;
      }
      pending[waiting] = first + j;
      pending_slot[waiting++] = slot[j];
      if (waiting == 2) trace_pending();
    }
  }
  if (waiting != 0) trace_pending();
  return batch.count;
}

// A batch in packets of P::kWidth rays, in the batch's order; the rays of packets that are not coherent
// (packet_coherent) go one at a time (trace_alone), each run of such packets in one call. Splitting such
// a packet by octant into smaller packets, as Embree's hybrid kernels do, or keeping it whole with
// per-lane planes (packet_enter's kPerLane, which the binary layouts' packets gain by), was slower than
// tracing its rays alone on most shadow and diffuse cells of configs/tune.toml (README, "Packets"). Any
// hit first runs the batch through the shadow cache where it takes it (trace_packets_shadow_cached).
template <class P, uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, bool kAnyHit>
void trace_packet_batch(const WideBatch& batch) {
  constexpr uint32_t K = P::kWidth;
  auto run = [&]<AnyHitOrder kOrder>() {
    std::size_t start = 0;
    if constexpr (kAnyHit) {
      if (batch.shadow_cache && !(kBox == BoxTestKind::kFma && batch.robust_box) && ShadowCache::takes(batch))
        start = trace_packets_shadow_cached<P, N, kTri, kBox, kOrder>(batch);
    }
    std::size_t alone = start;  // the first ray of the run of incoherent packets before `first`
    for (std::size_t first = start; first < batch.count; first += K) {
      const uint32_t n = static_cast<uint32_t>(batch.count - first < K ? batch.count - first : K);
      const WideRay* rays = batch.rays + first;
      if (!packet_coherent<kBox>(rays, n)) continue;
      trace_alone<N, kTri, kBox, kAnyHit>(batch, alone, first);
      alone = first + n;
      trace_packet<P, N, kTri, kBox, kAnyHit, kOrder>(batch.root_planes, batch.arena, rays, n,
                                                      kAnyHit ? nullptr : batch.hits + first,
                                                      kAnyHit ? batch.occluded + first : nullptr);
    }
    trace_alone<N, kTri, kBox, kAnyHit>(batch, alone, batch.count);
  };
  if constexpr (kAnyHit) {
    if (batch.any_hit_order == AnyHitOrder::kStored) return run.template operator()<AnyHitOrder::kStored>();
    if (batch.any_hit_order == AnyHitOrder::kNearestStored)
      return run.template operator()<AnyHitOrder::kNearestStored>();
    if (batch.any_hit_order == AnyHitOrder::kFarthestStored)
      return run.template operator()<AnyHitOrder::kFarthestStored>();
  }
  run.template operator()<AnyHitOrder::kNearest>();
}

// The packet kernels of this instruction set (select_variant's table) for packets of `packet` rays: 8, or
// (AVX-512) 16; nullptr for a width this set has no kernels for.
inline WideKernel select_packet_kernel(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit,
                                       uint32_t packet) {
  auto table = [&]<class P>() {
    return select_variant(
        width, tri, box, any_hit,
        []<uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, bool kAnyHit>() -> WideKernel {
          return &trace_packet_batch<P, N, kTri, kBox, kAnyHit>;
        });
  };
  if (packet == Lanes8::kWidth) return table.template operator()<Lanes8>();
#if defined(SAHBENCH_WIDE_AVX512)
  if (packet == Lanes16::kWidth) return table.template operator()<Lanes16>();
#endif
  return nullptr;
}
