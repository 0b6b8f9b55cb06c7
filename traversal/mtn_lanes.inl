// The float part of MollerTrumboreNormalTest (triangle_tests.h) on several lanes: one ray against several
// triangles, or several rays against one triangle. Shared by MollerTrumboreNormalLanes (triangle_lanes.h,
// the binary layouts' leaves) and the wide layouts' block and packet tests (wide_kernels.inl,
// wide_packets.inl). It is included inside a namespace by each (wide_kernels.inl's once per instruction
// set), so it includes nothing and calls only intrinsics, through `Ops` (Ops128 below, or the wide
// kernels' Ops256 and Ops512): the including file includes <immintrin.h> first and compiles with FMA.
// Lanes the float test cannot take (outside mtn_triangle_in_range or mtn_ray_in_range) are the caller's
// to finish in double.

// A ray's origin, direction and interval in every lane (one ray against several triangles), or 8 or 16
// rays' in theirs (a packet against one triangle, wide_packets.inl). Templated on the Ops (below) rather
// than on their vector type, whose alignment attribute a template argument would drop.
template <class Ops>
struct RayLanes {
  using V = typename Ops::V;
  V org[3];
  V dir[3];
  V tmin, tmax;
};

// MollerTrumboreNormalTest on 4, 8 or 16 lanes (V = __m128, __m256 or __m512, the triangles' lanes loaded
// by `load(part, axis)`, part 0 v0, 1 e1, 2 e2, 3 the normal, the rays' in `r`): the scalar test's float
// operations lane for lane, with FMA instructions where it calls std::fma. The division
// waits for a lane to pass, so a ray that hits nothing in the block divides nothing; t is checked again
// once divided.
template <class V, class Ops, class Load>
[[gnu::always_inline]] inline uint32_t intersect_mtn_lanes(V valid, Load load, const RayLanes<Ops>& r,
                                                           float* t_out, float* u_out, float* v_out) {
  const V dx = r.dir[0], dy = r.dir[1], dz = r.dir[2];
  const V cx = Ops::sub(load(0, 0), r.org[0]), cy = Ops::sub(load(0, 1), r.org[1]),
          cz = Ops::sub(load(0, 2), r.org[2]);
  const V nx = load(3, 0), ny = load(3, 1), nz = load(3, 2);
  const V rx = Ops::fmsub(dy, cz, Ops::mul(dz, cy)), ry = Ops::fmsub(dz, cx, Ops::mul(dx, cz)),
          rz = Ops::fmsub(dx, cy, Ops::mul(dy, cx));
  const V det = Ops::fmadd(dx, nx, Ops::fmadd(dy, ny, Ops::mul(dz, nz)));
  const V sign_bit = Ops::set1(-0.0f);
  const V sign = Ops::and_(det, sign_bit);
  const V abs_det = Ops::xor_(det, sign);
  const V su = Ops::xor_(Ops::fmadd(load(2, 0), rx, Ops::fmadd(load(2, 1), ry, Ops::mul(load(2, 2), rz))),
                         Ops::xor_(sign, sign_bit));
  const V sv =
      Ops::xor_(Ops::fmadd(load(1, 0), rx, Ops::fmadd(load(1, 1), ry, Ops::mul(load(1, 2), rz))), sign);
  const V zero = Ops::set1(0.0f);
  V hit = Ops::and_(valid, Ops::and_(Ops::ge(abs_det, Ops::set1(__FLT_MIN__)),
                                     Ops::and_(Ops::ge(su, zero), Ops::ge(sv, zero))));
  hit = Ops::and_(hit, Ops::le(Ops::add(su, sv), abs_det));
  const V st = Ops::xor_(Ops::fmadd(cx, nx, Ops::fmadd(cy, ny, Ops::mul(cz, nz))), sign);
  hit = Ops::and_(hit,
                  Ops::and_(Ops::ge(st, Ops::mul(abs_det, r.tmin)), Ops::le(st, Ops::mul(abs_det, r.tmax))));
  if (!Ops::movemask(hit)) return 0;
  const V inv_det = Ops::div(Ops::set1(1.0f), abs_det);
  const V t = Ops::mul(st, inv_det);
  hit = Ops::and_(hit, Ops::and_(Ops::ge(t, r.tmin), Ops::le(t, r.tmax)));
  Ops::store(t_out, t);
  Ops::store(u_out, Ops::mul(su, inv_det));
  Ops::store(v_out, Ops::mul(sv, inv_det));
  return static_cast<uint32_t>(Ops::movemask(hit));
}

struct Ops128 {
  using V = __m128;
  [[gnu::always_inline]] static __m128 set1(float x) { return _mm_set1_ps(x); }
  [[gnu::always_inline]] static __m128 add(__m128 a, __m128 b) { return _mm_add_ps(a, b); }
  [[gnu::always_inline]] static __m128 sub(__m128 a, __m128 b) { return _mm_sub_ps(a, b); }
  [[gnu::always_inline]] static __m128 mul(__m128 a, __m128 b) { return _mm_mul_ps(a, b); }
  [[gnu::always_inline]] static __m128 div(__m128 a, __m128 b) { return _mm_div_ps(a, b); }
  [[gnu::always_inline]] static __m128 fmadd(__m128 a, __m128 b, __m128 c) { return _mm_fmadd_ps(a, b, c); }
  [[gnu::always_inline]] static __m128 fmsub(__m128 a, __m128 b, __m128 c) { return _mm_fmsub_ps(a, b, c); }
  [[gnu::always_inline]] static __m128 and_(__m128 a, __m128 b) { return _mm_and_ps(a, b); }
  [[gnu::always_inline]] static __m128 xor_(__m128 a, __m128 b) { return _mm_xor_ps(a, b); }
  [[gnu::always_inline]] static __m128 ge(__m128 a, __m128 b) { return _mm_cmp_ps(a, b, _CMP_GE_OQ); }
  [[gnu::always_inline]] static __m128 le(__m128 a, __m128 b) { return _mm_cmp_ps(a, b, _CMP_LE_OQ); }
  [[gnu::always_inline]] static int movemask(__m128 a) { return _mm_movemask_ps(a); }
  [[gnu::always_inline]] static void store(float* p, __m128 a) { _mm_storeu_ps(p, a); }
};
