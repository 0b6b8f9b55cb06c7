#pragma once
// The triangle tests of triangle_tests.h on up to four triangles of a leaf at once, in the four lanes of
// an SSE register, for the binary walks (bvh2_traversal.h's test_leaf). Each lane computes its scalar
// test's float operations in the same order, so it reaches the same decisions and the same t, u and v,
// bit for bit; a leaf's triangles are then decided by one branch per four instead of a chain of
// data-dependent branches per triangle. The triangles are read as stored, one after the other
// (bvh2_packed) or through references (bvh2), and transposed into lanes on the way in.

#include <bit>
#include <cassert>
#include <cstdint>
#include <type_traits>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "core/ray.h"
#include "core/triangle.h"
#include "traversal/triangle_tests.h"

namespace sahbench {

#if defined(__SSE2__)
namespace detail {
#include "traversal/watertight_lanes.inl"
#if defined(__FMA__)
#include "traversal/mtn_lanes.inl"
#endif

// The vertices of triangles at(0), ..., at(n - 1) (n in [1, 4]) in the lanes of SSE registers,
// vertex[k][axis]; lanes past n repeat the last triangle, and `valid` is all ones in the first n lanes.
struct FourTriangles {
  __m128 vertex[3][3];
  __m128 valid;
};

template <class TriangleAt>
[[gnu::always_inline]] inline FourTriangles four_triangles(TriangleAt at, uint32_t n) {
  assert(n >= 1 && n <= 4);
  static_assert(sizeof(Triangle) == 9 * sizeof(float), "a Triangle is its three vertices' nine floats");
  // Rows of each triangle's nine floats: (v0 x y z, v1 x), (v1 y z, v2 x y), v2 z.
  __m128 r0[4], r1[4], r2[4];
  for (uint32_t i = 0; i < 4; ++i) {
    const float* p = reinterpret_cast<const float*>(&at(i < n ? i : n - 1));
    r0[i] = _mm_loadu_ps(p);
    r1[i] = _mm_loadu_ps(p + 4);
    r2[i] = _mm_load_ss(p + 8);
  }
  _MM_TRANSPOSE4_PS(r0[0], r0[1], r0[2], r0[3]);
  _MM_TRANSPOSE4_PS(r1[0], r1[1], r1[2], r1[3]);
  const __m128 v2z = _mm_movelh_ps(_mm_unpacklo_ps(r2[0], r2[1]), _mm_unpacklo_ps(r2[2], r2[3]));
  return {{{r0[0], r0[1], r0[2]}, {r0[3], r1[0], r1[1]}, {r1[2], r1[3], v2z}},
          _mm_castsi128_ps(_mm_cmplt_epi32(_mm_setr_epi32(0, 1, 2, 3), _mm_set1_epi32(static_cast<int>(n))))};
}

// The lanes' x, y and z of a - b.
[[gnu::always_inline]] inline void lanes_sub(const __m128 (&a)[3], const __m128 (&b)[3], __m128 (&out)[3]) {
  for (int axis = 0; axis < 3; ++axis) out[axis] = _mm_sub_ps(a[axis], b[axis]);
}

// cross(a, b) of core/vec3.h, lane by lane: the same products and differences, none fused.
[[gnu::always_inline]] inline void lanes_cross(const __m128 (&a)[3], const __m128 (&b)[3], __m128 (&out)[3]) {
  out[0] = _mm_sub_ps(_mm_mul_ps(a[1], b[2]), _mm_mul_ps(a[2], b[1]));
  out[1] = _mm_sub_ps(_mm_mul_ps(a[2], b[0]), _mm_mul_ps(a[0], b[2]));
  out[2] = _mm_sub_ps(_mm_mul_ps(a[0], b[1]), _mm_mul_ps(a[1], b[0]));
}

// dot(a, b) of core/vec3.h, lane by lane: (x + y) + z, none fused.
[[gnu::always_inline]] inline __m128 lanes_dot(const __m128 (&a)[3], const __m128 (&b)[3]) {
  return _mm_add_ps(_mm_add_ps(_mm_mul_ps(a[0], b[0]), _mm_mul_ps(a[1], b[1])), _mm_mul_ps(a[2], b[2]));
}

[[gnu::always_inline]] inline void lanes_broadcast(Vec3 a, __m128 (&out)[3]) {
  out[0] = _mm_set1_ps(a.x);
  out[1] = _mm_set1_ps(a.y);
  out[2] = _mm_set1_ps(a.z);
}

}  // namespace detail

/// What the tests on four lanes share: the scalar test `Scalar` they compute lane by lane, set up once per
/// ray (one(): the same test on one triangle), and the two ways a leaf's triangles are reached (`Lanes`
/// implements `intersect_at<kRefine>(at, n, tmin, tmax, t, u, v)` with at(i) the i-th triangle).
template <class Lanes, class Scalar>
class FourLaneTest {
 public:
  explicit FourLaneTest(const Ray& ray) : one_(ray) {}

  const Scalar& one() const { return one_; }

  /// Bit i set: tris[i] (i < n, n in [1, 4]) is hit within [tmin, tmax], at t[i] with u[i], v[i];
  /// kRefine: t[i] refined as the watertight test's intersect refines it (the other tests have no
  /// refinement and ignore it).
  template <bool kRefine>
  unsigned intersect(const Triangle* tris, uint32_t n, float tmin, float tmax, float* t, float* u,
                     float* v) const {
    // The pointers by value: a lambda capturing by reference cost the binary walks 4 to 11%.
    return lanes().template intersect_at<kRefine>([tris](uint32_t i) -> const Triangle& { return tris[i]; },
                                                  n, tmin, tmax, t, u, v);
  }

  /// The same on the triangles triangles[refs[i]], i < n.
  template <bool kRefine>
  unsigned intersect(const Triangle* triangles, const uint32_t* refs, uint32_t n, float tmin, float tmax,
                     float* t, float* u, float* v) const {
    return lanes().template intersect_at<kRefine>(
        [triangles, refs](uint32_t i) -> const Triangle& { return triangles[refs[i]]; }, n, tmin, tmax, t, u,
        v);
  }

 private:
  const Lanes& lanes() const { return static_cast<const Lanes&>(*this); }

  Scalar one_;
};

/// WatertightTriangleTest on four lanes, by the code of the wide layouts' block test
/// (watertight_lanes.inl): a lane whose float edge functions or determinant cannot be trusted is
/// finished in double by the scalar test's code, and a hit's distance refined by it.
class WatertightLanes : public FourLaneTest<WatertightLanes, WatertightTriangleTest> {
 public:
  using FourLaneTest::FourLaneTest;

 private:
  friend class FourLaneTest<WatertightLanes, WatertightTriangleTest>;

  template <bool kRefine, class TriangleAt>
  unsigned intersect_at(TriangleAt at, uint32_t n, float tmin, float tmax, float* t, float* u,
                        float* v) const {
    const detail::FourTriangles four = detail::four_triangles(at, n);
    const WatertightTriangleTest& one = this->one();
    const auto [kx, ky, kz, sx, sy, sz] = one.shear();
    const __m128 permuted[3][3] = {{four.vertex[0][kx], four.vertex[0][ky], four.vertex[0][kz]},
                                   {four.vertex[1][kx], four.vertex[1][ky], four.vertex[1][kz]},
                                   {four.vertex[2][kx], four.vertex[2][ky], four.vertex[2][kz]}};
    const detail::Components o = detail::components(one.org());
    const __m128 org[3] = {_mm_set1_ps(o[kx]), _mm_set1_ps(o[ky]), _mm_set1_ps(o[kz])};
    const __m128 shear[3] = {_mm_set1_ps(sx), _mm_set1_ps(sy), _mm_set1_ps(sz)};
    const auto in_double = [](float ax, float ay, float az, float bx, float by, float bz, float cx, float cy,
                              float cz, float lo, float hi, float& t_out, float& u_out, float& v_out) {
      return watertight_in_double(ax, ay, az, bx, by, bz, cx, cy, cz, lo, hi, t_out, u_out, v_out);
    };
    unsigned mask =
        detail::watertight_lanes(permuted, org, shear, four.valid, tmin, tmax, t, u, v, in_double);
    if constexpr (kRefine)
      for (unsigned m = mask; m != 0; m &= m - 1) {
        const auto i = static_cast<unsigned>(std::countr_zero(m));
        const Triangle& tri = at(i);
        if (!refine_watertight_t(tri.v0, tri.v1, tri.v2, one.org(), one.dir(), tmin, tmax, t[i]))
          mask &= ~(1u << i);
      }
    return mask;
  }
};

/// MollerTrumboreTest (`Scalar`: it or MollerTrumboreNoEpsilonTest) on four lanes: Cramer's rule with
/// every operation of the scalar test, in its order; the lanes compute what the scalar test's early
/// outs skip, and mask it off.
template <class Scalar>
class MollerTrumboreLanes : public FourLaneTest<MollerTrumboreLanes<Scalar>, Scalar> {
 public:
  using FourLaneTest<MollerTrumboreLanes<Scalar>, Scalar>::FourLaneTest;

 private:
  friend class FourLaneTest<MollerTrumboreLanes<Scalar>, Scalar>;

  template <bool, class TriangleAt>
  unsigned intersect_at(TriangleAt at, uint32_t n, float tmin, float tmax, float* t_out, float* u_out,
                        float* v_out) const {
    const detail::FourTriangles four = detail::four_triangles(at, n);
    const Scalar& one = this->one();
    __m128 dir[3], org[3], edge1[3], edge2[3], s[3], p[3], q[3];
    detail::lanes_broadcast(one.dir(), dir);
    detail::lanes_broadcast(one.org(), org);
    detail::lanes_sub(four.vertex[1], four.vertex[0], edge1);
    detail::lanes_sub(four.vertex[2], four.vertex[0], edge2);
    detail::lanes_cross(dir, edge2, p);
    const __m128 det = detail::lanes_dot(edge1, p);
    // |det| > epsilon, ordered: a NaN determinant is a miss.
    const __m128 abs_det = _mm_andnot_ps(_mm_set1_ps(-0.0f), det);
    __m128 hit = _mm_and_ps(four.valid, _mm_cmpgt_ps(abs_det, _mm_set1_ps(one.det_epsilon())));
    if (_mm_movemask_ps(hit) == 0) return 0;
    const __m128 inv_det = _mm_div_ps(_mm_set1_ps(1.0f), det);
    detail::lanes_sub(org, four.vertex[0], s);
    const __m128 u = _mm_mul_ps(detail::lanes_dot(s, p), inv_det);
    const __m128 zero = _mm_setzero_ps(), unit = _mm_set1_ps(1.0f);
    hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmpge_ps(u, zero), _mm_cmple_ps(u, unit)));
    detail::lanes_cross(s, edge1, q);
    const __m128 v = _mm_mul_ps(detail::lanes_dot(dir, q), inv_det);
    hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmpge_ps(v, zero), _mm_cmple_ps(_mm_add_ps(u, v), unit)));
    const __m128 t = _mm_mul_ps(detail::lanes_dot(edge2, q), inv_det);
    hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmpge_ps(t, _mm_set1_ps(tmin)), _mm_cmple_ps(t, _mm_set1_ps(tmax))));
    _mm_store_ps(t_out, t);
    _mm_store_ps(u_out, u);
    _mm_store_ps(v_out, v);
    return static_cast<unsigned>(_mm_movemask_ps(hit));
  }
};

// Only where the compiler may emit FMA instructions, so LeafTestOf<MollerTrumboreNormalTest> depends on
// the target: the binary walks use it compiled for the build's own target, and the binary packet kernels
// (pair_packets.inl, in the AVX2 and AVX-512 files) inline it into their flattened loops.
#if defined(__FMA__)
/// MollerTrumboreNormalTest on four lanes, by the code of the wide layouts' block test (mtn_lanes.inl),
/// with the scalar test's fused multiply-adds as FMA instructions (so only where the CPU has them); a
/// lane outside the float test's range (mtn_triangle_in_range), or every lane of a ray outside it, is
/// decided in double by the scalar test's mtn_in_double.
class MollerTrumboreNormalLanes : public FourLaneTest<MollerTrumboreNormalLanes, MollerTrumboreNormalTest> {
 public:
  using FourLaneTest::FourLaneTest;

 private:
  friend class FourLaneTest<MollerTrumboreNormalLanes, MollerTrumboreNormalTest>;

  // Lanes of `four.valid` whose triangle is outside the float test's range: mtn_triangle_in_range
  // lane by lane. A NaN component compares false here (out of range) where the scalar check skips it;
  // either way its determinant is NaN and the lane misses.
  [[gnu::always_inline]] static unsigned out_of_range(const detail::FourTriangles& four,
                                                      const __m128 (&edge1)[3], const __m128 (&edge2)[3],
                                                      const __m128 (&normal)[3]) {
    const __m128 sign = _mm_set1_ps(-0.0f), largest = _mm_set1_ps(kMtnMaxMagnitude);
    __m128 in_range = four.valid, normal_large = _mm_setzero_ps();
    for (int axis = 0; axis < 3; ++axis) {
      for (__m128 x : {four.vertex[0][axis], edge1[axis], edge2[axis], normal[axis]})
        in_range = _mm_and_ps(in_range, _mm_cmple_ps(_mm_andnot_ps(sign, x), largest));
      normal_large = _mm_or_ps(normal_large,
                               _mm_cmpge_ps(_mm_andnot_ps(sign, normal[axis]), _mm_set1_ps(kMtnMinNormal)));
    }
    return static_cast<unsigned>(
        _mm_movemask_ps(_mm_andnot_ps(_mm_and_ps(in_range, normal_large), four.valid)));
  }

  template <bool, class TriangleAt>
  unsigned intersect_at(TriangleAt at, uint32_t n, float tmin, float tmax, float* t_out, float* u_out,
                        float* v_out) const {
    const detail::FourTriangles four = detail::four_triangles(at, n);
    const MollerTrumboreNormalTest& one = this->one();
    __m128 d[3], org[3], edge1[3], edge2[3], normal[3];
    detail::lanes_broadcast(one.dir(), d);
    detail::lanes_broadcast(one.org(), org);
    detail::lanes_sub(four.vertex[1], four.vertex[0], edge1);
    detail::lanes_sub(four.vertex[2], four.vertex[0], edge2);
    detail::lanes_cross(edge1, edge2, normal);  // stored_normal
    const unsigned in_double = one.ray_in_range() ? out_of_range(four, edge1, edge2, normal)
                                                  : static_cast<unsigned>(_mm_movemask_ps(four.valid));
    const auto load = [&](int part, int axis) __attribute__((always_inline)) {
      return part == 0   ? four.vertex[0][axis]
             : part == 1 ? edge1[axis]
             : part == 2 ? edge2[axis]
                         : normal[axis];
    };
    const detail::RayLanes<detail::Ops128> ray{
        {org[0], org[1], org[2]}, {d[0], d[1], d[2]}, _mm_set1_ps(tmin), _mm_set1_ps(tmax)};
    unsigned mask =
        detail::intersect_mtn_lanes<__m128, detail::Ops128>(four.valid, load, ray, t_out, u_out, v_out) &
        ~in_double;
    for (unsigned m = in_double; m != 0; m &= m - 1) [[unlikely]] {
        const auto i = static_cast<unsigned>(std::countr_zero(m));
        const Triangle& tri = at(i);
        if (mtn_in_double(tri.v0, tri.v1 - tri.v0, tri.v2 - tri.v0, one.org(), one.dir(), tmin, tmax,
                          t_out[i], u_out[i], v_out[i]))
          mask |= 1u << i;
      }
    return mask;
  }
};
#endif

namespace detail {
// The four-lane form of each triangle test, where there is one: the test itself where not.
template <class TriangleTest>
struct LanesOf {
  using type = TriangleTest;
};
template <>
struct LanesOf<WatertightTriangleTest> {
  using type = WatertightLanes;
};
template <>
struct LanesOf<MollerTrumboreTest> {
  using type = MollerTrumboreLanes<MollerTrumboreTest>;
};
template <>
struct LanesOf<MollerTrumboreNoEpsilonTest> {
  using type = MollerTrumboreLanes<MollerTrumboreNoEpsilonTest>;
};
#if defined(__FMA__)
template <>
struct LanesOf<MollerTrumboreNormalTest> {
  using type = MollerTrumboreNormalLanes;
};
#endif
}  // namespace detail

/// The test a binary walk runs on a leaf for `TriangleTest`: its four-lane form where the CPU has one.
template <class TriangleTest>
using LeafTestOf = typename detail::LanesOf<TriangleTest>::type;
#else
template <class TriangleTest>
using LeafTestOf = TriangleTest;
#endif

/// Whether the binary walks test a leaf's triangles four at a time.
template <class TriangleTest>
inline constexpr bool kTestsInLanes = !std::is_same_v<LeafTestOf<TriangleTest>, TriangleTest>;

}  // namespace sahbench
