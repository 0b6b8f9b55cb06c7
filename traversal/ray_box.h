#pragma once
// Ray/box slab tests (Kay and Kajiya 1986), set up once per ray and run once per node.

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/aabb.h"
#include "core/ray.h"

#if defined(__SSE4_1__)
#include <immintrin.h>
#endif

namespace sahbench {

/// gamma(n) = n * eps / (1 - n * eps), the bound on the relative error of n chained float operations
/// (Higham 2002, "Accuracy and Stability of Numerical Algorithms", chapter 3; pbrt-v4's gamma()), with
/// eps = 2^-24 the unit roundoff of float.
constexpr float float_gamma(int n) {
  constexpr float kUnitRoundoff = 0x1p-24f;
  return static_cast<float>(n) * kUnitRoundoff / (1.0f - static_cast<float>(n) * kUnitRoundoff);
}

namespace detail {

// What both slab tests precompute per ray: origin, reciprocal direction and, per axis, whether the
// max plane is met first (pbrt's dirIsNeg; Williams et al. 2005, "An Efficient and Robust Ray-Box
// Intersection Algorithm"). The near plane is chosen by the sign bit (not by dir < 0), so that -0 counts
// as negative: 1 / -0 = -inf, and the max plane is then the near one, exactly as for any negative value.
struct SlabSetup {
  std::array<float, 3> org;
  std::array<float, 3> inv_dir;
  std::array<bool, 3> negative;

  explicit SlabSetup(const Ray& ray) {
    for (std::size_t axis = 0; axis < 3; ++axis) {
      org[axis] = ray.org[axis];
      // 1 / +-0 = +-inf by IEEE 754; the slab code below copes with the inf (and the NaN it may make).
      inv_dir[axis] = 1.0f / ray.dir[axis];
      negative[axis] = std::signbit(ray.dir[axis]);
    }
  }

  // The near and far planes of `box` on `axis` for this ray, read from the box itself: a select per
  // plane rather than an index into a copy of the box, which the compiler would keep on the stack.
  float near_plane(const Aabb& box, std::size_t axis) const {
    return negative[axis] ? box.max[axis] : box.min[axis];
  }
  float far_plane(const Aabb& box, std::size_t axis) const {
    return negative[axis] ? box.min[axis] : box.max[axis];
  }

  // Intersects the ray's [tmin, tmax] with the three slabs. With kScaleFar, each far distance is
  // multiplied by `far_scale` (a bool rather than a float template parameter: clang < 18 has none).
  //
  // NaN: with a zero direction component, (plane - org) * inf is NaN exactly when the origin lies on that
  // plane. The updates are written `t > near ? t : near` so that a NaN t compares false and leaves the
  // interval unchanged: an origin on a face plane counts as inside that slab, which can only add hits.
  // `t_exit` is where the ray leaves the box, min(tmax, far distances): bvh2_packed's closest hit orders
  // by it the children it enters at one distance (packed_bvh2.h: PackedWalk).
  template <bool kScaleFar>
  bool intersect(const Aabb& box, float tmin, float tmax, float& t_entry, float& t_exit,
                 float far_scale = 1.0f) const {
    float t_near = tmin;
    float t_far = tmax;
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const float t0 = (near_plane(box, axis) - org[axis]) * inv_dir[axis];
      float t1 = (far_plane(box, axis) - org[axis]) * inv_dir[axis];
      if constexpr (kScaleFar) t1 *= far_scale;
      t_near = t0 > t_near ? t0 : t_near;
      t_far = t1 < t_far ? t1 : t_far;
    }
    t_entry = t_near;
    t_exit = t_far;
    return t_near <= t_far;
  }
};

// Both boxes of a binary node's children in one pass, four lanes per box (x, y, z and one unused), with
// the same IEEE operations per plane as SlabSetup::intersect and the same NaN rule: _mm_max_ps(t, near)
// is `t > near ? t : near`. The binary kernel calls it once per inner node.
enum class SlabForm { kRobust, kFast, kFma };

#if defined(__SSE4_1__)
struct SlabLanes {
  __m128 org, inv_dir, org_inv, negative;

  explicit SlabLanes(const SlabSetup& s)
      : org(_mm_setr_ps(s.org[0], s.org[1], s.org[2], 0.0f)),
        inv_dir(_mm_setr_ps(s.inv_dir[0], s.inv_dir[1], s.inv_dir[2], 1.0f)),
        org_inv(_mm_mul_ps(org, inv_dir)),
        negative(_mm_castsi128_ps(
            _mm_setr_epi32(-int(s.negative[0]), -int(s.negative[1]), -int(s.negative[2]), 0))) {}

  // Bit 0: `a` is met within [tmin, tmax], bit 1: `b`; their entry distances in t_a and t_b.
  template <SlabForm kForm>
  [[gnu::always_inline]] unsigned intersect_pair(const Aabb& a, const Aabb& b, float tmin, float tmax,
                                                 float& t_a, float& t_b, float far_scale) const {
    __m128 near_a, far_a, near_b, far_b;
    distances<kForm>(a, near_a, far_a, far_scale);
    distances<kForm>(b, near_b, far_b, far_scale);
    near_a = _mm_max_ps(near_a, _mm_set1_ps(tmin));
    near_b = _mm_max_ps(near_b, _mm_set1_ps(tmin));
    far_a = _mm_min_ps(far_a, _mm_set1_ps(tmax));
    far_b = _mm_min_ps(far_b, _mm_set1_ps(tmax));
    // Lanes (a, b) of x, y and z side by side, reduced over the three axes; lane 3 is never read.
    const __m128 near_xy = _mm_unpacklo_ps(near_a, near_b);  // ax bx ay by
    const __m128 near_z = _mm_unpackhi_ps(near_a, near_b);   // az bz
    const __m128 far_xy = _mm_unpacklo_ps(far_a, far_b);
    const __m128 far_z = _mm_unpackhi_ps(far_a, far_b);
    const __m128 t_near = _mm_max_ps(_mm_max_ps(near_xy, _mm_movehl_ps(near_xy, near_xy)), near_z);
    const __m128 t_far = _mm_min_ps(_mm_min_ps(far_xy, _mm_movehl_ps(far_xy, far_xy)), far_z);
    t_a = _mm_cvtss_f32(t_near);
    t_b = _mm_cvtss_f32(_mm_shuffle_ps(t_near, t_near, _MM_SHUFFLE(1, 1, 1, 1)));
    return static_cast<unsigned>(_mm_movemask_ps(_mm_cmple_ps(t_near, t_far))) & 3u;
  }

 private:
  // Near and far distances of `box`'s planes, per axis. The max corner is read from the box's own bytes
  // (min.z, max.x, max.y, max.z, shifted down a lane), so nothing past the box is loaded.
  template <SlabForm kForm>
  [[gnu::always_inline]] void distances(const Aabb& box, __m128& near, __m128& far, float far_scale) const {
    const __m128 lo = _mm_loadu_ps(&box.min.x);
    const __m128 hi_shifted = _mm_loadu_ps(&box.min.z);
    const __m128 hi = _mm_shuffle_ps(hi_shifted, hi_shifted, _MM_SHUFFLE(3, 3, 2, 1));
    const __m128 near_plane = _mm_blendv_ps(lo, hi, negative);
    const __m128 far_plane = _mm_blendv_ps(hi, lo, negative);
    if constexpr (kForm == SlabForm::kFma) {
#if defined(__FMA__)
      near = _mm_fmsub_ps(near_plane, inv_dir, org_inv);
      far = _mm_fmsub_ps(far_plane, inv_dir, org_inv);
#else
      static_assert(kForm != SlabForm::kFma, "box=fma pairs need FMA instructions");
#endif
    } else {
      near = _mm_mul_ps(_mm_sub_ps(near_plane, org), inv_dir);
      far = _mm_mul_ps(_mm_sub_ps(far_plane, org), inv_dir);
      if constexpr (kForm == SlabForm::kRobust) far = _mm_mul_ps(far, _mm_set1_ps(far_scale));
    }
  }
};
#endif

}  // namespace detail

/// Conservative ray/box test of Ize 2013, "Robust BVH Ray Traversal" (JCGT 2(2)), in the form of pbrt-v4
/// (Bounds3::IntersectP): each far distance is multiplied by 1 + 2 gamma(3), which bounds the rounding of
/// the subtraction, the reciprocal and the product in both the near and the far distance, so that a box
/// the exact ray meets within [tmin, tmax] is never reported as missed. It may report a hit on a box the
/// ray misses by a few ulps; that only costs time.
///
/// The guarantee is about the slabs: the ray's own tmin and tmax are compared as given, so a box that
/// the exact ray enters at exactly tmax may still be missed by a rounding of the near distance. The
/// scaling moves a positive far distance outwards but a negative one further below zero, so it holds
/// for tmin >= 0 (Ize's setting, and every ray set of this project). Intervals are closed: a box touched
/// at a single point or only at t = tmax counts as hit when the computed distances say so.
class RobustRayBox {
 public:
  /// 1 + 2 gamma(3): the bound of Ize 2013, as pbrt-v4 applies it.
  static constexpr float kFarScale = 1.0f + 2.0f * float_gamma(3);

  explicit RobustRayBox(const Ray& ray) : setup_(ray) {}

  /// True when the ray meets `box` within [tmin, tmax]; `t_entry` is then the (rounded) entry distance,
  /// max(tmin, near distance), which is a valid ordering key but not a conservative bound.
  bool intersect(const Aabb& box, float tmin, float tmax, float& t_entry) const {
    float t_exit;
    return intersect(box, tmin, tmax, t_entry, t_exit);
  }
  /// The same, with the (rounded, scaled) exit distance min(tmax, far distances) in `t_exit`.
  bool intersect(const Aabb& box, float tmin, float tmax, float& t_entry, float& t_exit) const {
    return setup_.intersect<true>(box, tmin, tmax, t_entry, t_exit, kFarScale);
  }

  /// intersect() on two boxes at once (a binary node's children): bit 0 for `a`, bit 1 for `b`.
  [[gnu::always_inline]] unsigned intersect_pair(const Aabb& a, const Aabb& b, float tmin, float tmax,
                                                 float& t_a, float& t_b) const {
#if defined(__SSE4_1__)
    return lanes_.intersect_pair<detail::SlabForm::kRobust>(a, b, tmin, tmax, t_a, t_b, kFarScale);
#else
    return unsigned(intersect(a, tmin, tmax, t_a)) | unsigned(intersect(b, tmin, tmax, t_b)) << 1;
#endif
  }

 private:
  detail::SlabSetup setup_;
#if defined(__SSE4_1__)
  detail::SlabLanes lanes_{setup_};
#endif
};

/// The plain slab test (Kay and Kajiya 1986; Williams et al. 2005) without Ize's scaling: one multiply per
/// axis cheaper, but rounding can make it miss a box the ray grazes (DESIGN.md: faster, less exact
/// variants are reported with their error). Same NaN handling and closed intervals as RobustRayBox.
class FastRayBox {
 public:
  explicit FastRayBox(const Ray& ray) : setup_(ray) {}

  bool intersect(const Aabb& box, float tmin, float tmax, float& t_entry) const {
    float t_exit;
    return intersect(box, tmin, tmax, t_entry, t_exit);
  }
  bool intersect(const Aabb& box, float tmin, float tmax, float& t_entry, float& t_exit) const {
    return setup_.intersect<false>(box, tmin, tmax, t_entry, t_exit);
  }

  /// intersect() on two boxes at once (a binary node's children): bit 0 for `a`, bit 1 for `b`.
  [[gnu::always_inline]] unsigned intersect_pair(const Aabb& a, const Aabb& b, float tmin, float tmax,
                                                 float& t_a, float& t_b) const {
#if defined(__SSE4_1__)
    return lanes_.intersect_pair<detail::SlabForm::kFast>(a, b, tmin, tmax, t_a, t_b, 1.0f);
#else
    return unsigned(intersect(a, tmin, tmax, t_a)) | unsigned(intersect(b, tmin, tmax, t_b)) << 1;
#endif
  }

 private:
  detail::SlabSetup setup_;
#if defined(__SSE4_1__)
  detail::SlabLanes lanes_{setup_};
#endif
};

/// The slab test as Embree writes it (its BVH node intersectors): t = plane * rdir - org * rdir, each
/// distance one fused multiply-subtract, with org * rdir computed once per ray. One operation per plane
/// instead of two, and a shorter dependency chain, which is what the wide kernels gain from it; the
/// scalar kernels call std::fma, which is exact on any CPU but slower where fma is not an instruction.
/// Like FastRayBox it can miss a box the ray grazes, and org * rdir adds an absolute error of up to
/// 2^-24 |org / dir| on each axis: far from the world's origin, a ray grazing a box within that distance
/// may miss it (the stress suite's far cases measure it).
///
/// Its domain is the rays whose reciprocal and org * rdir are finite: every direction component a
/// normal float (|d| >= 2^-126, zero excluded) and no org * rdir overflowing. Outside it the form cannot
/// be written without clamping the reciprocal, as Embree's rcp_safe does (|d| below 1e-18 taken as
/// 1e-18), which misses every box narrower than 1e-18 t around an axis-parallel ray and overflows for
/// origins beyond 3.4e20. So every box=fma kernel traces a ray outside the domain with RobustRayBox
/// (bvh2_traversal.h, wide_kernels.inl): axis-parallel rays pay for the robust test and get its answers.
class FmaRayBox {
 public:
  /// Whether `ray` is in the domain of this test; the others take RobustRayBox.
  static bool takes(const Ray& ray) {
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const float d = ray.dir[axis];
      if (!(std::abs(d) >= std::numeric_limits<float>::min())) return false;
      if (!(std::abs(ray.org[axis] * (1.0f / d)) < std::numeric_limits<float>::infinity())) return false;
    }
    return true;
  }

  /// `ray` must be one the test takes().
  explicit FmaRayBox(const Ray& ray) : setup_(ray) {
    for (std::size_t axis = 0; axis < 3; ++axis) org_inv_[axis] = ray.org[axis] * setup_.inv_dir[axis];
  }

  bool intersect(const Aabb& box, float tmin, float tmax, float& t_entry) const {
    float t_exit;
    return intersect(box, tmin, tmax, t_entry, t_exit);
  }
  bool intersect(const Aabb& box, float tmin, float tmax, float& t_entry, float& t_exit) const {
    float t_near = tmin;
    float t_far = tmax;
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const float t0 = std::fma(setup_.near_plane(box, axis), setup_.inv_dir[axis], -org_inv_[axis]);
      const float t1 = std::fma(setup_.far_plane(box, axis), setup_.inv_dir[axis], -org_inv_[axis]);
      t_near = t0 > t_near ? t0 : t_near;
      t_far = t1 < t_far ? t1 : t_far;
    }
    t_entry = t_near;
    t_exit = t_far;
    return t_near <= t_far;
  }

  /// intersect() on two boxes at once (a binary node's children): bit 0 for `a`, bit 1 for `b`.
  [[gnu::always_inline]] unsigned intersect_pair(const Aabb& a, const Aabb& b, float tmin, float tmax,
                                                 float& t_a, float& t_b) const {
#if defined(__SSE4_1__) && defined(__FMA__)
    return lanes_.intersect_pair<detail::SlabForm::kFma>(a, b, tmin, tmax, t_a, t_b, 1.0f);
#else
    return unsigned(intersect(a, tmin, tmax, t_a)) | unsigned(intersect(b, tmin, tmax, t_b)) << 1;
#endif
  }

 private:
  detail::SlabSetup setup_;
  std::array<float, 3> org_inv_;
#if defined(__SSE4_1__)
  detail::SlabLanes lanes_{setup_};
#endif
};

}  // namespace sahbench
