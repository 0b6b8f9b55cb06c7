#pragma once
// Ray/box slab tests (Kay and Kajiya 1986), set up once per ray and run once per node.

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/aabb.h"
#include "core/ray.h"

namespace sahbench {

/// gamma(n) = n * eps / (1 - n * eps), the bound on the relative error of n chained float operations
/// (Higham 2002, "Accuracy and Stability of Numerical Algorithms", chapter 3; pbrt-v4's gamma()), with
/// eps = 2^-24 the unit roundoff of float.
constexpr float float_gamma(int n) {
  constexpr float kUnitRoundoff = 0x1p-24f;
  return static_cast<float>(n) * kUnitRoundoff / (1.0f - static_cast<float>(n) * kUnitRoundoff);
}

namespace detail {

// A box seen as six floats: min x y z, max x y z, so that a per-ray index picks the near or far plane
// without a branch (pbrt's dirIsNeg; Williams et al. 2005, "An Efficient and Robust Ray-Box
// Intersection Algorithm").
using BoxPlanes = std::array<float, 6>;
static_assert(sizeof(Aabb) == sizeof(BoxPlanes), "Aabb must be six packed floats to be read as planes");

// What both slab tests precompute per ray: origin, reciprocal direction and, per axis, which of the
// six planes is met first. The near plane is chosen by the sign bit (not by dir < 0), so that -0 counts
// as negative: 1 / -0 = -inf, and the max plane is then the near one, exactly as for any negative value.
struct SlabSetup {
  std::array<float, 3> org;
  std::array<float, 3> inv_dir;
  std::array<uint8_t, 3> near_plane;
  std::array<uint8_t, 3> far_plane;

  explicit SlabSetup(const Ray& ray) {
    for (std::size_t axis = 0; axis < 3; ++axis) {
      org[axis] = ray.org[axis];
      // 1 / +-0 = +-inf by IEEE 754; the slab code below copes with the inf (and the NaN it may make).
      inv_dir[axis] = 1.0f / ray.dir[axis];
      const bool negative = std::signbit(ray.dir[axis]);
      near_plane[axis] = static_cast<uint8_t>(negative ? axis + 3 : axis);
      far_plane[axis] = static_cast<uint8_t>(negative ? axis : axis + 3);
    }
  }

  // Intersects the ray's [tmin, tmax] with the three slabs. With kScaleFar, each far distance is
  // multiplied by `far_scale` (a bool rather than a float template parameter: clang < 18 has none).
  //
  // NaN: with a zero direction component, (plane - org) * inf is NaN exactly when the origin lies on that
  // plane. The updates are written `t > near ? t : near` so that a NaN t compares false and leaves the
  // interval unchanged: an origin on a face plane counts as inside that slab, which can only add hits.
  template <bool kScaleFar>
  bool intersect(const Aabb& box, float tmin, float tmax, float& t_entry, float far_scale = 1.0f) const {
    const BoxPlanes planes = std::bit_cast<BoxPlanes>(box);
    float t_near = tmin;
    float t_far = tmax;
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const float t0 = (planes[near_plane[axis]] - org[axis]) * inv_dir[axis];
      float t1 = (planes[far_plane[axis]] - org[axis]) * inv_dir[axis];
      if constexpr (kScaleFar) t1 *= far_scale;
      t_near = t0 > t_near ? t0 : t_near;
      t_far = t1 < t_far ? t1 : t_far;
    }
    t_entry = t_near;
    return t_near <= t_far;
  }
};

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
    return setup_.intersect<true>(box, tmin, tmax, t_entry, kFarScale);
  }

 private:
  detail::SlabSetup setup_;
};

/// The plain slab test (Kay and Kajiya 1986; Williams et al. 2005) without Ize's scaling: one multiply per
/// axis cheaper, but rounding can make it miss a box the ray grazes (DESIGN.md: faster, less exact
/// variants are reported with their error). Same NaN handling and closed intervals as RobustRayBox.
class FastRayBox {
 public:
  explicit FastRayBox(const Ray& ray) : setup_(ray) {}

  bool intersect(const Aabb& box, float tmin, float tmax, float& t_entry) const {
    return setup_.intersect<false>(box, tmin, tmax, t_entry);
  }

 private:
  detail::SlabSetup setup_;
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
    const detail::BoxPlanes planes = std::bit_cast<detail::BoxPlanes>(box);
    float t_near = tmin;
    float t_far = tmax;
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const float t0 = std::fma(planes[setup_.near_plane[axis]], setup_.inv_dir[axis], -org_inv_[axis]);
      const float t1 = std::fma(planes[setup_.far_plane[axis]], setup_.inv_dir[axis], -org_inv_[axis]);
      t_near = t0 > t_near ? t0 : t_near;
      t_far = t1 < t_far ? t1 : t_far;
    }
    t_entry = t_near;
    return t_near <= t_far;
  }

 private:
  detail::SlabSetup setup_;
  std::array<float, 3> org_inv_;
};

}  // namespace sahbench
