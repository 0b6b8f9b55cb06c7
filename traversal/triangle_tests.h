#pragma once
// Ray/triangle tests, set up once per ray and run once per primitive. All share one contract:
//
//   bool intersect(const Triangle& tri, float tmin, float tmax, float& t, float& u, float& v) const
//
// returns true when the ray meets the triangle at a distance t with tmin <= t <= tmax (a closed interval,
// checked on the returned float t), and then sets t and the barycentrics (u, v) of the hit with respect
// to v1 and v2: p = (1-u-v)*v0 + u*v1 + v*v2 (core/ray.h). Front and back faces are both hit (no
// culling); a triangle seen edge-on (determinant 0) is missed. On a miss the outputs are unspecified.

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "core/ray.h"
#include "core/triangle.h"

namespace sahbench {

namespace detail {

using Components = std::array<float, 3>;
static_assert(sizeof(Vec3) == sizeof(Components), "Vec3 must be three packed floats");

// Vec3::operator[] is a chain of conditionals; a per-ray axis permutation wants a plain array index.
inline Components components(Vec3 a) {
  return std::bit_cast<Components>(a);
}

}  // namespace detail

/// The per-ray part of the watertight test (Woop et al. 2013, section 3): the axis of largest |dir|
/// becomes z (kz), the other two x and y, and the shear (sx, sy, sz) turns the ray into the +z axis.
/// Shared by the scalar test below and the SIMD kernels (wide_kernels.inl), so both transform every
/// vertex with the same float operations.
struct WatertightShear {
  uint8_t kx, ky, kz;
  float sx, sy, sz;
};

inline WatertightShear watertight_shear(Vec3 dir) {
  const Vec3 abs_dir{std::abs(dir.x), std::abs(dir.y), std::abs(dir.z)};
  WatertightShear s;
  // The axis of largest |dir| becomes z, so the shear divides by the largest component.
  s.kz = static_cast<uint8_t>(largest_axis(abs_dir));
  s.kx = static_cast<uint8_t>((s.kz + 1) % 3);
  s.ky = static_cast<uint8_t>((s.kx + 1) % 3);
  // Swapping x and y when the ray points down z keeps the winding, hence the sign of the edge
  // functions and of the determinant, the same for both directions (section 3).
  if (dir[s.kz] < 0.0f) std::swap(s.kx, s.ky);
  s.sx = dir[s.kx] / dir[s.kz];
  s.sy = dir[s.ky] / dir[s.kz];
  s.sz = 1.0f / dir[s.kz];
  return s;
}

/// Whether the float edge functions of the watertight test can be trusted: all finite and non-zero. A
/// zero may be a rounded non-zero (the ray passes within rounding of an edge; Woop et al. section 4), and
/// an infinite or NaN one comes from coordinates beyond float's range for products.
inline bool watertight_float_ok(float e0, float e1, float e2) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  return std::abs(e0) < kInf && std::abs(e1) < kInf && std::abs(e2) < kInf && e0 != 0.0f && e1 != 0.0f &&
         e2 != 0.0f;
}

/// Whether the float determinant and scaled distance can be trusted: det a normal float (not subnormal,
/// so 1 / det is finite) and the scaled distance finite.
inline bool watertight_det_ok(float det, float scaled_t) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const float abs_det = std::abs(det);
  return abs_det >= std::numeric_limits<float>::min() && abs_det < kInf && std::abs(scaled_t) < kInf;
}

/// The rest of the watertight test in double, from the float sheared vertices (a, b, c), when the float
/// path cannot be trusted. A product of two floats is exact in double and the difference of two is
/// rounded once, so each edge function's sign is exact (section 4) and two triangles sharing an edge
/// still get opposite values for it; the distance is computed in double and rounded once. Used by
/// WatertightTriangleTest and by the SIMD kernels' lanes (wide_kernels.inl repeats it, see there).
inline bool watertight_in_double(float ax, float ay, float az, float bx, float by, float bz, float cx,
                                 float cy, float cz, float tmin, float tmax, float& t, float& u, float& v) {
  const double e0 = static_cast<double>(cx) * by - static_cast<double>(cy) * bx;
  const double e1 = static_cast<double>(ax) * cy - static_cast<double>(ay) * cx;
  const double e2 = static_cast<double>(bx) * ay - static_cast<double>(by) * ax;
  if ((e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0)) return false;
  const double det = e0 + e1 + e2;
  if (det == 0.0 || !std::isfinite(det)) return false;
  const double distance = (e0 * az + e1 * bz + e2 * cz) / det;
  t = static_cast<float>(distance);
  if (!(t >= tmin && t <= tmax)) return false;
  u = static_cast<float>(e1 / det);
  v = static_cast<float>(e2 / det);
  return true;
}

/// The distance along the ray to the plane of (v0, v1, v2), t = n . (v0 - org) / n . dir with
/// n = (v1 - v0) x (v2 - v0), computed in double from the float inputs and rounded once; NaN where the
/// ray is parallel to the plane in double too.
///
/// The watertight test's own distance is a weighted mean of the sheared vertices' z (Woop et al. 2013,
/// section 3), and the sheared vertices are translated to the ray's origin and sheared in float, each
/// rounded to the ulps of its magnitude. On a thin triangle the barycentric weights amplify those
/// roundings by the aspect ratio: a 1000:1 needle at coordinates of 100 came out 15,000 ulps from the
/// exact t. In double, v0 - org and the edges are exact differences of floats whose exponents are within
/// 29 of each other, the cross product's products are exact, and what is left is a few units of 2^-53
/// times the aspect ratio over the cosine between ray and normal: far below a float ulp unless the ray
/// grazes the plane, so the rounded t is within one ulp of the exact distance. The watertight tests
/// keep their float edge functions for the hit decision (they are what makes them watertight) and run
/// this once per hit, not per test.
inline double plane_distance_in_double(Vec3 v0, Vec3 v1, Vec3 v2, Vec3 org, Vec3 dir) {
  const double e1x = static_cast<double>(v1.x) - v0.x, e1y = static_cast<double>(v1.y) - v0.y,
               e1z = static_cast<double>(v1.z) - v0.z;
  const double e2x = static_cast<double>(v2.x) - v0.x, e2y = static_cast<double>(v2.y) - v0.y,
               e2z = static_cast<double>(v2.z) - v0.z;
  const double nx = e1y * e2z - e1z * e2y, ny = e1z * e2x - e1x * e2z, nz = e1x * e2y - e1y * e2x;
  const double cx = static_cast<double>(v0.x) - org.x, cy = static_cast<double>(v0.y) - org.y,
               cz = static_cast<double>(v0.z) - org.z;
  return (nx * cx + ny * cy + nz * cz) / (nx * dir.x + ny * dir.y + nz * dir.z);
}

/// A watertight hit's distance: plane_distance_in_double where it is finite, else the test's own
/// `t_float` (a plane too steep for double, or edges whose product left double's range). Returns false
/// when the refined distance falls outside [tmin, tmax]: the contract holds on the returned t.
inline bool refine_watertight_t(Vec3 v0, Vec3 v1, Vec3 v2, Vec3 org, Vec3 dir, float tmin, float tmax,
                                float& t) {
  const double distance = plane_distance_in_double(v0, v1, v2, org, dir);
  const float refined = static_cast<float>(distance);
  if (std::abs(refined) < std::numeric_limits<float>::infinity()) t = refined;
  return t >= tmin && t <= tmax;
}

/// Whether a watertight hit's float distance t decides it against [tmin, tmax] without its refined
/// distance: t lies inside the interval by more than 2^-12 of the farthest vertex's distance along the
/// ray. z0, z1 and z2 are the vertices' distances along the ray as the test computes them, sz * (v[kz]
/// - org[kz]). The float t is a weighted mean of them, wrong by a few float roundings of the largest times
/// the triangle's conditioning (the sensitivity of its barycentric weights), so the margin holds for
/// triangles up to about a hundred times worse conditioned than an even one (a 1000:1 needle can be
/// farther off: intersect's comment). What it catches is a hit near either end of the interval, such as a
/// ray leaving a large triangle from an origin moved off it, whose float t to that triangle can be -0 or
/// just above 0 where the exact distance is below 0.
inline bool watertight_range_holds(float t, float z0, float z1, float z2, float tmin, float tmax) {
  const float a0 = std::abs(z0), a1 = std::abs(z1), a2 = std::abs(z2);
  const float a01 = a0 > a1 ? a0 : a1;  // as wide_kernels.inl's lane_range_holds takes it, NaN included
  const float margin = (a01 > a2 ? a01 : a2) * 0x1p-12f;
  return t > tmin + margin && t < tmax - margin;
}

/// Watertight ray/triangle intersection of Woop, Benthin and Wald 2013, "Watertight Ray/Triangle
/// Intersection" (JCGT 2(1)). The ray is turned into the +z axis by a permutation and a shear computed
/// once per ray (section 3); the vertices are transformed by the same float operations for every
/// triangle, so two triangles sharing an edge evaluate that edge's 2D edge function from identical
/// inputs and cannot both miss a ray through it. Where an edge function comes out exactly 0, or the
/// products leave float's range, the test is finished in double (section 4: a product of two floats is
/// exact in double), so the signs stay exact. A ray through a shared edge or vertex hits at least one of the
/// triangles sharing it (unless the edge is a silhouette seen along the ray, where the surface itself folds
/// away).
///
/// The argument needs fl(a*b) - fl(c*d) with both products rounded, so that swapping the two vertices of
/// an edge negates its edge function exactly. A fused multiply-add breaks that, so every target using
/// this header compiles with -ffp-contract=off (set PUBLIC by traversal/CMakeLists.txt).
class WatertightTriangleTest {
 public:
  /// `ray.dir` must not be the zero vector.
  explicit WatertightTriangleTest(const Ray& ray)
      : org_(ray.org), dir_(ray.dir), shear_(watertight_shear(ray.dir)) {}

  /// The watertight decision, with a hit's distance refined (refine_watertight_t).
  bool intersect(const Triangle& tri, float tmin, float tmax, float& t, float& u, float& v) const {
    return intersect_float(tri, tmin, tmax, t, u, v) &&
           refine_watertight_t(tri.v0, tri.v1, tri.v2, org_, dir_, tmin, tmax, t);
  }

  const Vec3& org() const { return org_; }
  const Vec3& dir() const { return dir_; }
  const WatertightShear& shear() const { return shear_; }

  /// The watertight decision as any-hit queries run it, which report no distance: the float one, and the
  /// refined distance (refine_watertight_t) only where the float one's decision against [tmin, tmax]
  /// cannot stand (range_holds), so that a shadow ray rarely pays for a double-precision distance and is
  /// occluded where closest hit finds a hit (within range_holds' limit on the triangle's conditioning).
  bool intersect_any(const Triangle& tri, float tmin, float tmax, float& t, float& u, float& v) const {
    return intersect_float(tri, tmin, tmax, t, u, v) && any_hit_holds(tri, tmin, tmax, t);
  }

  /// Whether an any-hit query keeps a float hit at t on `tri`: where range_holds cannot vouch for it, its
  /// refined distance (written to t) decides.
  bool any_hit_holds(const Triangle& tri, float tmin, float tmax, float& t) const {
    return range_holds(tri, t, tmin, tmax) ||
           refine_watertight_t(tri.v0, tri.v1, tri.v2, org_, dir_, tmin, tmax, t);
  }

  /// watertight_range_holds for a float hit at t on `tri`, its vertices' distances along the ray computed
  /// as intersect_float computes them.
  bool range_holds(const Triangle& tri, float t, float tmin, float tmax) const {
    const float o = detail::components(org_)[shear_.kz];
    return watertight_range_holds(t, shear_.sz * (detail::components(tri.v0)[shear_.kz] - o),
                                  shear_.sz * (detail::components(tri.v1)[shear_.kz] - o),
                                  shear_.sz * (detail::components(tri.v2)[shear_.kz] - o), tmin, tmax);
  }

  /// The watertight decision with the float distance of Woop et al., which intersect refines and
  /// intersect_any checks.
  bool intersect_float(const Triangle& tri, float tmin, float tmax, float& t, float& u, float& v) const {
    // Vertices relative to the origin, then sheared so the ray is the +z axis through (0, 0).
    const detail::Components a = detail::components(tri.v0 - org_);
    const detail::Components b = detail::components(tri.v1 - org_);
    const detail::Components c = detail::components(tri.v2 - org_);
    const auto [kx, ky, kz, sx, sy, sz] = shear_;
    const float ax = a[kx] - sx * a[kz], ay = a[ky] - sy * a[kz];
    const float bx = b[kx] - sx * b[kz], by = b[ky] - sy * b[kz];
    const float cx = c[kx] - sx * c[kz], cy = c[ky] - sy * c[kz];
    const float az = sz * a[kz], bz = sz * b[kz], cz = sz * c[kz];

    // Scaled barycentrics: e0 weights v0 (edge v1-v2), e1 weights v1 (edge v2-v0), e2 weights v2.
    const float e0 = cx * by - cy * bx;
    const float e1 = ax * cy - ay * cx;
    const float e2 = bx * ay - by * ax;
    // The ray passes (to float precision) through an edge, or the products left float's range
    // (coordinates beyond about 1e12 overflow, edges below about 1e-19 underflow): decide in double.
    if (!watertight_float_ok(e0, e1, e2)) [[unlikely]]
      return watertight_in_double(ax, ay, az, bx, by, bz, cx, cy, cz, tmin, tmax, t, u, v);
    // Inside when no edge function has the wrong sign.
    if ((e0 < 0.0f || e1 < 0.0f || e2 < 0.0f) && (e0 > 0.0f || e1 > 0.0f || e2 > 0.0f)) return false;
    const float det = e0 + e1 + e2;
    const float scaled_t = e0 * az + e1 * bz + e2 * cz;
    if (!watertight_det_ok(det, scaled_t)) [[unlikely]]
      return watertight_in_double(ax, ay, az, bx, by, bz, cx, cy, cz, tmin, tmax, t, u, v);

    // Scaled distance T = t * det. Compare it with [tmin, tmax] * |det| before dividing, so misses
    // never pay for the division (section 3); flipping both signs makes det positive.
    const float abs_det = std::abs(det);
    const float signed_t = det < 0.0f ? -scaled_t : scaled_t;
    if (!(signed_t >= tmin * abs_det && signed_t <= tmax * abs_det)) return false;

    const float inv_det = 1.0f / det;
    t = scaled_t * inv_det;
    // The product may round across tmin or tmax; the contract is on the returned t.
    if (!(t >= tmin && t <= tmax)) return false;
    u = e1 * inv_det;
    v = e2 * inv_det;
    return true;
  }

 private:
  Vec3 org_;
  Vec3 dir_;
  WatertightShear shear_;
};

/// The triangle test as an any-hit query runs it: the watertight test's own (WatertightTriangleTest::
/// intersect_any), the others as they are.
template <class TriangleTest>
bool intersect_any(const TriangleTest& test, const Triangle& tri, float tmin, float tmax, float& t, float& u,
                   float& v) {
  if constexpr (requires { test.intersect_any(tri, tmin, tmax, t, u, v); })
    return test.intersect_any(tri, tmin, tmax, t, u, v);
  else
    return test.intersect(tri, tmin, tmax, t, u, v);
}

/// Whether an any-hit query keeps a hit at t that a four-lane test's float form found on `tri`:
/// WatertightTriangleTest::any_hit_holds for the watertight test; the others' hits stand.
template <class TriangleTest>
bool any_hit_holds(const TriangleTest& test, const Triangle& tri, float tmin, float tmax, float& t) {
  if constexpr (requires { test.any_hit_holds(tri, tmin, tmax, t); })
    return test.any_hit_holds(tri, tmin, tmax, t);
  else
    return true;
}

/// Default determinant threshold of MollerTrumboreTest: EPSILON = 0.000001 in the code listing of
/// Möller and Trumbore 1997. It is absolute, so its effect depends on the scale of the scene and of
/// `ray.dir` (det = dir . (e1 x e2) scales with |dir| |e1| |e2|); with unit directions and edges of
/// about one unit it rejects rays within about 1e-6 rad of the triangle's plane.
inline constexpr float kMollerTrumboreEpsilon = 1e-6f;

/// Ray/triangle test of Möller and Trumbore 1997, "Fast, Minimum Storage Ray/Triangle Intersection"
/// (JGT 2(1)), the non-culling branch: Cramer's rule on the ray/plane system, testing u and v as soon as
/// each is known. It is not watertight: rays through shared edges can leak. A hit needs
/// |det| > det_epsilon (strictly), so det_epsilon = 0 rejects only det == 0 (and NaN).
class MollerTrumboreTest {
 public:
  explicit MollerTrumboreTest(const Ray& ray, float det_epsilon = kMollerTrumboreEpsilon)
      : org_(ray.org), dir_(ray.dir), det_epsilon_(det_epsilon) {}

  const Vec3& org() const { return org_; }
  const Vec3& dir() const { return dir_; }
  float det_epsilon() const { return det_epsilon_; }

  bool intersect(const Triangle& tri, float tmin, float tmax, float& t, float& u, float& v) const {
    const Vec3 edge1 = tri.v1 - tri.v0;
    const Vec3 edge2 = tri.v2 - tri.v0;
    const Vec3 p = cross(dir_, edge2);
    const float det = dot(edge1, p);
    // Written so that a NaN determinant is a miss.
    if (!(std::abs(det) > det_epsilon_)) return false;
    const float inv_det = 1.0f / det;
    const Vec3 s = org_ - tri.v0;
    u = dot(s, p) * inv_det;
    if (!(u >= 0.0f && u <= 1.0f)) return false;
    const Vec3 q = cross(s, edge1);
    v = dot(dir_, q) * inv_det;
    if (!(v >= 0.0f && u + v <= 1.0f)) return false;
    t = dot(edge2, q) * inv_det;
    return t >= tmin && t <= tmax;
  }

 private:
  Vec3 org_;
  Vec3 dir_;
  float det_epsilon_;
};

/// MollerTrumboreTest with a determinant threshold of 0, as its own type so that kernels select it at
/// compile time like the others: only an edge-on triangle (det == 0) is rejected.
class MollerTrumboreNoEpsilonTest : public MollerTrumboreTest {
 public:
  explicit MollerTrumboreNoEpsilonTest(const Ray& ray) : MollerTrumboreTest(ray, 0.0f) {}
};

/// The geometric normal e1 x e2 of the edges e1 = v1 - v0, e2 = v2 - v0, as MollerTrumboreNormalTest
/// computes it and as the wide layouts store it (wide_bvh.h, BlockForm::kEdgesNormals): the same float
/// operations, so the stored normal is the one the test would compute.
inline Vec3 stored_normal(Vec3 edge1, Vec3 edge2) {
  return cross(edge1, edge2);
}

/// The float range of MollerTrumboreNormalTest. Its products reach |c| |e|^2, |d| |e|^2 and |d| |c| |e|
/// (c = v0 - org), and a triangle's normal |e|^2: with coordinates beyond about 1e12 they overflow, and
/// with edges below about 1e-19 the normal underflows to zero, and the float test misses what it should
/// hit (a triangle at the 1e30 scale had an infinite normal). So the test runs in float when the ray's
/// origin components are within 2^40 and its direction's largest component within [2^-40, 2^40]
/// (mtn_ray_in_range), and the triangle's v0, edge and normal components are within 2^40 and its
/// normal's largest component at least 2^-60 (mtn_triangle_in_range): then every product stays below
/// 2^125, and a determinant below float's smallest normal means a ray within 2^-26 rad of the plane.
/// Otherwise it runs in double (mtn_in_double), where no product of floats overflows or underflows.
inline constexpr float kMtnMaxMagnitude = 0x1p40f;
inline constexpr float kMtnMinDirection = 0x1p-40f;
inline constexpr float kMtnMinNormal = 0x1p-60f;

inline bool mtn_ray_in_range(Vec3 org, Vec3 dir) {
  const float largest = std::max({std::abs(dir.x), std::abs(dir.y), std::abs(dir.z)});
  return std::abs(org.x) <= kMtnMaxMagnitude && std::abs(org.y) <= kMtnMaxMagnitude &&
         std::abs(org.z) <= kMtnMaxMagnitude && largest >= kMtnMinDirection && largest <= kMtnMaxMagnitude;
}

/// `v0`, the edges and the normal as MollerTrumboreNormalTest computes them (stored_normal).
inline bool mtn_triangle_in_range(Vec3 v0, Vec3 e1, Vec3 e2, Vec3 n) {
  float largest = 0.0f, largest_normal = 0.0f;
  for (std::size_t axis = 0; axis < 3; ++axis) {
    largest =
        std::max({largest, std::abs(v0[axis]), std::abs(e1[axis]), std::abs(e2[axis]), std::abs(n[axis])});
    largest_normal = std::max(largest_normal, std::abs(n[axis]));
  }
  // std::max skips a NaN component; a triangle with one misses all the same (its determinant is NaN).
  return largest <= kMtnMaxMagnitude && largest_normal >= kMtnMinNormal;
}

/// MollerTrumboreNormalTest in double, from the float v0 and edges: the normal, c, r and the dot products
/// in double, then the same decisions (u >= 0, v >= 0, u + v <= det, t in [tmin, tmax] times det), and t,
/// u and v divided in double and rounded once. Used where the float test is out of range, by the scalar
/// test and by the SIMD kernels' lanes (wide_kernels.inl repeats it, as it does watertight_in_double).
inline bool mtn_in_double(Vec3 v0, Vec3 e1, Vec3 e2, Vec3 org, Vec3 dir, float tmin, float tmax, float& t,
                          float& u, float& v) {
  const double ax = e1.x, ay = e1.y, az = e1.z, bx = e2.x, by = e2.y, bz = e2.z;
  const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
  const double cx = static_cast<double>(v0.x) - org.x, cy = static_cast<double>(v0.y) - org.y,
               cz = static_cast<double>(v0.z) - org.z;
  const double dx = dir.x, dy = dir.y, dz = dir.z;
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
  t = static_cast<float>(st / abs_det);
  u = static_cast<float>(su / abs_det);
  v = static_cast<float>(sv / abs_det);
  return t >= tmin && t <= tmax;
}

/// Möller–Trumbore in the form Embree's Triangle4 intersector uses (Embree 3,
/// kernels/geometry/triangle_intersector_moeller.h; Wald et al. 2014, "Embree: A Kernel Framework for
/// Efficient CPU Ray Tracing"): the same Cramer's rule as MollerTrumboreTest, rearranged around the
/// geometric normal n = e1 x e2, which the wide layouts store with the triangle. With c = v0 - org and
/// r = dir x c, the determinant is dir . n, u = -(e2 . r) / det, v = (e1 . r) / det and t = (c . n) / det:
/// one cross product and four dot products per triangle where MollerTrumboreTest takes two of each and
/// a subtraction more. u, v and t are compared multiplied by |det| (0 <= u, 0 <= v, u + v <= |det|,
/// |det| tmin <= t <= |det| tmax), so the division waits for a hit; the hit's t is then checked again as
/// divided, as this header's contract says. |det| must be a normal float, so that 1 / |det| is finite (a
/// subnormal one, from a triangle of edge ~1e-19 or less, made hits at t = inf); an infinite det misses
/// too (|det| tmin is NaN at tmin = 0). There is no epsilon, as in mt0. Not watertight.
///
/// r, det and the dot products use fused multiply-adds in a fixed order (std::fma here, FMA
/// instructions in the SIMD kernels, wide_kernels.inl), so every kernel computes the same floats;
/// without FMA hardware std::fma is exact but slow. The stored normal is a plain (unfused) cross product.
class MollerTrumboreNormalTest {
 public:
  explicit MollerTrumboreNormalTest(const Ray& ray)
      : org_(ray.org), dir_(ray.dir), ray_in_range_(mtn_ray_in_range(ray.org, ray.dir)) {}

  const Vec3& org() const { return org_; }
  const Vec3& dir() const { return dir_; }
  /// Whether the ray is within the float test's range (mtn_ray_in_range); if not, every triangle is
  /// tested in double.
  bool ray_in_range() const { return ray_in_range_; }

  bool intersect(const Triangle& tri, float tmin, float tmax, float& t, float& u, float& v) const {
    // v0, the edges and the normal: what the wide layouts store.
    const Vec3 edge1 = tri.v1 - tri.v0;
    const Vec3 edge2 = tri.v2 - tri.v0;
    const Vec3 normal = stored_normal(edge1, edge2);
    if (!ray_in_range_ || !mtn_triangle_in_range(tri.v0, edge1, edge2, normal)) [[unlikely]]
      return mtn_in_double(tri.v0, edge1, edge2, org_, dir_, tmin, tmax, t, u, v);
    const Vec3 c = tri.v0 - org_;
    const Vec3 d = dir_;
    const Vec3 r{std::fma(d.y, c.z, -(d.z * c.y)), std::fma(d.z, c.x, -(d.x * c.z)),
                 std::fma(d.x, c.y, -(d.y * c.x))};
    const float det = dot_fma(d, normal);
    // The sign of det moved onto u, v and t by flipping sign bits, as the SIMD kernels do.
    const uint32_t sign = std::bit_cast<uint32_t>(det) & 0x80000000u;
    const float abs_det = std::bit_cast<float>(std::bit_cast<uint32_t>(det) ^ sign);
    const float su = flip(dot_fma(edge2, r), sign ^ 0x80000000u);
    const float sv = flip(dot_fma(edge1, r), sign);
    // Written so that a NaN is a miss.
    if (!(abs_det >= std::numeric_limits<float>::min() && su >= 0.0f && sv >= 0.0f && su + sv <= abs_det))
      return false;
    const float st = flip(dot_fma(c, normal), sign);
    if (!(st >= abs_det * tmin && st <= abs_det * tmax)) return false;
    const float inv_det = 1.0f / abs_det;
    t = st * inv_det;
    u = su * inv_det;
    v = sv * inv_det;
    return t >= tmin && t <= tmax;
  }

 private:
  // a . b as fma(a.x, b.x, fma(a.y, b.y, a.z * b.z)).
  static float dot_fma(Vec3 a, Vec3 b) { return std::fma(a.x, b.x, std::fma(a.y, b.y, a.z * b.z)); }
  static float flip(float x, uint32_t sign) {
    return std::bit_cast<float>(std::bit_cast<uint32_t>(x) ^ sign);
  }

  Vec3 org_;
  Vec3 dir_;
  bool ray_in_range_;
};

}  // namespace sahbench
