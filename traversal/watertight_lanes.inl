// The float part of the watertight test (Woop, Benthin and Wald 2013; triangle_tests.h's
// WatertightTriangleTest) on four triangles at once, from their vertices to the hits: the same
// float operations in the same order as the scalar test, lane by lane, so the same decisions. Shared by
// WatertightLanes (triangle_lanes.h, the binary layouts' leaves) and the wide layouts' block test
// (wide_kernels.inl). It is included inside a namespace by each (wide_kernels.inl's once per instruction
// set), so it includes nothing and calls only intrinsics, builtins and the double-precision finish its
// caller passes (triangle_tests.h's watertight_in_double, or wide_kernels.inl's own copy, lane_in_double):
// the including file includes <immintrin.h> first.

// All ones where x is finite.
[[gnu::always_inline]] inline __m128 watertight_lanes_finite(__m128 x) {
  return _mm_cmplt_ps(_mm_andnot_ps(_mm_set1_ps(-0.0f), x), _mm_set1_ps(__builtin_inff()));
}

// vertex[k]: the x, y and z of the triangles' vertex k (v0, v1, v2) in the ray's permuted axes (kx, ky,
// kz of WatertightShear); org: the ray's origin in those axes, shear: (sx, sy, sz), each broadcast;
// `valid`: all ones in the lanes holding a triangle. Bit i of the result: lane i is hit within [tmin,
// tmax], its t, u and v (the float distance) in the arrays. A lane whose float edge functions or
// determinant cannot be trusted (an exact zero, or beyond float's range) is handed to
// `in_double(ax, ay, az, bx, by, bz, cx, cy, cz, tmin, tmax, t, u, v)` with its sheared vertices, as
// the scalar test hands it to watertight_in_double.
template <class InDouble>
[[gnu::always_inline]] inline unsigned watertight_lanes(const __m128 (&vertex)[3][3], const __m128 (&org)[3],
                                                        const __m128 (&shear)[3], __m128 valid, float tmin,
                                                        float tmax, float* t_out, float* u_out, float* v_out,
                                                        InDouble in_double) {
  // Vertices relative to the origin, then sheared so that the ray is the +z axis through (0, 0).
  __m128 px[3], py[3], pz[3];
  for (int k = 0; k < 3; ++k) {
    const __m128 rx = _mm_sub_ps(vertex[k][0], org[0]), ry = _mm_sub_ps(vertex[k][1], org[1]),
                 rz = _mm_sub_ps(vertex[k][2], org[2]);
    px[k] = _mm_sub_ps(rx, _mm_mul_ps(shear[0], rz));
    py[k] = _mm_sub_ps(ry, _mm_mul_ps(shear[1], rz));
    pz[k] = _mm_mul_ps(shear[2], rz);
  }
  const __m128 ax = px[0], ay = py[0], az = pz[0], bx = px[1], by = py[1], bz = pz[1], cx = px[2], cy = py[2],
               cz = pz[2];
  // Scaled barycentrics: e0 weights v0 (edge v1-v2), e1 weights v1 (edge v2-v0), e2 weights v2.
  const __m128 e0 = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
  const __m128 e1 = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
  const __m128 e2 = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));

  const __m128 zero = _mm_setzero_ps();
  const __m128 sign = _mm_set1_ps(-0.0f);
  const __m128 inf = _mm_set1_ps(__builtin_inff());
  // watertight_float_ok, lane by lane: the lanes that fail it are finished in double.
  const __m128 float_ok = _mm_and_ps(
      _mm_and_ps(_mm_and_ps(watertight_lanes_finite(e0), watertight_lanes_finite(e1)),
                 watertight_lanes_finite(e2)),
      _mm_and_ps(_mm_and_ps(_mm_cmpneq_ps(e0, zero), _mm_cmpneq_ps(e1, zero)), _mm_cmpneq_ps(e2, zero)));
  unsigned doubtful = static_cast<unsigned>(_mm_movemask_ps(_mm_andnot_ps(float_ok, valid)));
  // Inside when no edge function has the wrong sign.
  const __m128 some_negative =
      _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(e0, zero), _mm_cmplt_ps(e1, zero)), _mm_cmplt_ps(e2, zero));
  const __m128 some_positive =
      _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(e0, zero), _mm_cmpgt_ps(e1, zero)), _mm_cmpgt_ps(e2, zero));
  __m128 hit = _mm_andnot_ps(_mm_and_ps(some_negative, some_positive), _mm_and_ps(valid, float_ok));
  const __m128 det = _mm_add_ps(_mm_add_ps(e0, e1), e2);
  const __m128 scaled_t = _mm_add_ps(_mm_add_ps(_mm_mul_ps(e0, az), _mm_mul_ps(e1, bz)), _mm_mul_ps(e2, cz));
  // watertight_det_ok: det a normal float and the scaled distance finite, else finished in double.
  const __m128 abs_det = _mm_andnot_ps(sign, det);
  const __m128 det_ok =
      _mm_and_ps(_mm_and_ps(_mm_cmpge_ps(abs_det, _mm_set1_ps(__FLT_MIN__)), _mm_cmplt_ps(abs_det, inf)),
                 watertight_lanes_finite(scaled_t));
  doubtful |= static_cast<unsigned>(_mm_movemask_ps(_mm_andnot_ps(det_ok, hit)));
  hit = _mm_and_ps(hit, det_ok);

  unsigned mask = 0;
  if (_mm_movemask_ps(hit)) {
    // Scaled distance T = t * det, compared with [tmin, tmax] * |det| before dividing (section 3).
    const __m128 signed_t = _mm_xor_ps(scaled_t, _mm_and_ps(det, sign));
    const __m128 lo = _mm_set1_ps(tmin), hi = _mm_set1_ps(tmax);
    hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmpge_ps(signed_t, _mm_mul_ps(lo, abs_det)),
                                     _mm_cmple_ps(signed_t, _mm_mul_ps(hi, abs_det))));
    if (_mm_movemask_ps(hit)) {
      const __m128 inv_det = _mm_div_ps(_mm_set1_ps(1.0f), det);
      const __m128 t = _mm_mul_ps(scaled_t, inv_det);
      // The product may round across tmin or tmax; the contract is on the returned t.
      hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmpge_ps(t, lo), _mm_cmple_ps(t, hi)));
      _mm_storeu_ps(t_out, t);
      _mm_storeu_ps(u_out, _mm_mul_ps(e1, inv_det));
      _mm_storeu_ps(v_out, _mm_mul_ps(e2, inv_det));
      mask = static_cast<unsigned>(_mm_movemask_ps(hit));
    }
  }
  if (doubtful) [[unlikely]] {
    alignas(16) float lanes[9][4];
    const __m128 regs[9] = {ax, ay, az, bx, by, bz, cx, cy, cz};
    for (int k = 0; k < 9; ++k) _mm_store_ps(lanes[k], regs[k]);
    for (unsigned i = 0; i < 4; ++i)
      if (doubtful & (1u << i) &&
          in_double(lanes[0][i], lanes[1][i], lanes[2][i], lanes[3][i], lanes[4][i], lanes[5][i], lanes[6][i],
                    lanes[7][i], lanes[8][i], tmin, tmax, t_out[i], u_out[i], v_out[i]))
        mask |= 1u << i;
  }
  return mask;
}
