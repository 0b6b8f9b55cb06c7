// The float part of the watertight test (Woop, Benthin and Wald 2013; triangle_tests.h's
// WatertightTriangleTest) on several lanes at once, from their vertices to the hits: the same
// float operations in the same order as the scalar test, lane by lane, so the same decisions. Shared by
// WatertightLanes (triangle_lanes.h, the binary layouts' leaves), the wide layouts' block test
// (wide_kernels.inl) and the binary packet kernels' leaves (pair_packets.inl). It is included
// inside a namespace by each (wide_kernels.inl's once per instruction set), so it includes nothing and calls
// only intrinsics, builtins and the double-precision finish its caller passes (triangle_tests.h's
// watertight_in_double, or wide_kernels.inl's own copy, lane_in_double): the including file includes
// <immintrin.h> first.

// The operations watertight_in_lanes takes on four lanes, SSE2 only: the packet kernels pass their own
// on eight or sixteen (wide_kernels.inl's Ops256, wide_packets.inl's Ops512). The comparisons are those
// of C's operators: false where either side is NaN, but `neq` true.
struct WatertightOps128 {
  using V = __m128;
  [[gnu::always_inline]] static __m128 set1(float x) { return _mm_set1_ps(x); }
  [[gnu::always_inline]] static __m128 add(__m128 a, __m128 b) { return _mm_add_ps(a, b); }
  [[gnu::always_inline]] static __m128 sub(__m128 a, __m128 b) { return _mm_sub_ps(a, b); }
  [[gnu::always_inline]] static __m128 mul(__m128 a, __m128 b) { return _mm_mul_ps(a, b); }
  [[gnu::always_inline]] static __m128 div(__m128 a, __m128 b) { return _mm_div_ps(a, b); }
  [[gnu::always_inline]] static __m128 and_(__m128 a, __m128 b) { return _mm_and_ps(a, b); }
  [[gnu::always_inline]] static __m128 or_(__m128 a, __m128 b) { return _mm_or_ps(a, b); }
  [[gnu::always_inline]] static __m128 xor_(__m128 a, __m128 b) { return _mm_xor_ps(a, b); }
  // ~a & b, as _mm_andnot_ps.
  [[gnu::always_inline]] static __m128 andnot(__m128 a, __m128 b) { return _mm_andnot_ps(a, b); }
  [[gnu::always_inline]] static __m128 lt(__m128 a, __m128 b) { return _mm_cmplt_ps(a, b); }
  [[gnu::always_inline]] static __m128 gt(__m128 a, __m128 b) { return _mm_cmpgt_ps(a, b); }
  [[gnu::always_inline]] static __m128 le(__m128 a, __m128 b) { return _mm_cmple_ps(a, b); }
  [[gnu::always_inline]] static __m128 ge(__m128 a, __m128 b) { return _mm_cmpge_ps(a, b); }
  [[gnu::always_inline]] static __m128 neq(__m128 a, __m128 b) { return _mm_cmpneq_ps(a, b); }
  [[gnu::always_inline]] static int movemask(__m128 a) { return _mm_movemask_ps(a); }
  [[gnu::always_inline]] static void store(float* p, __m128 a) { _mm_storeu_ps(p, a); }
};

// vertex[k]: the x, y and z of the triangles' vertex k (v0, v1, v2) in each lane's ray's permuted axes
// (kx, ky, kz of WatertightShear); org: each lane's ray's origin in those axes, shear: its (sx, sy, sz);
// `valid`: all ones in the lanes to test; [tmin, tmax] per lane. The lanes are four triangles against
// one ray (the binary leaves, the wide blocks) or one triangle against a packet's rays (the packet
// kernels). Bit i of the result: lane i is hit within its interval, its t, u and v (the float distance)
// in the arrays. A lane whose float edge functions or determinant cannot be trusted (an exact zero, or
// beyond float's range) is handed to `in_double(ax, ay, az, bx, by, bz, cx, cy, cz, tmin, tmax, t, u,
// v)` with its sheared vertices and interval, as the scalar test hands it to watertight_in_double.
template <class Ops, class InDouble>
[[gnu::always_inline]] inline unsigned watertight_in_lanes(const typename Ops::V (&vertex)[3][3],
                                                           const typename Ops::V (&org)[3],
                                                           const typename Ops::V (&shear)[3],
                                                           typename Ops::V valid, typename Ops::V lo,
                                                           typename Ops::V hi, float* t_out, float* u_out,
                                                           float* v_out, InDouble in_double) {
  using V = typename Ops::V;
  constexpr unsigned kLanes = sizeof(V) / sizeof(float);
  // Vertices relative to the origin, then sheared so that the ray is the +z axis through (0, 0).
  V px[3], py[3], pz[3];
  for (int k = 0; k < 3; ++k) {
    const V rx = Ops::sub(vertex[k][0], org[0]), ry = Ops::sub(vertex[k][1], org[1]),
            rz = Ops::sub(vertex[k][2], org[2]);
    px[k] = Ops::sub(rx, Ops::mul(shear[0], rz));
    py[k] = Ops::sub(ry, Ops::mul(shear[1], rz));
    pz[k] = Ops::mul(shear[2], rz);
  }
  const V ax = px[0], ay = py[0], az = pz[0], bx = px[1], by = py[1], bz = pz[1], cx = px[2], cy = py[2],
          cz = pz[2];
  // Scaled barycentrics: e0 weights v0 (edge v1-v2), e1 weights v1 (edge v2-v0), e2 weights v2.
  const V e0 = Ops::sub(Ops::mul(cx, by), Ops::mul(cy, bx));
  const V e1 = Ops::sub(Ops::mul(ax, cy), Ops::mul(ay, cx));
  const V e2 = Ops::sub(Ops::mul(bx, ay), Ops::mul(by, ax));

  const V zero = Ops::set1(0.0f);
  const V sign = Ops::set1(-0.0f);
  const V inf = Ops::set1(__builtin_inff());
  const auto finite = [&](V x) __attribute__((always_inline)) {
    return Ops::lt(Ops::andnot(sign, x), inf);
  };
  // watertight_float_ok, lane by lane: the lanes that fail it are finished in double.
  const V float_ok =
      Ops::and_(Ops::and_(Ops::and_(finite(e0), finite(e1)), finite(e2)),
                Ops::and_(Ops::and_(Ops::neq(e0, zero), Ops::neq(e1, zero)), Ops::neq(e2, zero)));
  unsigned doubtful = static_cast<unsigned>(Ops::movemask(Ops::andnot(float_ok, valid)));
  // Inside when no edge function has the wrong sign.
  const V some_negative = Ops::or_(Ops::or_(Ops::lt(e0, zero), Ops::lt(e1, zero)), Ops::lt(e2, zero));
  const V some_positive = Ops::or_(Ops::or_(Ops::gt(e0, zero), Ops::gt(e1, zero)), Ops::gt(e2, zero));
  V hit = Ops::andnot(Ops::and_(some_negative, some_positive), Ops::and_(valid, float_ok));
  const V det = Ops::add(Ops::add(e0, e1), e2);
  const V scaled_t = Ops::add(Ops::add(Ops::mul(e0, az), Ops::mul(e1, bz)), Ops::mul(e2, cz));
  // watertight_det_ok: det a normal float and the scaled distance finite, else finished in double.
  const V abs_det = Ops::andnot(sign, det);
  const V det_ok =
      Ops::and_(Ops::and_(Ops::ge(abs_det, Ops::set1(__FLT_MIN__)), Ops::lt(abs_det, inf)), finite(scaled_t));
  doubtful |= static_cast<unsigned>(Ops::movemask(Ops::andnot(det_ok, hit)));
  hit = Ops::and_(hit, det_ok);

  unsigned mask = 0;
  if (Ops::movemask(hit)) {
    // Scaled distance T = t * det, compared with [tmin, tmax] * |det| before dividing (section 3).
    const V signed_t = Ops::xor_(scaled_t, Ops::and_(det, sign));
    hit = Ops::and_(
        hit, Ops::and_(Ops::ge(signed_t, Ops::mul(lo, abs_det)), Ops::le(signed_t, Ops::mul(hi, abs_det))));
    if (Ops::movemask(hit)) {
      const V inv_det = Ops::div(Ops::set1(1.0f), det);
      const V t = Ops::mul(scaled_t, inv_det);
      // The product may round across tmin or tmax; the contract is on the returned t.
      hit = Ops::and_(hit, Ops::and_(Ops::ge(t, lo), Ops::le(t, hi)));
      Ops::store(t_out, t);
      Ops::store(u_out, Ops::mul(e1, inv_det));
      Ops::store(v_out, Ops::mul(e2, inv_det));
      mask = static_cast<unsigned>(Ops::movemask(hit));
    }
  }
  if (doubtful) [[unlikely]] {
    alignas(64) float lanes[11][kLanes];
    const V regs[11] = {ax, ay, az, bx, by, bz, cx, cy, cz, lo, hi};
    for (int k = 0; k < 11; ++k) Ops::store(lanes[k], regs[k]);
    for (unsigned m = doubtful; m != 0; m &= m - 1) {
      const auto i = static_cast<unsigned>(__builtin_ctz(m));
      if (in_double(lanes[0][i], lanes[1][i], lanes[2][i], lanes[3][i], lanes[4][i], lanes[5][i], lanes[6][i],
                    lanes[7][i], lanes[8][i], lanes[9][i], lanes[10][i], t_out[i], u_out[i], v_out[i]))
        mask |= 1u << i;
    }
  }
  return mask;
}

// Four triangles against one ray, its interval the same in every lane.
template <class InDouble>
[[gnu::always_inline]] inline unsigned watertight_lanes(const __m128 (&vertex)[3][3], const __m128 (&org)[3],
                                                        const __m128 (&shear)[3], __m128 valid, float tmin,
                                                        float tmax, float* t_out, float* u_out, float* v_out,
                                                        InDouble in_double) {
  return watertight_in_lanes<WatertightOps128>(vertex, org, shear, valid, _mm_set1_ps(tmin),
                                               _mm_set1_ps(tmax), t_out, u_out, v_out, in_double);
}
