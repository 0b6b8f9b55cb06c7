// Closest-hit and any-hit kernels on the wide layouts (wide_bvh.h), written once and compiled once per
// instruction set: wide_kernels_{scalar,sse,avx2,avx512}.cpp each define exactly one of
// SAHBENCH_WIDE_SCALAR, _SSE, _AVX2 or _AVX512, then include this file inside a namespace of their own,
// so the functions below never meet their twin from another instruction set at link time.
//
// Every lane computes exactly what the scalar kernels of ray_box.h and triangle_tests.h compute, in the
// same order and with the same IEEE operations (min/max with the same NaN rule, no reciprocal
// approximations, and fused multiply-adds only where the scalar test calls fmaf: the project builds with
// -ffp-contract=off), so every instruction set returns the same hits, and visits the same nodes in the
// same order, as the scalar one.

// The including file includes wide_kernels_isa.h (and <immintrin.h> for the SIMD sets) first: no
// header may be included inside a namespace. Inline functions and templates from shared headers would
// be compiled once per instruction set and merged by the linker, which may keep the AVX-512 copy for
// every caller; so the code below calls none (compiler builtins and intrinsics only) and reads only
// constants and plain structs from those headers.

// Every helper below is inlined into the kernels, whatever the compiler's inlining budget says: with three
// box tests x four triangle tests x two queries of kernels per instruction set in one file, GCC's
// unit-growth limit left descend() and sort_keys() out of line, and the shadow rays lost 4-8%.
// (The watertight test's double-precision finish, rarely run, stays a call.)
#ifndef SAHBENCH_KERNEL_INLINE
#define SAHBENCH_KERNEL_INLINE [[gnu::always_inline]] inline
#endif

// The constants come from the scalar tests so the two cannot drift apart.
inline constexpr float kWideFarScale = RobustRayBox::kFarScale;
inline constexpr float kWideMtEpsilon = kMollerTrumboreEpsilon;

// ---------------------------------------------------------------------------------------------------
// Ray against the N child boxes of a node: bit i of the result is set when the ray enters child i within
// [tmin, tmax]; t_entry[i] is then its entry distance. Slab test of Kay and Kajiya; for kRobust the far
// distances are scaled by Ize 2013's bound, as RobustRayBox does, and for kFma each distance is one fused
// multiply-subtract, as FmaRayBox computes it.

// One plane's distance, as ray_box.h computes it for each box test (FmaRayBox: one fused multiply-subtract
// with the ray's finite reciprocal; the others: subtract, then multiply).
template <BoxTestKind kBox>
SAHBENCH_KERNEL_INLINE float plane_distance(float plane, const WideRay& r, uint32_t axis) {
  if constexpr (kBox == BoxTestKind::kFma)
    return __builtin_fmaf(plane, r.inv_dir[axis], -r.org_inv[axis]);
  else
    return (plane - r.org[axis]) * r.inv_dir[axis];
}

// box=fma with integer min and max (kInt below): the maximum and minimum of the slab distances, and the
// final compare, done on the floats' bits as signed integers, as Embree's node test does on AVX-512
// (maxi, mini and an integer compare in its BVHNNodeIntersector1). An integer max or min takes one cycle
// where a float one takes four, and the slab test is on the path from one node's address to the next:
// 1-10% more rays/second in every cell of configs/wide.toml's scenes and ray sets, shadow rays 4-10%
// (A/B against the float path, 4 interleaved rounds).
// The bits order as the floats do among non-negative floats (+0 and +inf included), and every negative
// float orders below all of them. So the integer and float answers are the same, bit for bit, when
// - tmin is +0 or positive (sign bit clear): then the maximum is non-negative, and a negative distance
//   never wins it, as with floats;
// - no distance is -0 (the integer order puts it below every negative float) and none is NaN. The
//   integer path computes each distance as fma(plane, inv, (-org_inv) + 0), which is fma(plane, inv,
//   -org_inv) except that an exact zero sum is +0 (it is -0 only when both terms are -0); it is never
//   NaN when inv is finite and non-zero (so for every ray box=fma takes, FmaRayBox::takes, the CPU not
//   flushing denormals to zero), org_inv is finite and no plane is NaN (wide_bvh.cpp stores NaN planes
//   as infinities). tmax, the closest hit so far, may be -0: its sign bit is cleared.
// Then a minimum with a negative distance in it is negative under both orders, and the compare fails
// under both. One case is left: a negative distance below 2^-150 in magnitude rounds to -0 all the
// same, and a far distance of -0 with an entry of +0 (the ray starting on the box's far face) is a
// zero-length entry that the float compare takes and the integer one misses. That takes |org_inv| below
// 2^-100 on the distance's axis (wide_bvh.cpp proves the bound), so the ray set-up sorts the rays
// (WideRay::int_order): kFree rays cannot meet it; for kGuarded rays, whose origin is on or near a coordinate
// plane, the kernel looks for a far minimum of -0 (INT_MIN, below every other value) at each node and tests
// that node again on the float path. The check cost shadow rays 0.5-3% where every ray took it (Sponza's
// most), hence the two kinds. A batch takes the lowest kind of its rays (trace_batch): a negative tmin, or an
// origin so far out that org * inv overflows, sends it to the float path.

// Whether this instruction set has the integer path: the FMA sets (SSE has no fused multiply-add, and
// the scalar kernels are the reference).
#if defined(SAHBENCH_WIDE_AVX2) || defined(SAHBENCH_WIDE_AVX512)
inline constexpr bool kHasIntOrder = true;
#else
inline constexpr bool kHasIntOrder = false;
#endif

// A ray's constants for the 8-wide integer path (AVX2, AVX-512), broadcast once per ray by trace_ray:
// inv_dir and -org_inv + 0 on each axis. Made in the node test, the three negations and six broadcasts
// stayed in the node loop (GCC 12 did not hoist them), and tracing was 0-2.5% slower than with them here.
// Stored in the ray and broadcast from it in the loop, shadow rays were 0.6-2.7% slower than with neither.
// The leaf test's direction and origin kept here as well traced shadow rays
// 2-3% slower on AVX-512 (diffuse 0-2% faster), so the leaf tests broadcast theirs at each leaf. Empty in
// the other builds, which take their constants from the ray.
struct RaySlabs {
#if defined(SAHBENCH_WIDE_AVX2) || defined(SAHBENCH_WIDE_AVX512)
  __m256 inv[3];
  __m256 base[3];
#endif
};

SAHBENCH_KERNEL_INLINE RaySlabs ray_slabs([[maybe_unused]] const WideRay& r) {
  RaySlabs s;
#if defined(SAHBENCH_WIDE_AVX2) || defined(SAHBENCH_WIDE_AVX512)
  for (uint32_t axis = 0; axis < 3; ++axis) {
    s.inv[axis] = _mm256_set1_ps(r.inv_dir[axis]);
    s.base[axis] = _mm256_set1_ps(-r.org_inv[axis] + 0.0f);
  }
#endif
  return s;
}

#if defined(SAHBENCH_WIDE_SCALAR)

template <uint32_t N, BoxTestKind kBox, IntOrder kInt = IntOrder::kNone>
SAHBENCH_KERNEL_INLINE uint32_t intersect_children(const WideNode<N>& node, const WideRay& r, const RaySlabs&,
                                                   float tmin, float tmax, float* t_entry) {
  uint32_t mask = 0;
  for (uint32_t i = 0; i < N; ++i) {
    float t_near = tmin, t_far = tmax;
    for (uint32_t axis = 0; axis < 3; ++axis) {
      const float t0 = plane_distance<kBox>(node.planes[r.near_plane[axis]][i], r, axis);
      float t1 = plane_distance<kBox>(node.planes[r.far_plane[axis]][i], r, axis);
      if constexpr (kBox == BoxTestKind::kRobust) t1 *= kWideFarScale;
      t_near = t0 > t_near ? t0 : t_near;
      t_far = t1 < t_far ? t1 : t_far;
    }
    t_entry[i] = t_near;
    mask |= static_cast<uint32_t>(t_near <= t_far) << i;
  }
  return mask;
}

#else

// Four children at a time. _mm_max_ps(a, b) is a > b ? a : b and _mm_min_ps(a, b) is a < b ? a : b,
// exactly the scalar updates, so a NaN distance (origin on a face plane of a zero direction component)
// leaves the interval as it is, as in ray_box.h.
// Four planes' distances (plane_distance, lane by lane). SSE has no fused multiply-add: there each lane
// calls fmaf, which is exact but slow; box=fma is for the AVX2 and AVX-512 kernels.
template <BoxTestKind kBox>
SAHBENCH_KERNEL_INLINE __m128 plane_distances4(__m128 planes, const WideRay& r, uint32_t axis) {
  if constexpr (kBox != BoxTestKind::kFma) {
    return _mm_mul_ps(_mm_sub_ps(planes, _mm_set1_ps(r.org[axis])), _mm_set1_ps(r.inv_dir[axis]));
  } else {
#if defined(SAHBENCH_WIDE_AVX2) || defined(SAHBENCH_WIDE_AVX512)
    return _mm_fmsub_ps(planes, _mm_set1_ps(r.inv_dir[axis]), _mm_set1_ps(r.org_inv[axis]));
#else
    alignas(16) float lanes[4];
    _mm_store_ps(lanes, planes);
    for (float& lane : lanes) lane = __builtin_fmaf(lane, r.inv_dir[axis], -r.org_inv[axis]);
    return _mm_load_ps(lanes);
#endif
  }
}

template <BoxTestKind kBox, IntOrder kInt = IntOrder::kNone>
SAHBENCH_KERNEL_INLINE uint32_t intersect_children4(const float (*planes)[4], const WideRay& r, float tmin,
                                                    float tmax, float* t_entry, uint32_t stride) {
#if defined(SAHBENCH_WIDE_AVX2) || defined(SAHBENCH_WIDE_AVX512)
  if constexpr (kInt != IntOrder::kNone) {
    static_assert(kBox == BoxTestKind::kFma, "the integer order is box=fma's");
    auto distances = [&](uint32_t plane, uint32_t axis) __attribute__((always_inline)) {
      return _mm_castps_si128(_mm_fmadd_ps(_mm_load_ps(planes[plane * stride]), _mm_set1_ps(r.inv_dir[axis]),
                                           _mm_set1_ps(-r.org_inv[axis] + 0.0f)));
    };
    const __m128i t_near = _mm_max_epi32(
        _mm_max_epi32(distances(r.near_plane[0], 0), distances(r.near_plane[1], 1)),
        _mm_max_epi32(distances(r.near_plane[2], 2), _mm_set1_epi32(__builtin_bit_cast(int, tmin))));
    const __m128i t_far =
        _mm_min_epi32(_mm_min_epi32(distances(r.far_plane[0], 0), distances(r.far_plane[1], 1)),
                      _mm_min_epi32(distances(r.far_plane[2], 2),
                                    _mm_set1_epi32(__builtin_bit_cast(int, tmax) & 0x7fffffff)));
    // A far distance of -0 (see the exception above) makes its lane's minimum INT_MIN: that node is
    // tested again on the float path. Off the path to the mask, and a branch that is never taken.
    if constexpr (kInt == IntOrder::kGuarded) {
      if (__builtin_expect(
              !_mm_testz_si128(_mm_cmpeq_epi32(t_far, _mm_set1_epi32(INT32_MIN)), _mm_set1_epi32(-1)), 0))
        return intersect_children4<kBox>(planes, r, tmin, tmax, t_entry, stride);
    }
    _mm_storeu_si128(reinterpret_cast<__m128i*>(t_entry), t_near);
#if defined(SAHBENCH_WIDE_AVX512)
    return static_cast<uint32_t>(_mm_cmple_epi32_mask(t_near, t_far));
#else
    return static_cast<uint32_t>(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpgt_epi32(t_near, t_far)))) ^ 0xFu;
#endif
  }
#endif
  __m128 t_near = _mm_set1_ps(tmin);
  __m128 t_far = _mm_set1_ps(tmax);
  for (uint32_t axis = 0; axis < 3; ++axis) {
    const __m128 t0 = plane_distances4<kBox>(_mm_load_ps(planes[r.near_plane[axis] * stride]), r, axis);
    __m128 t1 = plane_distances4<kBox>(_mm_load_ps(planes[r.far_plane[axis] * stride]), r, axis);
    if constexpr (kBox == BoxTestKind::kRobust) t1 = _mm_mul_ps(t1, _mm_set1_ps(kWideFarScale));
    t_near = _mm_max_ps(t0, t_near);
    t_far = _mm_min_ps(t1, t_far);
  }
  _mm_storeu_ps(t_entry, t_near);
  return static_cast<uint32_t>(_mm_movemask_ps(_mm_cmple_ps(t_near, t_far)));
}

template <uint32_t N, BoxTestKind kBox, IntOrder kInt = IntOrder::kNone>
SAHBENCH_KERNEL_INLINE uint32_t intersect_children(const WideNode<N>& node, const WideRay& r,
                                                   [[maybe_unused]] const RaySlabs& slabs, float tmin,
                                                   float tmax, float* t_entry) {
  if constexpr (N == 4) {
    return intersect_children4<kBox, kInt>(reinterpret_cast<const float(*)[4]>(node.planes), r, tmin, tmax,
                                           t_entry, 1);
  } else {
#if defined(SAHBENCH_WIDE_AVX2) || defined(SAHBENCH_WIDE_AVX512)
    if constexpr (kInt != IntOrder::kNone) {
      static_assert(kBox == BoxTestKind::kFma, "the integer order is box=fma's");
      // Both extremes as trees of two levels: each distance is one fused multiply-subtract from the load.
      auto distances = [&](uint32_t plane, uint32_t axis) __attribute__((always_inline)) {
        return _mm256_castps_si256(
            _mm256_fmadd_ps(_mm256_load_ps(node.planes[plane]), slabs.inv[axis], slabs.base[axis]));
      };
      const __m256i t_near = _mm256_max_epi32(
          _mm256_max_epi32(distances(r.near_plane[0], 0), distances(r.near_plane[1], 1)),
          _mm256_max_epi32(distances(r.near_plane[2], 2), _mm256_set1_epi32(__builtin_bit_cast(int, tmin))));
      const __m256i t_far =
          _mm256_min_epi32(_mm256_min_epi32(distances(r.far_plane[0], 0), distances(r.far_plane[1], 1)),
                           _mm256_min_epi32(distances(r.far_plane[2], 2),
                                            _mm256_set1_epi32(__builtin_bit_cast(int, tmax) & 0x7fffffff)));
      if constexpr (kInt == IntOrder::kGuarded) {
#if defined(SAHBENCH_WIDE_AVX512)
        const bool negative_zero = _mm256_cmpeq_epi32_mask(t_far, _mm256_set1_epi32(INT32_MIN)) != 0;
#else
        const bool negative_zero = !_mm256_testz_si256(
            _mm256_cmpeq_epi32(t_far, _mm256_set1_epi32(INT32_MIN)), _mm256_set1_epi32(-1));
#endif
        if (__builtin_expect(negative_zero, 0))
          return intersect_children<N, kBox>(node, r, slabs, tmin, tmax, t_entry);
      }
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(t_entry), t_near);
#if defined(SAHBENCH_WIDE_AVX512)
      return static_cast<uint32_t>(_mm256_cmple_epi32_mask(t_near, t_far));
#else
      return static_cast<uint32_t>(
                 _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(t_near, t_far)))) ^
             0xFFu;
#endif
    }
#endif
#if defined(SAHBENCH_WIDE_AVX2) || defined(SAHBENCH_WIDE_AVX512)
    __m256 t_near = _mm256_set1_ps(tmin);
    __m256 t_far = _mm256_set1_ps(tmax);
    for (uint32_t axis = 0; axis < 3; ++axis) {
      if constexpr (kBox == BoxTestKind::kFma) {
        const __m256 org_inv = _mm256_set1_ps(r.org_inv[axis]);
        const __m256 inv = _mm256_set1_ps(r.inv_dir[axis]);
        const __m256 t0 = _mm256_fmsub_ps(_mm256_load_ps(node.planes[r.near_plane[axis]]), inv, org_inv);
        const __m256 t1 = _mm256_fmsub_ps(_mm256_load_ps(node.planes[r.far_plane[axis]]), inv, org_inv);
        t_near = _mm256_max_ps(t0, t_near);
        t_far = _mm256_min_ps(t1, t_far);
        continue;
      }
      const __m256 org = _mm256_set1_ps(r.org[axis]);
      const __m256 inv = _mm256_set1_ps(r.inv_dir[axis]);
      const __m256 near = _mm256_load_ps(node.planes[r.near_plane[axis]]);
      const __m256 far = _mm256_load_ps(node.planes[r.far_plane[axis]]);
      const __m256 t0 = _mm256_mul_ps(_mm256_sub_ps(near, org), inv);
      __m256 t1 = _mm256_mul_ps(_mm256_sub_ps(far, org), inv);
      if constexpr (kBox == BoxTestKind::kRobust) t1 = _mm256_mul_ps(t1, _mm256_set1_ps(kWideFarScale));
      t_near = _mm256_max_ps(t0, t_near);
      t_far = _mm256_min_ps(t1, t_far);
    }
    _mm256_storeu_ps(t_entry, t_near);
    return static_cast<uint32_t>(_mm256_movemask_ps(_mm256_cmp_ps(t_near, t_far, _CMP_LE_OQ)));
#else
    // SSE: the two halves of the eight children. planes[p] is 8 floats; as [4]-rows, plane p's first
    // half is row 2p and its second half row 2p + 1.
    const auto* rows = reinterpret_cast<const float(*)[4]>(node.planes);
    static_assert(kInt == IntOrder::kNone, "no integer order without fused multiply-adds");
    const uint32_t lo = intersect_children4<kBox>(rows, r, tmin, tmax, t_entry, 2);
    const uint32_t hi = intersect_children4<kBox>(rows + 1, r, tmin, tmax, t_entry + 4, 2);
    return lo | (hi << 4);
#endif
  }
}

#endif

// The watertight test's double-precision finish, for lanes whose float edge functions are zero or out
// of range (triangle_tests.h: watertight_in_double, repeated here because this file may call nothing
// from shared headers; the layout tests check that both give the same answers bit for bit).
inline bool lane_in_double(float ax, float ay, float az, float bx, float by, float bz, float cx, float cy,
                           float cz, float tmin, float tmax, float& t, float& u, float& v) {
  const double e0 = static_cast<double>(cx) * by - static_cast<double>(cy) * bx;
  const double e1 = static_cast<double>(ax) * cy - static_cast<double>(ay) * cx;
  const double e2 = static_cast<double>(bx) * ay - static_cast<double>(by) * ax;
  if ((e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0)) return false;
  const double det = e0 + e1 + e2;
  if (det == 0.0 || !(det - det == 0.0)) return false;  // zero, infinite or NaN
  const double distance = (e0 * az + e1 * bz + e2 * cz) / det;
  t = static_cast<float>(distance);
  if (!(t >= tmin && t <= tmax)) return false;
  u = static_cast<float>(e1 / det);
  v = static_cast<float>(e2 / det);
  return true;
}

// triangle_tests.h's watertight_range_holds, for lane i of a block hit at t: its vertices' distances
// along the ray computed as the lanes compute them.
SAHBENCH_KERNEL_INLINE bool lane_range_holds(const TriangleBlock& b, const WideRay& r, uint32_t i, float t,
                                             float tmin, float tmax) {
  const float o = r.org[r.kz];
  const float z0 = __builtin_fabsf(r.sz * (b.v0[r.kz][i] - o)),
              z1 = __builtin_fabsf(r.sz * (b.v1[r.kz][i] - o)),
              z2 = __builtin_fabsf(r.sz * (b.v2[r.kz][i] - o));
  const float z01 = z0 > z1 ? z0 : z1;
  const float margin = (z01 > z2 ? z01 : z2) * 0x1p-12f;
  return t > tmin + margin && t < tmax - margin;
}

// triangle_tests.h's plane_distance_in_double and refine_watertight_t, for the lanes of `mask` (a
// watertight block test's hits): each hit's distance recomputed in double from the block's vertices and
// the ray, the lane dropped where it falls outside [tmin, tmax]. The same operations in the same order,
// so every instruction set returns the same t as the scalar test. Any hit (kAnyHit) refines only the
// lanes whose float decision cannot stand (lane_range_holds), as WatertightTriangleTest::intersect_any.
template <bool kAnyHit>
SAHBENCH_KERNEL_INLINE uint32_t refine_lanes(const TriangleBlock& b, const WideRay& r, float tmin, float tmax,
                                             uint32_t mask, float* t_out) {
  for (uint32_t hits = mask; hits; hits &= hits - 1) {
    const uint32_t i = static_cast<uint32_t>(__builtin_ctz(hits));
    if constexpr (kAnyHit) {
      if (lane_range_holds(b, r, i, t_out[i], tmin, tmax)) continue;
    }
    const double e1x = static_cast<double>(b.v1[0][i]) - b.v0[0][i],
                 e1y = static_cast<double>(b.v1[1][i]) - b.v0[1][i],
                 e1z = static_cast<double>(b.v1[2][i]) - b.v0[2][i];
    const double e2x = static_cast<double>(b.v2[0][i]) - b.v0[0][i],
                 e2y = static_cast<double>(b.v2[1][i]) - b.v0[1][i],
                 e2z = static_cast<double>(b.v2[2][i]) - b.v0[2][i];
    const double nx = e1y * e2z - e1z * e2y, ny = e1z * e2x - e1x * e2z, nz = e1x * e2y - e1y * e2x;
    const double cx = static_cast<double>(b.v0[0][i]) - r.org[0],
                 cy = static_cast<double>(b.v0[1][i]) - r.org[1],
                 cz = static_cast<double>(b.v0[2][i]) - r.org[2];
    const double distance = (nx * cx + ny * cy + nz * cz) / (nx * r.dir[0] + ny * r.dir[1] + nz * r.dir[2]);
    const float refined = static_cast<float>(distance);
    if (__builtin_fabsf(refined) < __builtin_inff()) t_out[i] = refined;
    if (!(t_out[i] >= tmin && t_out[i] <= tmax)) mask &= ~(1u << i);
  }
  return mask;
}

// triangle_tests.h's watertight_float_ok and watertight_det_ok, for one lane.
SAHBENCH_KERNEL_INLINE bool lane_float_ok(float e0, float e1, float e2) {
  constexpr float kInf = __builtin_inff();
  return __builtin_fabsf(e0) < kInf && __builtin_fabsf(e1) < kInf && __builtin_fabsf(e2) < kInf &&
         e0 != 0.0f && e1 != 0.0f && e2 != 0.0f;
}
SAHBENCH_KERNEL_INLINE bool lane_det_ok(float det, float scaled_t) {
  constexpr float kInf = __builtin_inff();
  const float abs_det = __builtin_fabsf(det);
  return abs_det >= __FLT_MIN__ && abs_det < kInf && __builtin_fabsf(scaled_t) < kInf;
}

// ---------------------------------------------------------------------------------------------------
// Ray against the four triangles of a block: bit i is set when lane i is hit within [tmin, tmax], with
// its t, u, v in the arrays. Watertight: Woop et al. 2013 as WatertightTriangleTest, on blocks in vertex
// form; Möller–Trumbore as MollerTrumboreTest with `epsilon`, on blocks in edge form (wide_bvh.h);
// tri=mtn as MollerTrumboreNormalTest, on NormalBlocks.

// x with its sign bit xor `sign`.
SAHBENCH_KERNEL_INLINE float flip_sign(float x, uint32_t sign) {
  return __builtin_bit_cast(float, __builtin_bit_cast(uint32_t, x) ^ sign);
}

// triangle_tests.h's mtn_in_double for lane i of a block, for the lanes outside the float test's range
// (NormalBlock::in_double, WideRay::mtn_in_double); repeated here as lane_in_double is.
inline bool mtn_lane_in_double(const NormalBlock& b, uint32_t i, const WideRay& r, float tmin, float tmax,
                               float& t_out, float& u_out, float& v_out) {
  const TriangleBlock& e = b.tri;  // edge form
  const double ax = e.v1[0][i], ay = e.v1[1][i], az = e.v1[2][i], bx = e.v2[0][i], by = e.v2[1][i],
               bz = e.v2[2][i];
  const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
  const double cx = static_cast<double>(e.v0[0][i]) - r.org[0],
               cy = static_cast<double>(e.v0[1][i]) - r.org[1],
               cz = static_cast<double>(e.v0[2][i]) - r.org[2];
  const double dx = r.dir[0], dy = r.dir[1], dz = r.dir[2];
  const double rx = dy * cz - dz * cy, ry = dz * cx - dx * cz, rz = dx * cy - dy * cx;
  const double det = dx * nx + dy * ny + dz * nz;
  if (det == 0.0 || !(det - det == 0.0)) return false;  // parallel, or NaN
  const double sign = det < 0.0 ? -1.0 : 1.0;
  const double abs_det = det * sign;
  const double su = -(bx * rx + by * ry + bz * rz) * sign;
  const double sv = (ax * rx + ay * ry + az * rz) * sign;
  if (!(su >= 0.0 && sv >= 0.0 && su + sv <= abs_det)) return false;
  const double st = (cx * nx + cy * ny + cz * nz) * sign;
  if (!(st >= abs_det * tmin && st <= abs_det * tmax)) return false;
  t_out = static_cast<float>(st / abs_det);
  u_out = static_cast<float>(su / abs_det);
  v_out = static_cast<float>(sv / abs_det);
  return t_out >= tmin && t_out <= tmax;
}

// The lanes of `mask` (bits 0-3 block b[0], 4-7 b[1]) tested by mtn_lane_in_double: the hits of those
// lanes in place of the float test's, whose other lanes `float_hits` keeps.
inline uint32_t mtn_lanes_in_double(const NormalBlock* b, uint32_t mask, uint32_t float_hits,
                                    const WideRay& r, float tmin, float tmax, float* t_out, float* u_out,
                                    float* v_out) {
  uint32_t hits = float_hits & ~mask;
  for (; mask; mask &= mask - 1) {
    const uint32_t i = static_cast<uint32_t>(__builtin_ctz(mask));
    const NormalBlock& block = b[i / kBlockWidth];
    const uint32_t lane = i % kBlockWidth;
    if (block.tri.prim[lane] != kInvalidPrim &&
        mtn_lane_in_double(block, lane, r, tmin, tmax, t_out[i], u_out[i], v_out[i]))
      hits |= 1u << i;
  }
  return hits;
}

// The lanes of block b that the float test cannot answer: all when the ray is out of its range.
SAHBENCH_KERNEL_INLINE uint32_t mtn_double_lanes(const NormalBlock& b, const WideRay& r) {
  return r.mtn_in_double ? kBlockLanes : b.in_double;
}

// One lane of MollerTrumboreNormalTest: the scalar kernels' test, and the SSE kernels' (SSE has no fused
// multiply-add; fmaf is exact there, and slow). The same operations as triangle_tests.h, in the same order.
SAHBENCH_KERNEL_INLINE bool mtn_lane(const NormalBlock& b, uint32_t i, const WideRay& r, float tmin,
                                     float tmax, float& t_out, float& u_out, float& v_out) {
  if (mtn_double_lanes(b, r) >> i & 1u) [[unlikely]]
    return mtn_lane_in_double(b, i, r, tmin, tmax, t_out, u_out, v_out);
  const TriangleBlock& e = b.tri;  // edge form
  const float cx = e.v0[0][i] - r.org[0], cy = e.v0[1][i] - r.org[1], cz = e.v0[2][i] - r.org[2];
  const float dx = r.dir[0], dy = r.dir[1], dz = r.dir[2];
  const float nx = b.normal[0][i], ny = b.normal[1][i], nz = b.normal[2][i];
  const float rx = __builtin_fmaf(dy, cz, -(dz * cy)), ry = __builtin_fmaf(dz, cx, -(dx * cz)),
              rz = __builtin_fmaf(dx, cy, -(dy * cx));
  const float det = __builtin_fmaf(dx, nx, __builtin_fmaf(dy, ny, dz * nz));
  const uint32_t sign = __builtin_bit_cast(uint32_t, det) & 0x80000000u;
  const float abs_det = flip_sign(det, sign);
  const float su = flip_sign(__builtin_fmaf(e.v2[0][i], rx, __builtin_fmaf(e.v2[1][i], ry, e.v2[2][i] * rz)),
                             sign ^ 0x80000000u);
  const float sv =
      flip_sign(__builtin_fmaf(e.v1[0][i], rx, __builtin_fmaf(e.v1[1][i], ry, e.v1[2][i] * rz)), sign);
  if (!(abs_det >= __FLT_MIN__ && su >= 0.0f && sv >= 0.0f && su + sv <= abs_det)) return false;
  const float st = flip_sign(__builtin_fmaf(cx, nx, __builtin_fmaf(cy, ny, cz * nz)), sign);
  if (!(st >= abs_det * tmin && st <= abs_det * tmax)) return false;
  const float inv_det = 1.0f / abs_det;
  t_out = st * inv_det;
  u_out = su * inv_det;
  v_out = sv * inv_det;
  return t_out >= tmin && t_out <= tmax;
}

#if !defined(SAHBENCH_WIDE_AVX2) && !defined(SAHBENCH_WIDE_AVX512)
SAHBENCH_KERNEL_INLINE uint32_t intersect_block_mtn(const NormalBlock& b, const WideRay& r, float tmin,
                                                    float tmax, float* t_out, float* u_out, float* v_out) {
  uint32_t mask = 0;
  for (uint32_t i = 0; i < kBlockWidth; ++i)
    if (b.tri.prim[i] != kInvalidPrim && mtn_lane(b, i, r, tmin, tmax, t_out[i], u_out[i], v_out[i]))
      mask |= 1u << i;
  return mask;
}
#endif

#if defined(SAHBENCH_WIDE_SCALAR)

SAHBENCH_KERNEL_INLINE float component(const float (&v)[3][kBlockWidth], uint32_t axis, uint32_t lane) {
  return v[axis][lane];
}

// kRefine: closest hit's distances refined in double (refine_lanes); any hit takes the float ones and
// checks them in intersect_leaf (refine_lanes<true>), as triangle_tests.h's intersect_any does.
template <bool kRefine>
inline uint32_t intersect_block_watertight(const TriangleBlock& b, const WideRay& r, float tmin, float tmax,
                                           float* t_out, float* u_out, float* v_out) {
  uint32_t mask = 0;
  for (uint32_t i = 0; i < kBlockWidth; ++i) {
    if (b.prim[i] == kInvalidPrim) continue;
    const float a_x = b.v0[r.kx][i] - r.org[r.kx], a_y = b.v0[r.ky][i] - r.org[r.ky],
                a_z = b.v0[r.kz][i] - r.org[r.kz];
    const float b_x = b.v1[r.kx][i] - r.org[r.kx], b_y = b.v1[r.ky][i] - r.org[r.ky],
                b_z = b.v1[r.kz][i] - r.org[r.kz];
    const float c_x = b.v2[r.kx][i] - r.org[r.kx], c_y = b.v2[r.ky][i] - r.org[r.ky],
                c_z = b.v2[r.kz][i] - r.org[r.kz];
    const float ax = a_x - r.sx * a_z, ay = a_y - r.sy * a_z;
    const float bx = b_x - r.sx * b_z, by = b_y - r.sy * b_z;
    const float cx = c_x - r.sx * c_z, cy = c_y - r.sy * c_z;
    const float az = r.sz * a_z, bz = r.sz * b_z, cz = r.sz * c_z;
    const float e0 = cx * by - cy * bx;
    const float e1 = ax * cy - ay * cx;
    const float e2 = bx * ay - by * ax;
    if (!lane_float_ok(e0, e1, e2)) {
      if (lane_in_double(ax, ay, az, bx, by, bz, cx, cy, cz, tmin, tmax, t_out[i], u_out[i], v_out[i]))
        mask |= 1u << i;
      continue;
    }
    if ((e0 < 0.0f || e1 < 0.0f || e2 < 0.0f) && (e0 > 0.0f || e1 > 0.0f || e2 > 0.0f)) continue;
    const float det = e0 + e1 + e2;
    const float scaled_t = e0 * az + e1 * bz + e2 * cz;
    if (!lane_det_ok(det, scaled_t)) {
      if (lane_in_double(ax, ay, az, bx, by, bz, cx, cy, cz, tmin, tmax, t_out[i], u_out[i], v_out[i]))
        mask |= 1u << i;
      continue;
    }
    const float abs_det = det < 0.0f ? -det : det;
    const float signed_t = det < 0.0f ? -scaled_t : scaled_t;
    if (!(signed_t >= tmin * abs_det && signed_t <= tmax * abs_det)) continue;
    const float inv_det = 1.0f / det;
    const float t = scaled_t * inv_det;
    if (!(t >= tmin && t <= tmax)) continue;
    t_out[i] = t;
    u_out[i] = e1 * inv_det;
    v_out[i] = e2 * inv_det;
    mask |= 1u << i;
  }
  return kRefine ? refine_lanes<false>(b, r, tmin, tmax, mask, t_out) : mask;
}

SAHBENCH_KERNEL_INLINE uint32_t intersect_block_mt(const TriangleBlock& b, const WideRay& r, float tmin,
                                                   float tmax, float epsilon, float* t_out, float* u_out,
                                                   float* v_out) {
  uint32_t mask = 0;
  for (uint32_t i = 0; i < kBlockWidth; ++i) {
    if (b.prim[i] == kInvalidPrim) continue;
    // The block is in edge form (BlockForm::kEdges).
    const float e1x = b.v1[0][i], e1y = b.v1[1][i], e1z = b.v1[2][i];
    const float e2x = b.v2[0][i], e2y = b.v2[1][i], e2z = b.v2[2][i];
    const float px = r.dir[1] * e2z - r.dir[2] * e2y;
    const float py = r.dir[2] * e2x - r.dir[0] * e2z;
    const float pz = r.dir[0] * e2y - r.dir[1] * e2x;
    const float det = e1x * px + e1y * py + e1z * pz;
    if (!((det < 0.0f ? -det : det) > epsilon)) continue;
    const float inv_det = 1.0f / det;
    const float sx = r.org[0] - b.v0[0][i], sy = r.org[1] - b.v0[1][i], sz = r.org[2] - b.v0[2][i];
    const float u = (sx * px + sy * py + sz * pz) * inv_det;
    if (!(u >= 0.0f && u <= 1.0f)) continue;
    const float qx = sy * e1z - sz * e1y;
    const float qy = sz * e1x - sx * e1z;
    const float qz = sx * e1y - sy * e1x;
    const float v = (r.dir[0] * qx + r.dir[1] * qy + r.dir[2] * qz) * inv_det;
    if (!(v >= 0.0f && u + v <= 1.0f)) continue;
    const float t = (e2x * qx + e2y * qy + e2z * qz) * inv_det;
    if (!(t >= tmin && t <= tmax)) continue;
    t_out[i] = t;
    u_out[i] = u;
    v_out[i] = v;
    mask |= 1u << i;
  }
  return mask;
}

#else

#include "traversal/watertight_lanes.inl"

SAHBENCH_KERNEL_INLINE __m128 lanes_valid(const TriangleBlock& b) {
  const __m128i prim = _mm_load_si128(reinterpret_cast<const __m128i*>(b.prim));
  const __m128i invalid = _mm_cmpeq_epi32(prim, _mm_set1_epi32(-1));
  return _mm_castsi128_ps(_mm_xor_si128(invalid, _mm_set1_epi32(-1)));
}

// kRefine: closest hit's distances refined in double (refine_lanes); any hit takes the float ones and
// checks them in intersect_leaf (refine_lanes<true>), as triangle_tests.h's intersect_any does.
template <bool kRefine>
inline uint32_t intersect_block_watertight(const TriangleBlock& b, const WideRay& r, float tmin, float tmax,
                                           float* t_out, float* u_out, float* v_out) {
  const __m128 valid = lanes_valid(b);
  const __m128 vertex[3][3] = {{_mm_load_ps(b.v0[r.kx]), _mm_load_ps(b.v0[r.ky]), _mm_load_ps(b.v0[r.kz])},
                               {_mm_load_ps(b.v1[r.kx]), _mm_load_ps(b.v1[r.ky]), _mm_load_ps(b.v1[r.kz])},
                               {_mm_load_ps(b.v2[r.kx]), _mm_load_ps(b.v2[r.ky]), _mm_load_ps(b.v2[r.kz])}};
  const __m128 org[3] = {_mm_set1_ps(r.org[r.kx]), _mm_set1_ps(r.org[r.ky]), _mm_set1_ps(r.org[r.kz])};
  const __m128 shear[3] = {_mm_set1_ps(r.sx), _mm_set1_ps(r.sy), _mm_set1_ps(r.sz)};
  // The double finish as a lambda, so that it is part of the instantiation's type, not a pointer to fold.
  const auto in_double = [](float ax, float ay, float az, float bx, float by, float bz, float cx, float cy,
                            float cz, float lo, float hi, float& t, float& u, float& v) {
    return lane_in_double(ax, ay, az, bx, by, bz, cx, cy, cz, lo, hi, t, u, v);
  };
  const uint32_t mask =
      watertight_lanes(vertex, org, shear, valid, tmin, tmax, t_out, u_out, v_out, in_double);
  return kRefine && mask ? refine_lanes<false>(b, r, tmin, tmax, mask, t_out) : mask;
}

SAHBENCH_KERNEL_INLINE uint32_t intersect_block_mt(const TriangleBlock& b, const WideRay& r, float tmin,
                                                   float tmax, float epsilon, float* t_out, float* u_out,
                                                   float* v_out) {
  const __m128 valid = lanes_valid(b);
  const __m128 v0x = _mm_load_ps(b.v0[0]), v0y = _mm_load_ps(b.v0[1]), v0z = _mm_load_ps(b.v0[2]);
  // The block is in edge form (BlockForm::kEdges).
  const __m128 e1x = _mm_load_ps(b.v1[0]), e1y = _mm_load_ps(b.v1[1]), e1z = _mm_load_ps(b.v1[2]);
  const __m128 e2x = _mm_load_ps(b.v2[0]), e2y = _mm_load_ps(b.v2[1]), e2z = _mm_load_ps(b.v2[2]);
  const __m128 dx = _mm_set1_ps(r.dir[0]), dy = _mm_set1_ps(r.dir[1]), dz = _mm_set1_ps(r.dir[2]);
  // p = dir x edge2, det = edge1 . p (vec3.h's cross and dot, term for term).
  const __m128 px = _mm_sub_ps(_mm_mul_ps(dy, e2z), _mm_mul_ps(dz, e2y));
  const __m128 py = _mm_sub_ps(_mm_mul_ps(dz, e2x), _mm_mul_ps(dx, e2z));
  const __m128 pz = _mm_sub_ps(_mm_mul_ps(dx, e2y), _mm_mul_ps(dy, e2x));
  const __m128 det = _mm_add_ps(_mm_add_ps(_mm_mul_ps(e1x, px), _mm_mul_ps(e1y, py)), _mm_mul_ps(e1z, pz));
  const __m128 sign = _mm_set1_ps(-0.0f);
  __m128 hit = _mm_and_ps(valid, _mm_cmpgt_ps(_mm_andnot_ps(sign, det), _mm_set1_ps(epsilon)));
  if (!_mm_movemask_ps(hit)) return 0;
  const __m128 inv_det = _mm_div_ps(_mm_set1_ps(1.0f), det);
  const __m128 sx = _mm_sub_ps(_mm_set1_ps(r.org[0]), v0x), sy = _mm_sub_ps(_mm_set1_ps(r.org[1]), v0y),
               sz = _mm_sub_ps(_mm_set1_ps(r.org[2]), v0z);
  const __m128 u =
      _mm_mul_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(sx, px), _mm_mul_ps(sy, py)), _mm_mul_ps(sz, pz)), inv_det);
  const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
  hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmpge_ps(u, zero), _mm_cmple_ps(u, one)));
  const __m128 qx = _mm_sub_ps(_mm_mul_ps(sy, e1z), _mm_mul_ps(sz, e1y));
  const __m128 qy = _mm_sub_ps(_mm_mul_ps(sz, e1x), _mm_mul_ps(sx, e1z));
  const __m128 qz = _mm_sub_ps(_mm_mul_ps(sx, e1y), _mm_mul_ps(sy, e1x));
  const __m128 v =
      _mm_mul_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, qx), _mm_mul_ps(dy, qy)), _mm_mul_ps(dz, qz)), inv_det);
  hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmpge_ps(v, zero), _mm_cmple_ps(_mm_add_ps(u, v), one)));
  const __m128 t = _mm_mul_ps(
      _mm_add_ps(_mm_add_ps(_mm_mul_ps(e2x, qx), _mm_mul_ps(e2y, qy)), _mm_mul_ps(e2z, qz)), inv_det);
  hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmpge_ps(t, _mm_set1_ps(tmin)), _mm_cmple_ps(t, _mm_set1_ps(tmax))));
  _mm_storeu_ps(t_out, t);
  _mm_storeu_ps(u_out, u);
  _mm_storeu_ps(v_out, v);
  return static_cast<uint32_t>(_mm_movemask_ps(hit));
}

#endif

#if defined(SAHBENCH_WIDE_AVX2) || defined(SAHBENCH_WIDE_AVX512)
// Two consecutive blocks (one leaf's) at once, 8 lanes: intersect_block_mt lane for lane, in 256-bit
// registers. Bits 0-3 are the first block's lanes, 4-7 the second's.
SAHBENCH_KERNEL_INLINE __m256 load_pair(const float* lo, const float* hi) {
  return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(lo)), _mm_load_ps(hi), 1);
}

// All ones in the lanes of two blocks that hold a triangle (lanes_valid for 8 lanes).
SAHBENCH_KERNEL_INLINE __m256 pair_lanes_valid(const TriangleBlock& lo, const TriangleBlock& hi) {
  const __m256i prim = _mm256_insertf128_si256(
      _mm256_castsi128_si256(_mm_load_si128(reinterpret_cast<const __m128i*>(lo.prim))),
      _mm_load_si128(reinterpret_cast<const __m128i*>(hi.prim)), 1);
  const __m256i all = _mm256_set1_epi32(-1);
  return _mm256_castsi256_ps(_mm256_xor_si256(_mm256_cmpeq_epi32(prim, all), all));
}

SAHBENCH_KERNEL_INLINE uint32_t intersect_block_pair_mt(const TriangleBlock* b, const WideRay& r, float tmin,
                                                        float tmax, float epsilon, float* t_out, float* u_out,
                                                        float* v_out) {
  const __m256 valid = pair_lanes_valid(b[0], b[1]);
  const __m256 v0x = load_pair(b[0].v0[0], b[1].v0[0]), v0y = load_pair(b[0].v0[1], b[1].v0[1]),
               v0z = load_pair(b[0].v0[2], b[1].v0[2]);
  const __m256 e1x = load_pair(b[0].v1[0], b[1].v1[0]), e1y = load_pair(b[0].v1[1], b[1].v1[1]),
               e1z = load_pair(b[0].v1[2], b[1].v1[2]);
  const __m256 e2x = load_pair(b[0].v2[0], b[1].v2[0]), e2y = load_pair(b[0].v2[1], b[1].v2[1]),
               e2z = load_pair(b[0].v2[2], b[1].v2[2]);
  const __m256 dx = _mm256_set1_ps(r.dir[0]), dy = _mm256_set1_ps(r.dir[1]), dz = _mm256_set1_ps(r.dir[2]);
  const __m256 px = _mm256_sub_ps(_mm256_mul_ps(dy, e2z), _mm256_mul_ps(dz, e2y));
  const __m256 py = _mm256_sub_ps(_mm256_mul_ps(dz, e2x), _mm256_mul_ps(dx, e2z));
  const __m256 pz = _mm256_sub_ps(_mm256_mul_ps(dx, e2y), _mm256_mul_ps(dy, e2x));
  const __m256 det =
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(e1x, px), _mm256_mul_ps(e1y, py)), _mm256_mul_ps(e1z, pz));
  const __m256 sign = _mm256_set1_ps(-0.0f);
  __m256 hit =
      _mm256_and_ps(valid, _mm256_cmp_ps(_mm256_andnot_ps(sign, det), _mm256_set1_ps(epsilon), _CMP_GT_OQ));
  if (!_mm256_movemask_ps(hit)) return 0;
  const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
  const __m256 sx = _mm256_sub_ps(_mm256_set1_ps(r.org[0]), v0x),
               sy = _mm256_sub_ps(_mm256_set1_ps(r.org[1]), v0y),
               sz = _mm256_sub_ps(_mm256_set1_ps(r.org[2]), v0z);
  const __m256 u = _mm256_mul_ps(
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(sx, px), _mm256_mul_ps(sy, py)), _mm256_mul_ps(sz, pz)),
      inv_det);
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  hit = _mm256_and_ps(hit,
                      _mm256_and_ps(_mm256_cmp_ps(u, zero, _CMP_GE_OQ), _mm256_cmp_ps(u, one, _CMP_LE_OQ)));
  const __m256 qx = _mm256_sub_ps(_mm256_mul_ps(sy, e1z), _mm256_mul_ps(sz, e1y));
  const __m256 qy = _mm256_sub_ps(_mm256_mul_ps(sz, e1x), _mm256_mul_ps(sx, e1z));
  const __m256 qz = _mm256_sub_ps(_mm256_mul_ps(sx, e1y), _mm256_mul_ps(sy, e1x));
  const __m256 v = _mm256_mul_ps(
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, qx), _mm256_mul_ps(dy, qy)), _mm256_mul_ps(dz, qz)),
      inv_det);
  hit = _mm256_and_ps(hit, _mm256_and_ps(_mm256_cmp_ps(v, zero, _CMP_GE_OQ),
                                         _mm256_cmp_ps(_mm256_add_ps(u, v), one, _CMP_LE_OQ)));
  const __m256 t = _mm256_mul_ps(
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(e2x, qx), _mm256_mul_ps(e2y, qy)), _mm256_mul_ps(e2z, qz)),
      inv_det);
  hit = _mm256_and_ps(hit, _mm256_and_ps(_mm256_cmp_ps(t, _mm256_set1_ps(tmin), _CMP_GE_OQ),
                                         _mm256_cmp_ps(t, _mm256_set1_ps(tmax), _CMP_LE_OQ)));
  _mm256_storeu_ps(t_out, t);
  _mm256_storeu_ps(u_out, u);
  _mm256_storeu_ps(v_out, v);
  return static_cast<uint32_t>(_mm256_movemask_ps(hit));
}
#endif

#if defined(SAHBENCH_WIDE_AVX2) || defined(SAHBENCH_WIDE_AVX512)
// RayLanes, intersect_mtn_lanes and Ops128, shared with the binary layouts' leaves.
#include "traversal/mtn_lanes.inl"

template <class Ops>
SAHBENCH_KERNEL_INLINE RayLanes<Ops> ray_lanes(const WideRay& r, float tmin, float tmax) {
  return {{Ops::set1(r.org[0]), Ops::set1(r.org[1]), Ops::set1(r.org[2])},
          {Ops::set1(r.dir[0]), Ops::set1(r.dir[1]), Ops::set1(r.dir[2])},
          Ops::set1(tmin),
          Ops::set1(tmax)};
}

struct Ops256 {
  using V = __m256;
  SAHBENCH_KERNEL_INLINE static __m256 set1(float x) { return _mm256_set1_ps(x); }
  SAHBENCH_KERNEL_INLINE static __m256 add(__m256 a, __m256 b) { return _mm256_add_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m256 sub(__m256 a, __m256 b) { return _mm256_sub_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m256 mul(__m256 a, __m256 b) { return _mm256_mul_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m256 div(__m256 a, __m256 b) { return _mm256_div_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m256 fmadd(__m256 a, __m256 b, __m256 c) {
    return _mm256_fmadd_ps(a, b, c);
  }
  SAHBENCH_KERNEL_INLINE static __m256 fmsub(__m256 a, __m256 b, __m256 c) {
    return _mm256_fmsub_ps(a, b, c);
  }
  SAHBENCH_KERNEL_INLINE static __m256 and_(__m256 a, __m256 b) { return _mm256_and_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m256 xor_(__m256 a, __m256 b) { return _mm256_xor_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m256 or_(__m256 a, __m256 b) { return _mm256_or_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m256 andnot(__m256 a, __m256 b) { return _mm256_andnot_ps(a, b); }
  SAHBENCH_KERNEL_INLINE static __m256 ge(__m256 a, __m256 b) { return _mm256_cmp_ps(a, b, _CMP_GE_OQ); }
  SAHBENCH_KERNEL_INLINE static __m256 le(__m256 a, __m256 b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
  SAHBENCH_KERNEL_INLINE static __m256 lt(__m256 a, __m256 b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
  SAHBENCH_KERNEL_INLINE static __m256 gt(__m256 a, __m256 b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
  SAHBENCH_KERNEL_INLINE static __m256 neq(__m256 a, __m256 b) { return _mm256_cmp_ps(a, b, _CMP_NEQ_UQ); }
  SAHBENCH_KERNEL_INLINE static int movemask(__m256 a) { return _mm256_movemask_ps(a); }
  SAHBENCH_KERNEL_INLINE static void store(float* p, __m256 a) { _mm256_storeu_ps(p, a); }
};

// The [component][lane] array `part` of a NormalBlock: 0 v0, 1 e1, 2 e2, 3 the normal.
SAHBENCH_KERNEL_INLINE const float (*mtn_part(const NormalBlock& b, int part))[kBlockWidth] {
  return part == 0 ? b.tri.v0 : part == 1 ? b.tri.v1 : part == 2 ? b.tri.v2 : b.normal;
}

SAHBENCH_KERNEL_INLINE uint32_t intersect_block_mtn(const NormalBlock& b, const WideRay& r, float tmin,
                                                    float tmax, float* t_out, float* u_out, float* v_out) {
  auto load = [&](int part, int axis) __attribute__((always_inline)) {
    return _mm_load_ps(mtn_part(b, part)[axis]);
  };
  const uint32_t hits = intersect_mtn_lanes<__m128, Ops128>(
      lanes_valid(b.tri), load, ray_lanes<Ops128>(r, tmin, tmax), t_out, u_out, v_out);
  const uint32_t in_double = mtn_double_lanes(b, r);
  if (in_double) [[unlikely]]
    return mtn_lanes_in_double(&b, in_double, hits, r, tmin, tmax, t_out, u_out, v_out);
  return hits;
}

// Two consecutive blocks, 8 lanes: bits 0-3 are the first block's lanes, 4-7 the second's.
SAHBENCH_KERNEL_INLINE uint32_t intersect_block_pair_mtn(const NormalBlock* b, const WideRay& r, float tmin,
                                                         float tmax, float* t_out, float* u_out,
                                                         float* v_out) {
  auto load = [&](int part, int axis) __attribute__((always_inline)) {
    return load_pair(mtn_part(b[0], part)[axis], mtn_part(b[1], part)[axis]);
  };
  const uint32_t hits = intersect_mtn_lanes<__m256, Ops256>(
      pair_lanes_valid(b[0].tri, b[1].tri), load, ray_lanes<Ops256>(r, tmin, tmax), t_out, u_out, v_out);
  const uint32_t in_double = mtn_double_lanes(b[0], r) | mtn_double_lanes(b[1], r) << kBlockWidth;
  if (in_double) [[unlikely]]
    return mtn_lanes_in_double(b, in_double, hits, r, tmin, tmax, t_out, u_out, v_out);
  return hits;
}

// Two consecutive blocks, 8 lanes: intersect_block_watertight<kRefine> lane for lane (watertight_in_lanes
// on 256-bit registers, each lane the scalar test's operations), both blocks against one tmax. Bits 0-3
// are the first block's lanes, 4-7 the second's.
template <bool kRefine>
SAHBENCH_KERNEL_INLINE uint32_t intersect_block_pair_watertight(const TriangleBlock* b, const WideRay& r,
                                                                float tmin, float tmax, float* t_out,
                                                                float* u_out, float* v_out) {
  const uint32_t axis[3] = {r.kx, r.ky, r.kz};
  __m256 vertex[3][3];
  for (int k = 0; k < 3; ++k) {
    for (int a = 0; a < 3; ++a) {
      const float(&lo)[3][kBlockWidth] = k == 0 ? b[0].v0 : k == 1 ? b[0].v1 : b[0].v2;
      const float(&hi)[3][kBlockWidth] = k == 0 ? b[1].v0 : k == 1 ? b[1].v1 : b[1].v2;
      vertex[k][a] = load_pair(lo[axis[a]], hi[axis[a]]);
    }
  }
  const __m256 org[3] = {_mm256_set1_ps(r.org[r.kx]), _mm256_set1_ps(r.org[r.ky]),
                         _mm256_set1_ps(r.org[r.kz])};
  const __m256 shear[3] = {_mm256_set1_ps(r.sx), _mm256_set1_ps(r.sy), _mm256_set1_ps(r.sz)};
  const auto in_double = [](float ax, float ay, float az, float bx, float by, float bz, float cx, float cy,
                            float cz, float lo, float hi, float& t, float& u, float& v) {
    return lane_in_double(ax, ay, az, bx, by, bz, cx, cy, cz, lo, hi, t, u, v);
  };
  const uint32_t mask =
      watertight_in_lanes<Ops256>(vertex, org, shear, pair_lanes_valid(b[0], b[1]), _mm256_set1_ps(tmin),
                                  _mm256_set1_ps(tmax), t_out, u_out, v_out, in_double);
  if (!kRefine || !mask) return mask;
  return refine_lanes<false>(b[0], r, tmin, tmax, mask & kBlockLanes, t_out) |
         refine_lanes<false>(b[1], r, tmin, tmax, mask >> kBlockWidth, t_out + kBlockWidth) << kBlockWidth;
}
#endif

// The block a layout of triangle test kTri stores (wide_bvh.h: BlockForm), and its TriangleBlock part.
template <TriangleTestKind kTri>
using BlockOf =
    std::conditional_t<kTri == TriangleTestKind::kMollerTrumboreNormal, NormalBlock, TriangleBlock>;
SAHBENCH_KERNEL_INLINE const TriangleBlock& tri_part(const TriangleBlock& b) {
  return b;
}
SAHBENCH_KERNEL_INLINE const TriangleBlock& tri_part(const NormalBlock& b) {
  return b.tri;
}

template <TriangleTestKind kTri, bool kAnyHit = false>
SAHBENCH_KERNEL_INLINE uint32_t intersect_block(const BlockOf<kTri>& b, const WideRay& r, float tmin,
                                                float tmax, float* t, float* u, float* v) {
  if constexpr (kTri == TriangleTestKind::kWatertight)
    return intersect_block_watertight<!kAnyHit>(b, r, tmin, tmax, t, u, v);
  else if constexpr (kTri == TriangleTestKind::kMollerTrumbore)
    return intersect_block_mt(b, r, tmin, tmax, kWideMtEpsilon, t, u, v);
  else if constexpr (kTri == TriangleTestKind::kMollerTrumboreNoEpsilon)
    return intersect_block_mt(b, r, tmin, tmax, 0.0f, t, u, v);
  else
    return intersect_block_mtn(b, r, tmin, tmax, t, u, v);
}

SAHBENCH_KERNEL_INLINE uint32_t occupied_lanes(const TriangleBlock& b) {
  uint32_t n = 0;
  for (uint32_t i = 0; i < kBlockWidth; ++i) n += b.prim[i] != kInvalidPrim;
  return n;
}

// ---------------------------------------------------------------------------------------------------
// The traversal: depth first with an explicit stack of child slots (inner nodes and leaves alike), the
// children a ray enters pushed so that the nearest is popped first, and (closest hit) entries entered
// beyond the closest hit so far skipped when popped. The same loop as
// bvh2_traversal.h, with a node's N box tests done at once.

struct WideStackEntry {
  uint32_t child;
  uint32_t count;  // 0: inner node `child`; else a leaf of `count` blocks from `child`
  float t_entry;
};

// Where an any-hit walk found its hit: the leaf (`count` blocks from `leaf`), and the last inner node the
// walk visited (ShadowCache): the leaf's parent, whose subtree holds its neighbours, where the walk went
// straight down to it; a node of a subtree the walk left empty-handed where it took the leaf off its stack.
struct Occluder {
  uint32_t leaf;
  uint32_t count;
  uint32_t node;
};

// Stack bound: compile_wide() rejects wide nodes deeper than kMaxDepth - 1, and popping a node then
// pushing its at most N children leaves at most N - 1 entries per level, so (N - 1) kMaxDepth + 1 entries
// suffice: 449 for N = 8.
inline constexpr uint32_t kWideStackCapacity = 7 * kMaxDepth + 1;

// The root's box, one lane: the scalar slab test of intersect_children.
template <BoxTestKind kBox>
SAHBENCH_KERNEL_INLINE bool intersect_root(const float* planes, const WideRay& r, float& t_entry) {
  float t_near = r.tmin, t_far = r.tmax;
  for (uint32_t axis = 0; axis < 3; ++axis) {
    const float t0 = plane_distance<kBox>(planes[r.near_plane[axis]], r, axis);
    float t1 = plane_distance<kBox>(planes[r.far_plane[axis]], r, axis);
    if constexpr (kBox == BoxTestKind::kRobust) t1 *= kWideFarScale;
    t_near = t0 > t_near ? t0 : t_near;
    t_far = t1 < t_far ? t1 : t_far;
  }
  t_entry = t_near;
  return t_near <= t_far;
}

// A float's bits as an unsigned integer with the same order (negative values flipped whole, positive
// ones with the sign bit set), so distances sort as integers.
SAHBENCH_KERNEL_INLINE uint32_t ordered_bits(float x) {
  const uint32_t bits = __builtin_bit_cast(uint32_t, x);
  return bits ^ ((bits >> 31) ? 0xffffffffu : 0x80000000u);
}

SAHBENCH_KERNEL_INLINE void compare_swap(uint64_t& a, uint64_t& b) {
  const uint64_t lo = a < b ? a : b, hi = a < b ? b : a;
  a = lo;
  b = hi;
}

// The key of an unused place: larger than every real one.
inline constexpr uint64_t kLastKey = ~uint64_t{0};

// Sorts keys[0, k) ascending, 2 <= k <= N, without branches on the keys: the caller has filled unused
// places with kLastKey, and the whole array goes through a sorting network, Knuth's (TAOCP vol. 3,
// 5.3.4) optimal ones for 4 (5 comparators) and 8 (19 comparators) inputs. The next node's address
// waits for this sort, so it is kept short and free of mispredicted branches.
template <uint32_t N>
SAHBENCH_KERNEL_INLINE void sort_keys(uint64_t* keys, uint32_t k) {
  if (N == 4 || k <= 4) {
    compare_swap(keys[0], keys[1]);
    compare_swap(keys[2], keys[3]);
    compare_swap(keys[0], keys[2]);
    compare_swap(keys[1], keys[3]);
    compare_swap(keys[1], keys[2]);
    return;
  }
  if constexpr (N == 8) {
    constexpr uint8_t kNetwork[19][2] = {{0, 2}, {1, 3}, {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6},
                                         {3, 7}, {0, 1}, {2, 3}, {4, 5}, {6, 7}, {2, 4}, {3, 5},
                                         {1, 4}, {3, 6}, {1, 2}, {3, 4}, {5, 6}};
    for (const auto& [a, b] : kNetwork) compare_swap(keys[a], keys[b]);
  }
}

// The node or block at arena reference `ref` (wide_bvh.h).
template <class T>
SAHBENCH_KERNEL_INLINE const T& at(const WideUnit* arena, uint32_t ref) {
  return *reinterpret_cast<const T*>(arena + ref);
}

// A child's node, or its leaf's first block, fetched ahead of its visit.
template <uint32_t N>
SAHBENCH_KERNEL_INLINE void prefetch_slot(const WideUnit* arena, uint32_t child, uint32_t count) {
  const char* p = reinterpret_cast<const char*>(arena + child);
  __builtin_prefetch(p);
  __builtin_prefetch(p + 64);
  __builtin_prefetch(p + 128);
  if (N == 8 || count != 0) __builtin_prefetch(p + 192);
}

// The children of `node` that the ray enters (bit i of `mask`, entered at t_entry[i]): returns the one
// to visit next and pushes the others. One child, the common case below the top levels, goes straight.
// Closest hit: two or more are sorted nearest first by a 64-bit key, the entry distance as an ordered
// integer above and the slot below (ties go to the higher slot, as in bvh2_traversal.h, so both kernels
// visit the same nodes); the rest are pushed farthest first and fetched ahead. Any hit visits them in
// kOrder (bvh2_traversal.h: resolve_any_hit_order): kStored in slot order, which the wide builders make
// an occlusion order (builders/child_order.h), kNearestStored (kFarthestStored) the nearest (farthest)
// first and then slot order.
// Any hit does not fetch the children it pushes: a shadow ray often ends before it pops them, and
// fetching them traced the shadow rays of Sponza 1%, of the bunny and the dragon 3% slower (two same-run
// A/Bs, 6 and 8 rounds, t1 and t2; the terrain within noise).
template <uint32_t N, AnyHitOrder kOrder>
SAHBENCH_KERNEL_INLINE WideStackEntry descend(const WideNode<N>& node, uint32_t mask, const float* t_entry,
                                              const WideUnit* arena, WideStackEntry* stack, uint32_t& size) {
  const uint32_t first = static_cast<uint32_t>(__builtin_ctz(mask));
  if ((mask & (mask - 1)) == 0) return {node.child[first], node.count[first], t_entry[first]};
  if constexpr (kOrder == AnyHitOrder::kStored || kOrder == AnyHitOrder::kNearestStored ||
                kOrder == AnyHitOrder::kFarthestStored) {
    uint32_t next = first;
    if constexpr (kOrder != AnyHitOrder::kStored) {
      // The nearest (kFarthestStored: the farthest), ties to the earlier slot: a shadow ray starts inside
      // several boxes (entry distance tmin), and the stored order puts the likelier occluder first. Ties to
      // the later slot traced wide_binned_sah's Sponza shadow rays 31% slower. The distance is kept in a
      // register: comparing against t_entry[next] chained a load into every step, and traced 2-5% slower on
      // the bunny, the dragon and the terrain (7% faster on Sponza; measured with ties to the later slot).
      float next_t = t_entry[first];
      for (uint32_t m = mask & (mask - 1); m; m &= m - 1) {
        const uint32_t i = static_cast<uint32_t>(__builtin_ctz(m));
        const float t = t_entry[i];
        const bool better = kOrder == AnyHitOrder::kFarthestStored ? t > next_t : t < next_t;
        next = better ? i : next;
        next_t = better ? t : next_t;
      }
    }
    for (uint32_t rest = mask & ~(1u << next); rest;) {
      const uint32_t i = 31u - static_cast<uint32_t>(__builtin_clz(rest));  // the last slot left
      stack[size++] = {node.child[i], node.count[i], t_entry[i]};
      rest &= ~(1u << i);
    }
    return {node.child[next], node.count[next], t_entry[next]};
  }
  // Two children, the most common case after one: the nearer goes on, the other on the stack (ties to
  // the higher slot, as the keys below order them).
  const uint32_t rest = mask & (mask - 1);
  if ((rest & (rest - 1)) == 0) {
    const uint32_t second = static_cast<uint32_t>(__builtin_ctz(rest));
    const bool second_first = t_entry[second] <= t_entry[first];
    const uint32_t near = second_first ? second : first, far = second_first ? first : second;
    prefetch_slot<N>(arena, node.child[near], node.count[near]);
    prefetch_slot<N>(arena, node.child[far], node.count[far]);
    stack[size++] = {node.child[far], node.count[far], t_entry[far]};
    return {node.child[near], node.count[near], t_entry[near]};
  }
  // All places first, with two vector stores (a fill of the places left after the loop became a call
  // to memset, with a vzeroupper, on the way to the next node).
  uint64_t keys[N < 4 ? 4 : N];
  for (uint64_t& key : keys) key = kLastKey;
  uint32_t k = 0;
  for (uint32_t m = mask; m; m &= m - 1) {
    const uint32_t i = static_cast<uint32_t>(__builtin_ctz(m));
    // + 0.0f turns -0 into +0, which compare equal as floats.
    keys[k++] = (static_cast<uint64_t>(ordered_bits(t_entry[i] + 0.0f)) << 32) | (N - 1 - i);
    prefetch_slot<N>(arena, node.child[i], node.count[i]);
  }
  sort_keys<N>(keys, k);
  for (uint32_t j = k - 1; j > 0; --j) {
    const uint32_t i = N - 1 - static_cast<uint32_t>(keys[j]);
    stack[size++] = {node.child[i], node.count[i], t_entry[i]};
  }
  const uint32_t i = N - 1 - static_cast<uint32_t>(keys[0]);
  return {node.child[i], node.count[i], t_entry[i]};
}

// Closest hit: the lanes of `lanes` (hits of `block` at t, u, v) that are closer than best_t, or as close
// with a lower primitive index (the tie rule of bvh2_traversal.h), taken in lane order into `best`.
SAHBENCH_KERNEL_INLINE void take_closest(const TriangleBlock& block, uint32_t lanes, const float* t,
                                         const float* u, const float* v, Hit& best, float& best_t) {
  for (; lanes; lanes &= lanes - 1) {
    const uint32_t i = static_cast<uint32_t>(__builtin_ctz(lanes));
    const uint32_t prim = block.prim[i];
    if (t[i] < best_t || (t[i] == best_t && prim < best.prim)) {
      best = {prim, t[i], u[i], v[i]};
      best_t = t[i];
    }
  }
}

// Any hit: the first lane of `lanes` (hits of `block` at the float distances in t) that stands goes into
// `best`; false when none does. A watertight float hit near either end of the interval is kept only where
// its refined distance lies in it (triangle_tests.h: WatertightTriangleTest::intersect_any).
template <TriangleTestKind kTri>
SAHBENCH_KERNEL_INLINE bool take_any_hit(const TriangleBlock& block, const WideRay& r, uint32_t lanes,
                                         float* t, float tmax, Hit& best) {
  if (!lanes) return false;
  if constexpr (kTri == TriangleTestKind::kWatertight) {
    const uint32_t i = static_cast<uint32_t>(__builtin_ctz(lanes));
    if (!lane_range_holds(block, r, i, t[i], r.tmin, tmax)) [[unlikely]] {
      lanes = refine_lanes<true>(block, r, r.tmin, tmax, lanes, t);
      if (!lanes) return false;
    }
  }
  best = {block.prim[__builtin_ctz(lanes)], t[__builtin_ctz(lanes)], 0.0f, 0.0f};
  return true;
}

// The blocks of a leaf against one ray. Closest hit: hits closer than best_t (or as close with a lower
// primitive index) go into `best`, and false is returned. Any hit: true on the first hit, in `best`.
template <TriangleTestKind kTri, bool kAnyHit, bool kCount>
SAHBENCH_KERNEL_INLINE bool intersect_leaf(const BlockOf<kTri>* blocks, uint32_t count, const WideRay& r,
                                           Hit& best, float& best_t, [[maybe_unused]] WideCounts* counts) {
  uint32_t b = 0;
#if defined(SAHBENCH_WIDE_AVX2) || defined(SAHBENCH_WIDE_AVX512)
  if constexpr (!kAnyHit && !kCount) {
    // Closest hit: two blocks at a time, 8 lanes. Möller–Trumbore compares t with tmax only at its end,
    // so testing the second block against the same tmax as the first finds the same closest hit (and tie)
    // as testing it after the first. The watertight test lowers tmax to each hit's refined distance, so
    // where the first block did and the second has hits, the second is tested again alone against the
    // lowered tmax (both blocks of a leaf rarely hit): the hits are those of block by block.
    for (; b + 1 < count; b += 2) {
      alignas(32) float t[2 * kBlockWidth], u[2 * kBlockWidth], v[2 * kBlockWidth];
      uint32_t lanes;
      if constexpr (kTri == TriangleTestKind::kWatertight) {
        lanes = intersect_block_pair_watertight<true>(blocks + b, r, r.tmin, best_t, t, u, v);
        const float before = best_t;
        take_closest(tri_part(blocks[b]), lanes & kBlockLanes, t, u, v, best, best_t);
        lanes >>= kBlockWidth;
        if (lanes && best_t != before)
          lanes = intersect_block_watertight<true>(blocks[b + 1], r, r.tmin, best_t, t + kBlockWidth,
                                                   u + kBlockWidth, v + kBlockWidth);
      } else {
        if constexpr (kTri == TriangleTestKind::kMollerTrumboreNormal) {
          lanes = intersect_block_pair_mtn(blocks + b, r, r.tmin, best_t, t, u, v);
        } else {
          const float eps = kTri == TriangleTestKind::kMollerTrumbore ? kWideMtEpsilon : 0.0f;
          lanes = intersect_block_pair_mt(blocks + b, r, r.tmin, best_t, eps, t, u, v);
        }
        take_closest(tri_part(blocks[b]), lanes & kBlockLanes, t, u, v, best, best_t);
        lanes >>= kBlockWidth;
      }
      take_closest(tri_part(blocks[b + 1]), lanes, t + kBlockWidth, u + kBlockWidth, v + kBlockWidth, best,
                   best_t);
    }
  }
  if constexpr (kAnyHit && kTri == TriangleTestKind::kWatertight && !kCount) {
    // Any hit with the watertight test: two blocks at a time, the first block's hits taken before the
    // second's, so the same hit as block by block. Möller–Trumbore keeps one block at a time: the first
    // block often ends the ray, and its cheaper test made the second's wasted test cost more (-1% on two
    // scenes).
    for (; b + 1 < count; b += 2) {
      alignas(32) float t[2 * kBlockWidth], u[2 * kBlockWidth], v[2 * kBlockWidth];
      const uint32_t lanes = intersect_block_pair_watertight<false>(blocks + b, r, r.tmin, best_t, t, u, v);
      if (take_any_hit<kTri>(tri_part(blocks[b]), r, lanes & kBlockLanes, t, best_t, best) ||
          take_any_hit<kTri>(tri_part(blocks[b + 1]), r, lanes >> kBlockWidth, t + kBlockWidth, best_t, best))
        return true;
    }
  }
#endif
  for (; b < count; ++b) {
    alignas(16) float t[kBlockWidth], u[kBlockWidth], v[kBlockWidth];
    uint32_t lanes = intersect_block<kTri, kAnyHit>(blocks[b], r, r.tmin, best_t, t, u, v);
    const TriangleBlock& block = tri_part(blocks[b]);
    if constexpr (kCount) counts->prim_tests += occupied_lanes(block);
    if constexpr (kAnyHit) {
      if (take_any_hit<kTri>(block, r, lanes, t, best_t, best)) return true;
    } else {
      take_closest(block, lanes, t, u, v, best, best_t);
    }
  }
  return false;
}

// One ray through the subtree at `entry` (a node or a leaf it enters at entry.t_entry), starting from the
// closest hit so far in `best` and `best_t`, which it updates. Returns true when any hit has found one.
// One ray's walk below a node, one step at a time: a leaf, or an inner node, and then the pops to the
// next entry. Stepping two walks in turn (trace_ray_pair) gives the core two independent chains of loads,
// box tests and branches to overlap.
template <uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, bool kAnyHit, bool kCount, AnyHitOrder kOrder,
          IntOrder kInt>
class WideWalk {
 public:
  static_assert(kWideStackCapacity >= (N - 1) * kMaxDepth + 1, "wide traversal stack too small");

  SAHBENCH_KERNEL_INLINE WideWalk(const WideUnit* arena, const WideRay& r, WideStackEntry entry,
                                  const Hit& best, float best_t, WideCounts* counts)
      : arena_(arena),
        r_(r),
        slabs_(ray_slabs(r)),
        entry_(entry),
        best_(best),
        best_t_(best_t),
        counts_(counts) {}

  /// One step; false once the walk is over: the stack ran out, or (any hit) a hit was found.
  SAHBENCH_KERNEL_INLINE bool step() {
    if (entry_.count != 0) {
      if constexpr (kCount) ++counts_->leaf_visits;
      if (intersect_leaf<kTri, kAnyHit, kCount>(&at<BlockOf<kTri>>(arena_, entry_.child), entry_.count, r_,
                                                best_, best_t_, counts_)) {
        found_any_ = true;
        return false;
      }
    } else {
      const WideNode<N>& node = at<WideNode<N>>(arena_, entry_.child);
      // The child and count line is read only after the box test has picked a child: ask for it now, so
      // that it arrives with the planes rather than one memory latency after them.
      __builtin_prefetch(node.child);
      if constexpr (kCount) ++counts_->inner_visits;
      if constexpr (kAnyHit) node_ = entry_.child;
      alignas(32) float t_entry[N];
      const uint32_t mask = intersect_children<N, kBox, kInt>(node, r_, slabs_, r_.tmin, best_t_, t_entry);
      if (mask != 0) {
        // Continue with the nearest child entered; the others go on the stack, farthest deepest.
        entry_ = descend<N, kOrder>(node, mask, t_entry, arena_, stack_, size_);
        return true;
      }
    }
    // The next entry, skipping those entered beyond the closest hit so far (nothing inside can be closer;
    // equal is kept for the tie rule).
    do {
      if (size_ == 0) return false;
      entry_ = stack_[--size_];
    } while (!kAnyHit && entry_.t_entry > best_t_);
    return true;
  }

  const Hit& best() const { return best_; }
  float best_t() const { return best_t_; }
  /// Any hit: whether the walk ended on a hit.
  bool found_any() const { return found_any_; }
  /// Any hit, once found_any(): where the walk found its hit.
  Occluder occluder() const { return {entry_.child, entry_.count, node_}; }

 private:
  const WideUnit* arena_;
  const WideRay& r_;
  RaySlabs slabs_;
  WideStackEntry entry_;
  Hit best_;
  float best_t_;
  [[maybe_unused]] WideCounts* counts_;
  uint32_t size_ = 0;
  uint32_t node_ = 0;
  bool found_any_ = false;
  WideStackEntry stack_[kWideStackCapacity];
};

// The walk below `entry` to its end; true when an any-hit query found a hit.
template <uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, bool kAnyHit, bool kCount, AnyHitOrder kOrder,
          IntOrder kInt>
SAHBENCH_KERNEL_INLINE bool trace_subtree(const WideUnit* arena, const WideRay& r, WideStackEntry entry,
                                          Hit& best, float& best_t, WideCounts* counts,
                                          Occluder* occluder = nullptr) {
  WideWalk<N, kTri, kBox, kAnyHit, kCount, kOrder, kInt> walk(arena, r, entry, best, best_t, counts);
  while (walk.step()) {
  }
  best = walk.best();
  best_t = walk.best_t();
  if (occluder && walk.found_any()) *occluder = walk.occluder();
  return walk.found_any();
}

template <uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, bool kAnyHit, bool kCount, AnyHitOrder kOrder,
          IntOrder kInt>
inline Hit trace_ray(const float* root_planes, const WideUnit* arena, const WideRay& r, WideCounts* counts,
                     Occluder* occluder = nullptr) {
  Hit best;
  float t_root;
  if (!intersect_root<kBox>(root_planes, r, t_root)) return best;
  float best_t = r.tmax;
  trace_subtree<N, kTri, kBox, kAnyHit, kCount, kOrder, kInt>(arena, r, {0, 0, t_root}, best, best_t, counts,
                                                              occluder);
  return best;
}

// Two rays, their walks stepped in turn until one ends, then the other alone: each ray's answer is the
// one trace_ray gives it.
template <uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, bool kAnyHit, bool kCount, AnyHitOrder kOrder,
          IntOrder kInt>
inline void trace_ray_pair(const float* root_planes, const WideUnit* arena, const WideRay& r0,
                           const WideRay& r1, WideCounts* counts, Hit& hit0, Hit& hit1,
                           Occluder* occluder0 = nullptr, Occluder* occluder1 = nullptr) {
  using Walk = WideWalk<N, kTri, kBox, kAnyHit, kCount, kOrder, kInt>;
  float t0, t1;
  const bool in0 = intersect_root<kBox>(root_planes, r0, t0), in1 = intersect_root<kBox>(root_planes, r1, t1);
  if (!in0 || !in1) {
    hit0 = in0 ? trace_ray<N, kTri, kBox, kAnyHit, kCount, kOrder, kInt>(root_planes, arena, r0, counts,
                                                                         occluder0)
               : Hit{};
    hit1 = in1 ? trace_ray<N, kTri, kBox, kAnyHit, kCount, kOrder, kInt>(root_planes, arena, r1, counts,
                                                                         occluder1)
               : Hit{};
    return;
  }
  Walk a(arena, r0, {0, 0, t0}, Hit{}, r0.tmax, counts), b(arena, r1, {0, 0, t1}, Hit{}, r1.tmax, counts);
  bool more_a = true, more_b = true;
  while (more_a && more_b) {
    more_a = a.step();
    more_b = b.step();
  }
  while (more_a) more_a = a.step();
  while (more_b) more_b = b.step();
  hit0 = a.best();
  hit1 = b.best();
  if (occluder0 && a.found_any()) *occluder0 = a.occluder();
  if (occluder1 && b.found_any()) *occluder1 = b.occluder();
}

// A shadow cache (Haines and Greenberg, "The Light Buffer: A Shadow-Testing Accelerator", IEEE CG&A
// 6(9), 1986: test first the object that blocked the last shadow ray towards the same light). Rays that
// end at one point, as a point light's shadow rays do, are keyed by that point; before a ray's walk, the
// leaf where the last such ray found its hit is tested, then the subtree of the last inner node that walk
// visited (its neighbours, which block the next ray where the leaf itself does not). With the robust box
// test the answer cannot change: a triangle the leaf test hits in [tmin, tmax] occludes the ray however
// it is found, and the walk's box tests never cull a leaf the ray reaches. A non-robust box test may cull
// a leaf whose triangle the ray grazes, and the cache then finds that hit where the walk would not.
class ShadowCache {
 public:
  static constexpr int kSlots = 8;

  /// The slot of the point where `r` ends: that of an earlier ray ending there (within a thousandth of
  /// the longer of the two rays' reach along an axis), else a new one; -1 once kSlots other points hold
  /// every slot, or where the ray has no finite end (an unbounded ray's reach overflows).
  SAHBENCH_KERNEL_INLINE int slot(const WideRay& r) {
    float e[3], reach = 0.0f;
    for (int a = 0; a < 3; ++a) {
      const float d = r.dir[a] * r.tmax;
      e[a] = r.org[a] + d;
      reach = __builtin_fmaxf(reach, __builtin_fabsf(d));
    }
    const float tol = kTolerance * reach;
    if (!(tol < __builtin_inff())) return -1;
    // Shadow rays usually take their lights in turn: the ray `used_` rays back most likely shares this
    // one's end point.
    int k = used_ != 0 ? recent_[(rays_ - used_) % kRecent] : -1;
    if (k < 0 || !ends_at(k, e, tol)) {
      k = -1;
      for (int j = 0; j < used_; ++j)
        if (ends_at(j, e, tol)) {
          k = j;
          break;
        }
      if (k < 0) {
        if (used_ == kSlots) return -1;
        k = open(e, tol);
      }
    }
    recent_[rays_++ % kRecent] = static_cast<int8_t>(k);
    return k;
  }

  /// Whether the batch's first 2 kSlots rays end at kSlots points or fewer, each at a finite one: a look
  /// that traces nothing, so that a batch of AO or diffuse rays never runs the cache's loop, whose code
  /// would displace the plain loop's from the instruction caches.
  SAHBENCH_KERNEL_INLINE static bool takes(const WideBatch& batch) {
    ShadowCache look;
    const std::size_t n = batch.count < 2 * kSlots ? batch.count : 2 * kSlots;
    for (std::size_t i = 0; i < n; ++i)
      if (look.slot(batch.rays[i]) < 0) return false;
    return true;
  }

  /// Whether slot k's occluder blocks `r`, a ray of slot k: the leaf, then the subtree of the last inner
  /// node (not from the root: that is the walk itself, which the ray takes next if this fails). Counts the
  /// test for the slot's retirement (tested).
  struct Settle {
    bool settled = false;
    bool by_subtree = false;
  };
  template <uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, AnyHitOrder kOrder, IntOrder kInt>
  SAHBENCH_KERNEL_INLINE Settle test(const WideUnit* arena, int k, const WideRay& r) {
    if (occluder_[k].count == 0) return {};
    Settle s;
    s.settled = test_leaf<kTri>(arena, k, r);
    if (!s.settled) {
      s.by_subtree = true;
      s.settled = test_subtree<N, kTri, kBox, kOrder, kInt>(arena, k, r);
    }
    tested(k, s.settled);
    return s;
  }
  /// The two parts of test, without the count. Whether slot k's leaf blocks `r`.
  template <TriangleTestKind kTri>
  SAHBENCH_KERNEL_INLINE bool test_leaf(const WideUnit* arena, int k, const WideRay& r) const {
    const Occluder& last = occluder_[k];
    if (last.count == 0) return false;
    Hit hit;
    float best_t = r.tmax;
    return intersect_leaf<kTri, true, false>(&at<BlockOf<kTri>>(arena, last.leaf), last.count, r, hit, best_t,
                                             nullptr);
  }
  /// Whether a leaf under slot k's last inner node blocks `r`; keeps that leaf as the slot's occluder.
  template <uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, AnyHitOrder kOrder, IntOrder kInt>
  SAHBENCH_KERNEL_INLINE bool test_subtree(const WideUnit* arena, int k, const WideRay& r) {
    const Occluder last = occluder_[k];
    if (last.count == 0 || last.node == 0) return false;
    Hit hit;
    float best_t = r.tmax;
    Occluder found;
    if (!trace_subtree<N, kTri, kBox, true, false, kOrder, kInt>(arena, r, {last.node, 0, r.tmin}, hit,
                                                                 best_t, nullptr, &found))
      return false;
    // The leaf found, under the same node: the subtree walk's own last node lies deeper, and testing from
    // there would narrow the cache's reach with every hit.
    remember(k, {found.leaf, found.count, last.node});
    return true;
  }
  /// What to test first for rays of slot k; its count is 0 when there is nothing.
  SAHBENCH_KERNEL_INLINE const Occluder& occluder(int k) const { return occluder_[k]; }
  /// Where the walk of a ray of slot k found its hit.
  SAHBENCH_KERNEL_INLINE void remember(int k, const Occluder& occluder) {
    if (!retired_[k]) occluder_[k] = occluder;
  }
  /// Whether slot k's occluder settled the ray it was tested on. A slot retires (is tested no more in
  /// this batch) when its occluders settle fewer than a quarter of a run of kWindow tests: where occluders
  /// change from ray to ray, each failed test only adds to the walk.
  SAHBENCH_KERNEL_INLINE void tested(int k, bool settled) {
    settled_[k] += settled;
    if (++tests_[k] < kWindow) return;
    if (settled_[k] < kWindow / 4) {
      retired_[k] = true;
      occluder_[k].count = 0;
    }
    tests_[k] = settled_[k] = 0;
  }

 private:
  static constexpr float kTolerance = 1e-3f;
  static constexpr uint8_t kWindow = 16;
  static constexpr uint32_t kRecent = 16;  // a power of two above kSlots

  // A new slot for rays that end at e; the caller has checked that one is free.
  SAHBENCH_KERNEL_INLINE int open(const float* e, float tol) {
    const uint32_t k = static_cast<uint32_t>(used_++) % kSlots;
    for (int a = 0; a < 3; ++a) end_[k][a] = e[a];
    tol_[k] = tol;
    occluder_[k].count = 0;
    tests_[k] = settled_[k] = 0;
    retired_[k] = false;
    return static_cast<int>(k);
  }

  SAHBENCH_KERNEL_INLINE bool ends_at(int k, const float* e, float tol) const {
    const float d = __builtin_fmaxf(
        __builtin_fmaxf(__builtin_fabsf(end_[k][0] - e[0]), __builtin_fabsf(end_[k][1] - e[1])),
        __builtin_fabsf(end_[k][2] - e[2]));
    return d <= __builtin_fmaxf(tol, tol_[k]);
  }

  float end_[kSlots][3];
  float tol_[kSlots];  // of the ray that opened the slot
  Occluder occluder_[kSlots];
  uint8_t tests_[kSlots], settled_[kSlots];
  bool retired_[kSlots];
  int8_t recent_[kRecent];
  uint32_t rays_ = 0;
  int used_ = 0;
};

// Any hit through a ShadowCache, from the batch's first ray up to the first that ends at a point no slot
// takes (then the batch is not rays to a few points, and the caller traces the rest, that ray included,
// from the index this returns). The rays the cache does not settle are traced two at a time
// (trace_ray_pair). Out of line, so that the batch loop without it compiles as it would alone.
template <uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, AnyHitOrder kOrder, IntOrder kInt>
[[gnu::noinline]] std::size_t trace_shadow_cached(const WideBatch& batch) {
  ShadowCache cache;
  std::size_t pending[2];
  int pending_slot[2], n = 0;
  auto trace_pending = [&] {
    Occluder found[2];
    Hit hit[2];
    if (n == 2)
      trace_ray_pair<N, kTri, kBox, true, false, kOrder, kInt>(batch.root_planes, batch.arena,
                                                               batch.rays[pending[0]], batch.rays[pending[1]],
                                                               nullptr, hit[0], hit[1], &found[0], &found[1]);
    else
      hit[0] = trace_ray<N, kTri, kBox, true, false, kOrder, kInt>(
          batch.root_planes, batch.arena, batch.rays[pending[0]], nullptr, &found[0]);
    for (int j = 0; j < n; ++j) {
      const bool occluded = hit[j].prim != kInvalidPrim;
      batch.occluded[pending[j]] = occluded;
      if (occluded) cache.remember(pending_slot[j], found[j]);
    }
    n = 0;
  };
  std::size_t i = 0;
  for (; i < batch.count; ++i) {
    const WideRay& r = batch.rays[i];
    const int k = cache.slot(r);
    if (k < 0) break;
    const ShadowCache::Settle s = cache.test<N, kTri, kBox, kOrder, kInt>(batch.arena, k, r);
    if (s.settled) {
      batch.occluded[i] = 1;
      if (batch.shadow_cache_settled) ++batch.shadow_cache_settled[s.by_subtree];
      continue;
    }
    pending[n] = i;
    pending_slot[n++] = k;
    if (n == 2) trace_pending();
  }
  if (n != 0) trace_pending();
  return i;
}

// The integer order (kInt) is chosen for a whole batch, the lowest of its rays' (WideBatch::int_order):
// guarded if any ray needs the check for -0, the float path if any ray cannot take the integer path. A
// choice per ray, between two calls in the loop, traced the closest-hit rays up to 9% slower (the
// bunny's primary rays), and a check of every ray here 3-5%, than no choice at all; the set-up has the
// ray's values in registers.
//
// box=fma: the rays outside its domain (WideRay::robust_box) are skipped by the loop and traced after it
// with the robust box test, so that the loop has one kernel inlined, as without them.
inline constexpr int kAllRays = 2;

template <uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, bool kAnyHit, bool kCount>
void trace_batch(const WideBatch& batch) {
  // rays: every ray of the batch (kAllRays), or only those whose WideRay::robust_box is 0 or 1.
  auto run = [&]<BoxTestKind kRayBox, AnyHitOrder kOrder, IntOrder kInt>(int rays) {
    auto put = [&](std::size_t i, const Hit& hit) {
      if constexpr (kAnyHit)
        batch.occluded[i] = hit.prim != kInvalidPrim;
      else
        batch.hits[i] = hit;
    };
    // Two rays at a time where every ray takes this kernel (trace_ray_pair).
    if (kBox != BoxTestKind::kFma || rays == kAllRays) {
      if constexpr (kCount) batch.counts->rays += batch.count;
      std::size_t i = 0;
      if constexpr (kAnyHit && !kCount) {
        if (batch.shadow_cache && ShadowCache::takes(batch))
          i = trace_shadow_cached<N, kTri, kRayBox, kOrder, kInt>(batch);
      }
      for (; i + 1 < batch.count; i += 2) {
        Hit h0, h1;
        trace_ray_pair<N, kTri, kRayBox, kAnyHit, kCount, kOrder, kInt>(
            batch.root_planes, batch.arena, batch.rays[i], batch.rays[i + 1], batch.counts, h0, h1);
        put(i, h0);
        put(i + 1, h1);
      }
      if (i < batch.count)
        put(i, trace_ray<N, kTri, kRayBox, kAnyHit, kCount, kOrder, kInt>(batch.root_planes, batch.arena,
                                                                          batch.rays[i], batch.counts));
      return;
    }
    for (std::size_t i = 0; i < batch.count; ++i) {
      if constexpr (kBox == BoxTestKind::kFma) {
        if (rays != kAllRays && static_cast<int>(batch.rays[i].robust_box) != rays) continue;
      }
      if constexpr (kCount) ++batch.counts->rays;
      put(i, trace_ray<N, kTri, kRayBox, kAnyHit, kCount, kOrder, kInt>(batch.root_planes, batch.arena,
                                                                        batch.rays[i], batch.counts));
    }
  };
  auto with_order = [&]<BoxTestKind kRayBox, IntOrder kInt>(int rays) {
    if constexpr (kAnyHit) {
      if (batch.any_hit_order == AnyHitOrder::kStored)
        return run.template operator()<kRayBox, AnyHitOrder::kStored, kInt>(rays);
      if (batch.any_hit_order == AnyHitOrder::kNearestStored)
        return run.template operator()<kRayBox, AnyHitOrder::kNearestStored, kInt>(rays);
      if (batch.any_hit_order == AnyHitOrder::kFarthestStored)
        return run.template operator()<kRayBox, AnyHitOrder::kFarthestStored, kInt>(rays);
    }
    run.template operator()<kRayBox, AnyHitOrder::kNearest, kInt>(rays);
  };
  // The others, skipping the batch's robust-box rays only where it has some.
  int fma_rays = kAllRays;
  if constexpr (kBox == BoxTestKind::kFma) {
    if (batch.robust_box) [[unlikely]] {
      with_order.template operator()<BoxTestKind::kRobust, IntOrder::kNone>(1);
      fma_rays = 0;
    }
  }
  if constexpr (kHasIntOrder && kBox == BoxTestKind::kFma) {
    if (batch.int_order == IntOrder::kFree)
      return with_order.template operator()<kBox, IntOrder::kFree>(fma_rays);
    if (batch.int_order == IntOrder::kGuarded)
      return with_order.template operator()<kBox, IntOrder::kGuarded>(fma_rays);
  }
  with_order.template operator()<kBox, IntOrder::kNone>(fma_rays);
}
// A table of this instruction set's kernels, [width 4, 8][triangle test][box test][closest, any]:
// `entry.template operator()<N, kTri, kBox, kAnyHit>()` is the kernel of one combination.
template <class Entry>
WideKernel select_variant(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit, Entry entry) {
  auto pick = [&]<uint32_t N, TriangleTestKind kTri>() -> WideKernel {
    auto with_box = [&]<BoxTestKind kBox>() -> WideKernel {
      return any_hit ? entry.template operator()<N, kTri, kBox, true>()
                     : entry.template operator()<N, kTri, kBox, false>();
    };
    switch (box) {
      case BoxTestKind::kRobust:
        return with_box.template operator()<BoxTestKind::kRobust>();
      case BoxTestKind::kFast:
        return with_box.template operator()<BoxTestKind::kFast>();
      case BoxTestKind::kFma:
        return with_box.template operator()<BoxTestKind::kFma>();
    }
    return nullptr;
  };
  auto by_tri = [&]<uint32_t N>() -> WideKernel {
    switch (tri) {
      case TriangleTestKind::kWatertight:
        return pick.template operator()<N, TriangleTestKind::kWatertight>();
      case TriangleTestKind::kMollerTrumbore:
        return pick.template operator()<N, TriangleTestKind::kMollerTrumbore>();
      case TriangleTestKind::kMollerTrumboreNoEpsilon:
        return pick.template operator()<N, TriangleTestKind::kMollerTrumboreNoEpsilon>();
      case TriangleTestKind::kMollerTrumboreNormal:
        return pick.template operator()<N, TriangleTestKind::kMollerTrumboreNormal>();
    }
    return nullptr;
  };
  if (width == 4) return by_tri.template operator()<4>();
  if (width == 8) return by_tri.template operator()<8>();
  return nullptr;
}

// The single-ray kernels (counting ones: kCount).
template <bool kCount>
WideKernel select_kernel(uint32_t width, TriangleTestKind tri, BoxTestKind box, bool any_hit) {
  return select_variant(
      width, tri, box, any_hit,
      []<uint32_t N, TriangleTestKind kTri, BoxTestKind kBox, bool kAnyHit>() -> WideKernel {
        return &trace_batch<N, kTri, kBox, kAnyHit, kCount>;
      });
}

// ---------------------------------------------------------------------------------------------------
// Loops for the micro-benchmarks (bench/): every ray against every node, or every block, in turn. The
// sum of the hit masks and distances is returned so the work cannot be optimised away.

template <uint32_t N, BoxTestKind kBox>
double node_test_loop(const void* nodes, std::size_t node_count, const WideRay* rays, std::size_t ray_count) {
  const auto* typed = static_cast<const WideNode<N>*>(nodes);
  double sum = 0.0;
  alignas(32) float t_entry[N];
  auto loop = [&]<BoxTestKind kRayBox, IntOrder kInt>(const WideRay& ray) {
    const RaySlabs slabs = ray_slabs(ray);
    for (std::size_t n = 0; n < node_count; ++n)
      sum += intersect_children<N, kRayBox, kInt>(typed[n], ray, slabs, ray.tmin, ray.tmax, t_entry) +
             t_entry[0];
  };
  for (std::size_t r = 0; r < ray_count; ++r) {
    // The kernels' choice of path (trace_batch), so that the tests compare the integer path as well.
    if constexpr (kBox == BoxTestKind::kFma) {
      if (rays[r].robust_box) {
        loop.template operator()<BoxTestKind::kRobust, IntOrder::kNone>(rays[r]);
        continue;
      }
    }
    if constexpr (kHasIntOrder && kBox == BoxTestKind::kFma) {
      if (rays[r].int_order == IntOrder::kFree) {
        loop.template operator()<kBox, IntOrder::kFree>(rays[r]);
        continue;
      }
      if (rays[r].int_order == IntOrder::kGuarded) {
        loop.template operator()<kBox, IntOrder::kGuarded>(rays[r]);
        continue;
      }
    }
    loop.template operator()<kBox, IntOrder::kNone>(rays[r]);
  }
  return sum;
}

// One node against one ray, for the tests: the hit mask, with every slot's entry distance in t_entry,
// on the path (integer or float) that trace_batch takes for a batch of that ray alone.
template <uint32_t N, BoxTestKind kBox>
uint32_t node_test_one(const void* node, const WideRay& ray, float* t_entry) {
  const auto& typed = *static_cast<const WideNode<N>*>(node);
  const RaySlabs slabs = ray_slabs(ray);
  if constexpr (kBox == BoxTestKind::kFma) {
    if (ray.robust_box)
      return intersect_children<N, BoxTestKind::kRobust>(typed, ray, slabs, ray.tmin, ray.tmax, t_entry);
  }
  if constexpr (kHasIntOrder && kBox == BoxTestKind::kFma) {
    if (ray.int_order == IntOrder::kFree)
      return intersect_children<N, kBox, IntOrder::kFree>(typed, ray, slabs, ray.tmin, ray.tmax, t_entry);
    if (ray.int_order == IntOrder::kGuarded)
      return intersect_children<N, kBox, IntOrder::kGuarded>(typed, ray, slabs, ray.tmin, ray.tmax, t_entry);
  }
  return intersect_children<N, kBox>(typed, ray, slabs, ray.tmin, ray.tmax, t_entry);
}

template <TriangleTestKind kTri>
double block_test_loop(const void* data, std::size_t block_count, const WideRay* rays,
                       std::size_t ray_count) {
  const auto* blocks = static_cast<const BlockOf<kTri>*>(data);
  double sum = 0.0;
  alignas(16) float t[kBlockWidth], u[kBlockWidth], v[kBlockWidth];
  for (std::size_t r = 0; r < ray_count; ++r)
    for (std::size_t b = 0; b < block_count; ++b)
      sum += intersect_block<kTri>(blocks[b], rays[r], rays[r].tmin, rays[r].tmax, t, u, v) + t[0];
  return sum;
}

inline WideBenchLoops select_bench_loops(uint32_t width, TriangleTestKind tri, BoxTestKind box) {
  WideBenchLoops loops{};
  auto nodes = [&]<uint32_t N>() {
    switch (box) {
      case BoxTestKind::kRobust:
        loops.nodes = &node_test_loop<N, BoxTestKind::kRobust>;
        loops.node = &node_test_one<N, BoxTestKind::kRobust>;
        break;
      case BoxTestKind::kFast:
        loops.nodes = &node_test_loop<N, BoxTestKind::kFast>;
        loops.node = &node_test_one<N, BoxTestKind::kFast>;
        break;
      case BoxTestKind::kFma:
        loops.nodes = &node_test_loop<N, BoxTestKind::kFma>;
        loops.node = &node_test_one<N, BoxTestKind::kFma>;
        break;
    }
  };
  if (width == 4) nodes.template operator()<4>();
  if (width == 8) nodes.template operator()<8>();
  switch (tri) {
    case TriangleTestKind::kWatertight:
      loops.blocks = &block_test_loop<TriangleTestKind::kWatertight>;
      break;
    case TriangleTestKind::kMollerTrumbore:
      loops.blocks = &block_test_loop<TriangleTestKind::kMollerTrumbore>;
      break;
    case TriangleTestKind::kMollerTrumboreNoEpsilon:
      loops.blocks = &block_test_loop<TriangleTestKind::kMollerTrumboreNoEpsilon>;
      break;
    case TriangleTestKind::kMollerTrumboreNormal:
      loops.blocks = &block_test_loop<TriangleTestKind::kMollerTrumboreNormal>;
      break;
  }
  return loops;
}
