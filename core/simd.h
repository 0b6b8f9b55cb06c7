#pragma once
// Small fixed-width vectors for the builders' per-primitive loops: a Vec4f holds a point or a box corner
// (x, y, z in lanes 0 to 2, lane 3 unused) or one value per axis, so that one instruction serves all
// three axes; a Vec8f holds both corners of a box.
//
// SSE4.1 (and AVX for Vec8f) where the compiler targets it, as the project's -march=native does on
// x86-64; elsewhere a lane-by-lane implementation of the same operations. Both give bit-identical
// results: every lane operation is one IEEE operation, min/max and truncation follow the SSE rules
// exactly, and the project compiles with -ffp-contract=off, so no multiply and add are fused on either
// path. Masks have all bits set in the lanes where they are true, as SSE comparisons give.

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#if defined(__SSE4_1__)
#include <immintrin.h>
#endif

namespace sahbench::simd {

#if defined(__SSE4_1__)

// Trivially constructible wrappers, so that arrays of them cost nothing until written.
struct Vec4f {
  __m128 v;
};
struct Vec4i {
  __m128i v;
};

/// Four floats from any address (no alignment needed).
inline Vec4f load4(const void* p) {
  return {_mm_loadu_ps(static_cast<const float*>(p))};
}
inline void store4(float* p, Vec4f a) {
  _mm_storeu_ps(p, a.v);
}
inline Vec4i load4i(const uint32_t* p) {
  return {_mm_loadu_si128(reinterpret_cast<const __m128i*>(p))};
}
inline void store4i(uint32_t* p, Vec4i a) {
  _mm_storeu_si128(reinterpret_cast<__m128i*>(p), a.v);
}
inline Vec4f make4(float x, float y, float z, float w) {
  return {_mm_setr_ps(x, y, z, w)};
}
inline Vec4f splat(float s) {
  return {_mm_set1_ps(s)};
}
inline Vec4i splat(uint32_t s) {
  return {_mm_set1_epi32(static_cast<int>(s))};
}

inline Vec4f operator+(Vec4f a, Vec4f b) {
  return {_mm_add_ps(a.v, b.v)};
}
inline Vec4f operator-(Vec4f a, Vec4f b) {
  return {_mm_sub_ps(a.v, b.v)};
}
inline Vec4f operator*(Vec4f a, Vec4f b) {
  return {_mm_mul_ps(a.v, b.v)};
}
inline Vec4f operator/(Vec4f a, Vec4f b) {
  return {_mm_div_ps(a.v, b.v)};
}
/// Flips the sign bit, exactly as unary minus does.
inline Vec4f operator-(Vec4f a) {
  return {_mm_xor_ps(a.v, _mm_set1_ps(-0.0f))};
}
inline Vec4i operator+(Vec4i a, Vec4i b) {
  return {_mm_add_epi32(a.v, b.v)};
}

/// a < b ? a : b per lane (minps: b where either is NaN or both are zero).
inline Vec4f min(Vec4f a, Vec4f b) {
  return {_mm_min_ps(a.v, b.v)};
}
/// a > b ? a : b per lane (maxps: b where either is NaN or both are zero).
inline Vec4f max(Vec4f a, Vec4f b) {
  return {_mm_max_ps(a.v, b.v)};
}

inline Vec4f less(Vec4f a, Vec4f b) {
  return {_mm_cmplt_ps(a.v, b.v)};
}
inline Vec4f greater(Vec4f a, Vec4f b) {
  return {_mm_cmpgt_ps(a.v, b.v)};
}
/// Comparisons of int32 lanes, as masks for the float operations.
inline Vec4f greater(Vec4i a, Vec4i b) {
  return {_mm_castsi128_ps(_mm_cmpgt_epi32(a.v, b.v))};
}
inline Vec4f equal(Vec4i a, Vec4i b) {
  return {_mm_castsi128_ps(_mm_cmpeq_epi32(a.v, b.v))};
}
/// Bit i is set where a[i] < b[i], the lanes read as int32.
inline int less_mask(Vec4i a, Vec4i b) {
  return _mm_movemask_ps(_mm_castsi128_ps(_mm_cmplt_epi32(a.v, b.v)));
}
/// Bit i is set where lane i of a comparison mask is set.
inline int mask_bits(Vec4f mask) {
  return _mm_movemask_ps(mask.v);
}
inline Vec4f operator|(Vec4f a, Vec4f b) {
  return {_mm_or_ps(a.v, b.v)};
}
inline Vec4f operator&(Vec4f a, Vec4f b) {
  return {_mm_and_ps(a.v, b.v)};
}
/// 0 where mask is set, a elsewhere.
inline Vec4f and_not(Vec4f mask, Vec4f a) {
  return {_mm_andnot_ps(mask.v, a.v)};
}
/// b where mask is set, a elsewhere.
inline Vec4f select(Vec4f mask, Vec4f a, Vec4f b) {
  return {_mm_blendv_ps(a.v, b.v, mask.v)};
}
inline Vec4i select(Vec4f mask, Vec4i a, Vec4i b) {
  return {_mm_castps_si128(_mm_blendv_ps(_mm_castsi128_ps(a.v), _mm_castsi128_ps(b.v), mask.v))};
}

/// Lanes read as int32, converted as static_cast<float> does (rounded to nearest).
inline Vec4f to_float(Vec4i a) {
  return {_mm_cvtepi32_ps(a.v)};
}
/// Logical shift right of each lane by `n` bits (n < 32).
inline Vec4i shift_right(Vec4i a, uint32_t n) {
  return {_mm_srl_epi32(a.v, _mm_cvtsi32_si128(static_cast<int>(n)))};
}
/// Truncation toward zero; NaN and values outside the int32 range give INT32_MIN (cvttps2dq).
inline Vec4i truncate(Vec4f a) {
  return {_mm_cvttps_epi32(a.v)};
}
/// Per-lane minimum and maximum, the lanes read as uint32.
inline Vec4i min_u32(Vec4i a, Vec4i b) {
  return {_mm_min_epu32(a.v, b.v)};
}
inline Vec4i max_u32(Vec4i a, Vec4i b) {
  return {_mm_max_epu32(a.v, b.v)};
}
template <int I>
uint32_t lane(Vec4i a) {
  return static_cast<uint32_t>(_mm_extract_epi32(a.v, I));
}

/// Lanes 0 to 2 of x, y and z from the x, y and z lanes of three vectors: x = (a.x, b.x, c.x, ...), and
/// so on; lane 3 of the results is unspecified.
inline void transpose3(Vec4f a, Vec4f b, Vec4f c, Vec4f& x, Vec4f& y, Vec4f& z) {
  const __m128 ab_xy = _mm_unpacklo_ps(a.v, b.v);  // a.x b.x a.y b.y
  const __m128 ab_zw = _mm_unpackhi_ps(a.v, b.v);  // a.z b.z a.w b.w
  x = {_mm_movelh_ps(ab_xy, c.v)};
  y = {_mm_shuffle_ps(ab_xy, c.v, _MM_SHUFFLE(1, 1, 3, 2))};
  z = {_mm_shuffle_ps(ab_zw, c.v, _MM_SHUFFLE(2, 2, 1, 0))};
}

#else

struct Vec4f {
  float v[4];
};
struct Vec4i {
  uint32_t v[4];
};

template <class F>
Vec4f per_lane(F f) {
  return {{f(0), f(1), f(2), f(3)}};
}
template <class F>
Vec4i per_lane_i(F f) {
  return {{f(0), f(1), f(2), f(3)}};
}
inline uint32_t bits(float f) {
  return std::bit_cast<uint32_t>(f);
}
inline float mask_lane(bool set) {
  return std::bit_cast<float>(set ? ~0u : 0u);
}

inline Vec4f load4(const void* p) {
  Vec4f r;
  std::memcpy(r.v, p, sizeof r.v);
  return r;
}
inline void store4(float* p, Vec4f a) {
  std::memcpy(p, a.v, sizeof a.v);
}
inline Vec4i load4i(const uint32_t* p) {
  Vec4i r;
  std::memcpy(r.v, p, sizeof r.v);
  return r;
}
inline void store4i(uint32_t* p, Vec4i a) {
  std::memcpy(p, a.v, sizeof a.v);
}
inline Vec4f make4(float x, float y, float z, float w) {
  return {{x, y, z, w}};
}
inline Vec4f splat(float s) {
  return {{s, s, s, s}};
}
inline Vec4i splat(uint32_t s) {
  return {{s, s, s, s}};
}

inline Vec4f operator+(Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return a.v[i] + b.v[i]; });
}
inline Vec4f operator-(Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return a.v[i] - b.v[i]; });
}
inline Vec4f operator*(Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return a.v[i] * b.v[i]; });
}
inline Vec4f operator/(Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return a.v[i] / b.v[i]; });
}
inline Vec4f operator-(Vec4f a) {
  return per_lane([&](int i) { return -a.v[i]; });
}
inline Vec4i operator+(Vec4i a, Vec4i b) {
  return per_lane_i([&](int i) { return a.v[i] + b.v[i]; });
}

inline Vec4f min(Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return a.v[i] < b.v[i] ? a.v[i] : b.v[i]; });
}
inline Vec4f max(Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return a.v[i] > b.v[i] ? a.v[i] : b.v[i]; });
}

inline Vec4f less(Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return mask_lane(a.v[i] < b.v[i]); });
}
inline Vec4f greater(Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return mask_lane(a.v[i] > b.v[i]); });
}
inline Vec4f greater(Vec4i a, Vec4i b) {
  return per_lane(
      [&](int i) { return mask_lane(static_cast<int32_t>(a.v[i]) > static_cast<int32_t>(b.v[i])); });
}
inline Vec4f equal(Vec4i a, Vec4i b) {
  return per_lane([&](int i) { return mask_lane(a.v[i] == b.v[i]); });
}
inline int less_mask(Vec4i a, Vec4i b) {
  int mask = 0;
  for (int i = 0; i < 4; ++i) mask |= (static_cast<int32_t>(a.v[i]) < static_cast<int32_t>(b.v[i])) << i;
  return mask;
}
inline int mask_bits(Vec4f mask) {
  int bits_set = 0;
  for (int i = 0; i < 4; ++i) bits_set |= static_cast<int>(bits(mask.v[i]) >> 31) << i;
  return bits_set;
}
inline Vec4f operator|(Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return std::bit_cast<float>(bits(a.v[i]) | bits(b.v[i])); });
}
inline Vec4f operator&(Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return std::bit_cast<float>(bits(a.v[i]) & bits(b.v[i])); });
}
inline Vec4f and_not(Vec4f mask, Vec4f a) {
  return per_lane([&](int i) { return std::bit_cast<float>(~bits(mask.v[i]) & bits(a.v[i])); });
}
inline Vec4f select(Vec4f mask, Vec4f a, Vec4f b) {
  return per_lane([&](int i) { return bits(mask.v[i]) ? b.v[i] : a.v[i]; });
}
inline Vec4i select(Vec4f mask, Vec4i a, Vec4i b) {
  return per_lane_i([&](int i) { return bits(mask.v[i]) ? b.v[i] : a.v[i]; });
}

inline Vec4f to_float(Vec4i a) {
  return per_lane([&](int i) { return static_cast<float>(static_cast<int32_t>(a.v[i])); });
}
inline Vec4i shift_right(Vec4i a, uint32_t n) {
  return per_lane_i([&](int i) { return a.v[i] >> n; });
}
inline Vec4i truncate(Vec4f a) {
  // The int32 range as floats: -2^31 is exact, and 2^31 is the first value past the end.
  constexpr float kLow = -2147483648.0f, kEnd = 2147483648.0f;
  constexpr auto kInvalid = static_cast<uint32_t>(std::numeric_limits<int32_t>::min());
  return per_lane_i([&](int i) {
    return a.v[i] >= kLow && a.v[i] < kEnd ? static_cast<uint32_t>(static_cast<int32_t>(a.v[i])) : kInvalid;
  });
}
inline Vec4i min_u32(Vec4i a, Vec4i b) {
  return per_lane_i([&](int i) { return std::min(a.v[i], b.v[i]); });
}
inline Vec4i max_u32(Vec4i a, Vec4i b) {
  return per_lane_i([&](int i) { return std::max(a.v[i], b.v[i]); });
}
template <int I>
uint32_t lane(Vec4i a) {
  return a.v[I];
}

inline void transpose3(Vec4f a, Vec4f b, Vec4f c, Vec4f& x, Vec4f& y, Vec4f& z) {
  x = {{a.v[0], b.v[0], c.v[0], 0.0f}};
  y = {{a.v[1], b.v[1], c.v[1], 0.0f}};
  z = {{a.v[2], b.v[2], c.v[2], 0.0f}};
}

#endif

// Eight float lanes in two halves: one 256-bit register with AVX, two Vec4f otherwise.
#if defined(__AVX__) && defined(__SSE4_1__)
struct Vec8f {
  __m256 v;
};
inline Vec8f join(Vec4f low, Vec4f high) {
  return {_mm256_set_m128(high.v, low.v)};
}
inline Vec4f low_half(Vec8f a) {
  return {_mm256_castps256_ps128(a.v)};
}
inline Vec4f high_half(Vec8f a) {
  return {_mm256_extractf128_ps(a.v, 1)};
}
inline Vec8f splat8(float s) {
  return {_mm256_set1_ps(s)};
}
inline Vec8f min(Vec8f a, Vec8f b) {
  return {_mm256_min_ps(a.v, b.v)};
}
#else
struct Vec8f {
  Vec4f low, high;
};
inline Vec8f join(Vec4f low, Vec4f high) {
  return {low, high};
}
inline Vec4f low_half(Vec8f a) {
  return a.low;
}
inline Vec4f high_half(Vec8f a) {
  return a.high;
}
inline Vec8f splat8(float s) {
  return {splat(s), splat(s)};
}
inline Vec8f min(Vec8f a, Vec8f b) {
  return {min(a.low, b.low), min(a.high, b.high)};
}
#endif

// Four double lanes: one 256-bit register with AVX, lane by lane otherwise. Used where float rounding
// is too coarse (points computed while clipping triangles); to_float rounds each lane to nearest, as
// static_cast<float> does, on both paths.
#if defined(__AVX__) && defined(__SSE4_1__)
struct Vec4d {
  __m256d v;
};
inline Vec4d make4d(double x, double y, double z, double w) {
  return {_mm256_setr_pd(x, y, z, w)};
}
inline Vec4d splat4d(double s) {
  return {_mm256_set1_pd(s)};
}
inline Vec4d operator+(Vec4d a, Vec4d b) {
  return {_mm256_add_pd(a.v, b.v)};
}
inline Vec4d operator-(Vec4d a, Vec4d b) {
  return {_mm256_sub_pd(a.v, b.v)};
}
inline Vec4d operator*(Vec4d a, Vec4d b) {
  return {_mm256_mul_pd(a.v, b.v)};
}
/// Clears the sign bit, exactly as std::fabs does.
inline Vec4d abs(Vec4d a) {
  return {_mm256_andnot_pd(_mm256_set1_pd(-0.0), a.v)};
}
/// a < b ? a : b and a > b ? a : b per lane, as the Vec4f versions.
inline Vec4d min(Vec4d a, Vec4d b) {
  return {_mm256_min_pd(a.v, b.v)};
}
inline Vec4d max(Vec4d a, Vec4d b) {
  return {_mm256_max_pd(a.v, b.v)};
}
inline Vec4f to_float(Vec4d a) {
  return {_mm256_cvtpd_ps(a.v)};
}
#else
struct Vec4d {
  double v[4];
};
inline Vec4d make4d(double x, double y, double z, double w) {
  return {{x, y, z, w}};
}
inline Vec4d splat4d(double s) {
  return {{s, s, s, s}};
}
inline Vec4d operator+(Vec4d a, Vec4d b) {
  return {{a.v[0] + b.v[0], a.v[1] + b.v[1], a.v[2] + b.v[2], a.v[3] + b.v[3]}};
}
inline Vec4d operator-(Vec4d a, Vec4d b) {
  return {{a.v[0] - b.v[0], a.v[1] - b.v[1], a.v[2] - b.v[2], a.v[3] - b.v[3]}};
}
inline Vec4d operator*(Vec4d a, Vec4d b) {
  return {{a.v[0] * b.v[0], a.v[1] * b.v[1], a.v[2] * b.v[2], a.v[3] * b.v[3]}};
}
inline Vec4d abs(Vec4d a) {
  return {{std::fabs(a.v[0]), std::fabs(a.v[1]), std::fabs(a.v[2]), std::fabs(a.v[3])}};
}
inline Vec4d min(Vec4d a, Vec4d b) {
  Vec4d r;
  for (int i = 0; i < 4; ++i) r.v[i] = a.v[i] < b.v[i] ? a.v[i] : b.v[i];
  return r;
}
inline Vec4d max(Vec4d a, Vec4d b) {
  Vec4d r;
  for (int i = 0; i < 4; ++i) r.v[i] = a.v[i] > b.v[i] ? a.v[i] : b.v[i];
  return r;
}
inline Vec4f to_float(Vec4d a) {
  return make4(static_cast<float>(a.v[0]), static_cast<float>(a.v[1]), static_cast<float>(a.v[2]),
               static_cast<float>(a.v[3]));
}
#endif

}  // namespace sahbench::simd
