#include "traversal/wide_bvh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#if defined(__AVX__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>

#include "core/error.h"
#include "traversal/ray_box.h"
#include "traversal/triangle_tests.h"
#include "traversal/wide_kernels_isa.h"

namespace sahbench {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

template <uint32_t N>
WideNode<N> empty_node() {
  WideNode<N> node;
  for (uint32_t i = 0; i < N; ++i) {
    // An inverted box: the near distance is +inf and the far one -inf for any ray, so no ray enters it.
    for (uint32_t axis = 0; axis < 3; ++axis) {
      node.planes[2 * axis][i] = kInf;
      node.planes[2 * axis + 1][i] = -kInf;
    }
    node.child[i] = 0;
    node.count[i] = 0;
  }
  return node;
}

// A NaN plane is stored as -inf (a minimum) or +inf (a maximum). Every box test takes the distance to
// either as no bound at all (ray_box.h: a NaN distance leaves the interval as it is, and so does an
// infinite one on its own side), so no test answers differently; but the SIMD kernels' integer min and
// max (wide_kernels.inl) order NaN above every distance, and infinities as the float compares do.
// The builders never make NaN boxes from the scenes' finite triangles: this is for trees made by hand.
inline float finite_or(float plane, float unbounded) {
  return plane == plane ? plane : unbounded;
}

template <uint32_t N>
void set_box(WideNode<N>& node, uint32_t slot, const Aabb& box) {
  for (uint32_t axis = 0; axis < 3; ++axis) {
    node.planes[2 * axis][slot] = finite_or(box.min[axis], -kInf);
    node.planes[2 * axis + 1][slot] = finite_or(box.max[axis], kInf);
  }
}

// Writes triangle t into lane `lane` of `block`, in `form` (a NormalBlock for kEdgesNormals).
void set_lane(TriangleBlock& block, uint32_t lane, const Triangle& t, BlockForm form) {
  const bool edges = form != BlockForm::kVertices;
  const Vec3 e1 = t.v1 - t.v0, e2 = t.v2 - t.v0;
  for (uint32_t axis = 0; axis < 3; ++axis) {
    block.v0[axis][lane] = t.v0[axis];
    block.v1[axis][lane] = edges ? e1[axis] : t.v1[axis];
    block.v2[axis][lane] = edges ? e2[axis] : t.v2[axis];
  }
  if (form != BlockForm::kEdgesNormals) return;
  auto& normal_block = reinterpret_cast<NormalBlock&>(block);
  const Vec3 n = stored_normal(e1, e2);
  for (uint32_t axis = 0; axis < 3; ++axis) normal_block.normal[axis][lane] = n[axis];
  const bool in_double = block.prim[lane] != kInvalidPrim && !mtn_triangle_in_range(t.v0, e1, e2, n);
  normal_block.in_double =
      (normal_block.in_double & ~(1u << lane)) | (static_cast<uint32_t>(in_double) << lane);
}

// Writes the triangles of `refs` into consecutive blocks of `form` starting at `first`.
void fill_blocks(std::span<const uint32_t> refs, std::span<const Triangle> triangles, BlockForm form,
                 WideUnit* first) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Triangle unused{{nan, nan, nan}, {nan, nan, nan}, {nan, nan, nan}};
  for (std::size_t i = 0; i < refs.size(); i += kBlockWidth, first += block_units(form)) {
    auto& block = *reinterpret_cast<TriangleBlock*>(first);
    if (form == BlockForm::kEdgesNormals) {
      auto& normal_block = reinterpret_cast<NormalBlock&>(block);
      normal_block.in_double = 0;
      for (uint32_t& u : normal_block.unused) u = 0;
    }
    for (uint32_t lane = 0; lane < kBlockWidth; ++lane) {
      const bool used = i + lane < refs.size();
      block.prim[lane] = used ? refs[i + lane] : kInvalidPrim;
      set_lane(block, lane, used ? triangles[refs[i + lane]] : unused, form);
    }
  }
}

uint32_t blocks_for(uint32_t prims) {
  return (prims + kBlockWidth - 1) / kBlockWidth;
}

}  // namespace

namespace {

// One ray's set-up (make_wide_ray), with the choices fixed at compile time, as set_up_block below
// makes them for a batch: set-up is a tenth of a closest-hit ray's time at 10 Mrays/s, and a run-time
// choice of the reciprocal per axis (box=fma's or IEEE's) cost the closest-hit rays 1-7%.
// The bits of 2^-100 and of +inf. A slab distance fma(plane, inv, -org_inv) that is not zero is at
// least 2^-149 in magnitude when |org_inv| >= 2^-100: the exact product has at most 48 significant
// bits, so where it nearly cancels org_inv, of magnitude 2^k, the exact difference is a multiple of
// 2^(k - 49) or more; and where it does not, the difference is at least |org_inv| / 2. So it cannot
// round to -0 from below (wide_kernels.inl: kInt).
constexpr uint32_t kLowestFreeOrgInv = 0x0d800000u;
constexpr uint32_t kInfBits = 0x7f800000u;
static_assert(std::bit_cast<uint32_t>(0x1p-100f) == kLowestFreeOrgInv);

template <bool kShear, bool kFma>
inline void set_up(const Ray& ray, WideRay& r) {
  for (uint32_t axis = 0; axis < 3; ++axis) {
    r.org[axis] = ray.org[axis];
    r.dir[axis] = ray.dir[axis];
    // 1 / +-0 = +-inf, as in ray_box.h.
    r.inv_dir[axis] = 1.0f / ray.dir[axis];
    r.org_inv[axis] = ray.org[axis] * r.inv_dir[axis];
    const uint32_t negative = std::signbit(ray.dir[axis]) ? 1u : 0u;
    r.near_plane[axis] = 2 * axis + negative;
    r.far_plane[axis] = 2 * axis + (1u - negative);
  }
  r.tmin = ray.tmin;
  r.tmax = far_limit(ray);
  // An untraceable ray (core/ray.h) gets an empty interval, which no box test can widen, NaN or not.
  if (!traceable(ray)) r.tmin = 1.0f, r.tmax = 0.0f;
  // A ray outside box=fma's domain takes the robust box test (FmaRayBox::takes), and no integer path.
  // FmaRayBox::takes, on the reciprocals and products just made: every |d| a normal float, org * inv finite.
  bool fma_takes = true;
  for (uint32_t axis = 0; axis < 3; ++axis)
    fma_takes &= std::abs(ray.dir[axis]) >= std::numeric_limits<float>::min() &&
                 std::abs(r.org_inv[axis]) < std::numeric_limits<float>::infinity();
  r.robust_box = kFma && !fma_takes;
  r.mtn_in_double = !mtn_ray_in_range(ray.org, ray.dir);
  // In the domain, box=fma's inv_dir and org_inv are finite and inv_dir non-zero. Each axis in one
  // unsigned compare of |org_inv|'s bits: in [2^-100, inf), or not, and then below 2^-100 (guarded).
  IntOrder int_order = IntOrder::kNone;
  if (kFma && !r.robust_box && !std::signbit(r.tmin) && !(r.tmax < 0.0f)) {
    bool free = true, finite = true;
    for (uint32_t axis = 0; axis < 3; ++axis) {
      const uint32_t bits = std::bit_cast<uint32_t>(r.org_inv[axis]) & 0x7fffffffu;
      free &= bits - kLowestFreeOrgInv < kInfBits - kLowestFreeOrgInv;
      finite &= bits < kInfBits;
    }
    int_order = free ? IntOrder::kFree : finite ? IntOrder::kGuarded : IntOrder::kNone;
  }
  r.int_order = int_order;
  if constexpr (!kShear) {
    r.kx = 0, r.ky = 1, r.kz = 2;
    r.sx = r.sy = r.sz = 0.0f;
  } else {
    // watertight_shear's axes and factors, with selects in place of its branches: the axis of largest
    // |dir| is as good as random for diffuse rays, and a mispredicted branch per ray cost more than the test.
    const float ax = std::abs(ray.dir.x), ay = std::abs(ray.dir.y), az = std::abs(ray.dir.z);
    const bool x_largest = ax >= ay && ax >= az;
    const uint32_t kz = x_largest ? 0u : (ay >= az ? 1u : 2u);
    const uint32_t next = kz == 2 ? 0u : kz + 1, after = next == 2 ? 0u : next + 1;
    const bool swap = ray.dir[kz] < 0.0f;
    r.kz = kz;
    r.kx = swap ? after : next;
    r.ky = swap ? next : after;
    r.sx = ray.dir[r.kx] / ray.dir[kz];
    r.sy = ray.dir[r.ky] / ray.dir[kz];
    r.sz = 1.0f / ray.dir[kz];
  }
}

#if defined(__AVX__)
// Rows m[0..7] of an 8 x 8 matrix of 32-bit words become its columns (Intel's optimization manual's
// transpose: interleave pairs of rows, then pairs of pairs, then swap 128-bit halves).
inline void transpose8(__m256 (&m)[8]) {
  __m256 t[8], u[8];
  for (int i = 0; i < 8; i += 2) {
    t[i] = _mm256_unpacklo_ps(m[i], m[i + 1]);
    t[i + 1] = _mm256_unpackhi_ps(m[i], m[i + 1]);
  }
  for (int i = 0; i < 8; i += 4) {
    u[i] = _mm256_shuffle_ps(t[i], t[i + 2], 0x44);
    u[i + 1] = _mm256_shuffle_ps(t[i], t[i + 2], 0xEE);
    u[i + 2] = _mm256_shuffle_ps(t[i + 1], t[i + 3], 0x44);
    u[i + 3] = _mm256_shuffle_ps(t[i + 1], t[i + 3], 0xEE);
  }
  for (int i = 0; i < 4; ++i) {
    m[i] = _mm256_permute2f128_ps(u[i], u[i + 4], 0x20);
    m[i + 4] = _mm256_permute2f128_ps(u[i], u[i + 4], 0x31);
  }
}

// An array of words seen as floats, for the transposes, which move bits.
inline const float* words(const uint32_t* a) {
  return reinterpret_cast<const float*>(a);
}
#endif

// The same set-up for a block of kSetupBlock rays at a time, field by field in loops over the block
// that the compiler turns into SIMD instructions: a ray's six divisions and its selects, one ray at a
// time, cost about as much as a few node visits, most of the time of a ray that crosses few nodes (a
// primary ray that misses the scene's box costs its set-up and one box test). Each lane computes
// set_up's results by the same IEEE operations (the integer-path order by float compares that give
// the same answers), so each ray gets the same bits; tests/traversal/wide_bvh_test.cpp holds the two
// to it. Sixteen rays: one AVX-512 register of floats.
constexpr std::size_t kSetupBlock = 16;

template <bool kShear, bool kFma>
WideRaysInfo set_up_block(std::span<const Ray> rays, WideRay* out) {
  constexpr std::size_t B = kSetupBlock;
  constexpr float kMax = std::numeric_limits<float>::max();
  constexpr float kMin = std::numeric_limits<float>::min();
  constexpr float kInfinity = std::numeric_limits<float>::infinity();
  const std::size_t n = rays.size();
  // Lanes past the rays copy the first: computed, never stored.
  alignas(64) float o[3][B], d[3][B], tmin[B], tmax[B];
#if defined(__AVX__)
  // A Ray is eight floats (org, tmin, dir, tmax): eight rays are one 8 x 8 transpose away from the arrays.
  static_assert(sizeof(Ray) == 8 * sizeof(float) && offsetof(Ray, tmin) == 3 * sizeof(float) &&
                offsetof(Ray, dir) == 4 * sizeof(float) && offsetof(Ray, tmax) == 7 * sizeof(float));
  for (std::size_t h = 0; h < B; h += 8) {
    __m256 m[8];
    for (std::size_t i = 0; i < 8; ++i)
      m[i] = _mm256_loadu_ps(reinterpret_cast<const float*>(&rays[h + i < n ? h + i : 0]));
    transpose8(m);
    float* const columns[8] = {o[0], o[1], o[2], tmin, d[0], d[1], d[2], tmax};
    for (std::size_t i = 0; i < 8; ++i) _mm256_store_ps(columns[i] + h, m[i]);
  }
#else
  for (std::size_t j = 0; j < B; ++j) {
    const Ray& ray = rays[j < n ? j : 0];
    for (uint32_t axis = 0; axis < 3; ++axis) {
      o[axis][j] = ray.org[axis];
      d[axis][j] = ray.dir[axis];
    }
    tmin[j] = ray.tmin;
    tmax[j] = ray.tmax;
  }
#endif
  alignas(64) float inv[3][B], org_inv[3][B], t0[B], t1[B], sx[B], sy[B], sz[B];
  alignas(64) uint32_t near[3][B], far[3][B], kx[B], ky[B], kz[B], order[B], robust[B], in_double[B];
  for (uint32_t axis = 0; axis < 3; ++axis)
    for (std::size_t j = 0; j < B; ++j) {
      inv[axis][j] = 1.0f / d[axis][j];
      org_inv[axis][j] = o[axis][j] * inv[axis][j];
      const uint32_t negative = std::bit_cast<uint32_t>(d[axis][j]) >> 31;
      near[axis][j] = 2 * axis + negative;
      far[axis][j] = 2 * axis + (1u - negative);
    }
  for (std::size_t j = 0; j < B; ++j) {
    auto finite = [](float x) { return x - x == 0.0f; };
    const bool traceable = finite(o[0][j]) & finite(o[1][j]) & finite(o[2][j]) & finite(d[0][j]) &
                           finite(d[1][j]) & finite(d[2][j]) & (tmin[j] == tmin[j]) & (tmax[j] == tmax[j]);
    const float limit = tmax[j] > kMax ? kMax : tmax[j];
    t0[j] = traceable ? tmin[j] : 1.0f;
    t1[j] = traceable ? limit : 0.0f;
    bool fma_takes = true;
    for (uint32_t axis = 0; axis < 3; ++axis)
      fma_takes &= (std::abs(d[axis][j]) >= kMin) & (std::abs(org_inv[axis][j]) < kInfinity);
    const bool robust_box = kFma && !fma_takes;
    robust[j] = robust_box;
    const float ax = std::abs(d[0][j]), ay = std::abs(d[1][j]), az = std::abs(d[2][j]);
    // std::max({ax, ay, az})'s order, so that a NaN gives the same answer.
    float largest = ax < ay ? ay : ax;
    largest = largest < az ? az : largest;
    in_double[j] = !((std::abs(o[0][j]) <= kMtnMaxMagnitude) & (std::abs(o[1][j]) <= kMtnMaxMagnitude) &
                     (std::abs(o[2][j]) <= kMtnMaxMagnitude) & (largest >= kMtnMinDirection) &
                     (largest <= kMtnMaxMagnitude));
    uint32_t int_order = static_cast<uint32_t>(IntOrder::kNone);
    if constexpr (kFma) {
      // set_up's unsigned compares of |org_inv|'s bits, as float compares (the same answers, NaN
      // included).
      constexpr float kLowestFree = std::bit_cast<float>(kLowestFreeOrgInv);
      uint32_t free = 1, finite_all = 1;
      for (uint32_t axis = 0; axis < 3; ++axis) {
        const float magnitude = std::abs(org_inv[axis][j]);
        free &= static_cast<uint32_t>((magnitude >= kLowestFree) & (magnitude < kInfinity));
        finite_all &= static_cast<uint32_t>(magnitude < kInfinity);
      }
      // set_up's tests of tmin and tmax come after the loop.
      const uint32_t eligible = static_cast<uint32_t>(!robust_box);
      // IntOrder's values in arithmetic rather than selects, which the compiler vectorizes: kFree
      // implies finite.
      static_assert(static_cast<uint32_t>(IntOrder::kNone) == 0 &&
                    static_cast<uint32_t>(IntOrder::kGuarded) == 1 &&
                    static_cast<uint32_t>(IntOrder::kFree) == 2);
      int_order = (eligible & finite_all) * (1u + free);
    }
    order[j] = int_order;
    if constexpr (kShear) {
      // set_up's axes and factors, the selects on each lane.
      const bool x_largest = (ax >= ay) & (ax >= az);
      const uint32_t k = x_largest ? 0u : (ay >= az ? 1u : 2u);
      const uint32_t next = k == 2 ? 0u : k + 1, after = next == 2 ? 0u : next + 1;
      const float dk = k == 0 ? d[0][j] : (k == 1 ? d[1][j] : d[2][j]);
      const bool swap = dk < 0.0f;
      const uint32_t x = swap ? after : next, y = swap ? next : after;
      const float dx = x == 0 ? d[0][j] : (x == 1 ? d[1][j] : d[2][j]);
      const float dy = y == 0 ? d[0][j] : (y == 1 ? d[1][j] : d[2][j]);
      kz[j] = k, kx[j] = x, ky[j] = y;
      sx[j] = dx / dk;
      sy[j] = dy / dk;
      sz[j] = 1.0f / dk;
    } else {
      kx[j] = 0, ky[j] = 1, kz[j] = 2;
      sx[j] = sy[j] = sz[j] = 0.0f;
    }
  }
  // set_up's tests of the interval in a loop of their own: in the loop above, the compiler does not
  // vectorize them.
  if constexpr (kFma)
    for (std::size_t j = 0; j < B; ++j)
      order[j] = (std::bit_cast<int32_t>(t0[j]) < 0) | (t1[j] < 0.0f) ? 0u : order[j];
  std::size_t j = 0;
#if defined(__AVX__)
  // WideRay's first 24 words are whole fields, so eight rays are three 8 x 8 transposes from the arrays;
  // the last three words (sy, sz and the flags) go field by field.
  static_assert(offsetof(WideRay, sx) == 23 * sizeof(float) && offsetof(WideRay, sy) == 24 * sizeof(float));
  // clang-format off
  const float* const columns[24] = {
      o[0], o[1], o[2], d[0], d[1], d[2], inv[0], inv[1],
      inv[2], org_inv[0], org_inv[1], org_inv[2], t0, t1, words(near[0]), words(near[1]),
      words(near[2]), words(far[0]), words(far[1]), words(far[2]), words(kx), words(ky), words(kz), sx};
  // clang-format on
  for (; j + 8 <= n; j += 8) {
    for (std::size_t part = 0; part < 3; ++part) {
      __m256 m[8];
      for (std::size_t i = 0; i < 8; ++i) m[i] = _mm256_load_ps(columns[8 * part + i] + j);
      transpose8(m);
      for (std::size_t i = 0; i < 8; ++i)
        _mm256_storeu_ps(reinterpret_cast<float*>(out + j + i) + 8 * part, m[i]);
    }
    for (std::size_t i = j; i < j + 8; ++i) {
      out[i].sy = sy[i], out[i].sz = sz[i];
      out[i].int_order = static_cast<IntOrder>(order[i]);
      out[i].robust_box = robust[i] != 0;
      out[i].mtn_in_double = in_double[i] != 0;
    }
  }
#endif
  for (; j < n; ++j) {
    WideRay& r = out[j];
    for (uint32_t axis = 0; axis < 3; ++axis) {
      r.org[axis] = o[axis][j];
      r.dir[axis] = d[axis][j];
      r.inv_dir[axis] = inv[axis][j];
      r.org_inv[axis] = org_inv[axis][j];
      r.near_plane[axis] = near[axis][j];
      r.far_plane[axis] = far[axis][j];
    }
    r.tmin = t0[j];
    r.tmax = t1[j];
    r.kx = kx[j], r.ky = ky[j], r.kz = kz[j];
    r.sx = sx[j], r.sy = sy[j], r.sz = sz[j];
    r.int_order = static_cast<IntOrder>(order[j]);
    r.robust_box = robust[j] != 0;
    r.mtn_in_double = in_double[j] != 0;
  }
  // A ray on the robust box test takes no integer path, so it does not lower the batch's.
  uint32_t any_robust = 0, lowest = static_cast<uint32_t>(IntOrder::kFree);
  for (std::size_t i = 0; i < n; ++i) {
    any_robust |= robust[i];
    lowest = std::min(lowest, robust[i] ? lowest : order[i]);
  }
  return WideRaysInfo{static_cast<IntOrder>(lowest), any_robust != 0};
}

template <bool kShear, bool kFma>
WideRaysInfo set_up_all(std::span<const Ray> rays, WideRay* out) {
  WideRaysInfo info{IntOrder::kFree, false};
  for (std::size_t first = 0; first < rays.size(); first += kSetupBlock) {
    const std::size_t n = std::min(kSetupBlock, rays.size() - first);
    const WideRaysInfo block = set_up_block<kShear, kFma>(rays.subspan(first, n), out + first);
    info.robust_box |= block.robust_box;
    info.int_order = std::min(info.int_order, block.int_order);
  }
  return info;
}

}  // namespace

WideRaysInfo make_wide_rays(std::span<const Ray> rays, WideRay* out, bool shear, BoxTestKind box) {
  const bool fma = box == BoxTestKind::kFma;
  if (shear) return fma ? set_up_all<true, true>(rays, out) : set_up_all<true, false>(rays, out);
  return fma ? set_up_all<false, true>(rays, out) : set_up_all<false, false>(rays, out);
}

WideRay make_wide_ray(const Ray& ray, bool shear, BoxTestKind box) {
  WideRay r;
  const bool fma = box == BoxTestKind::kFma;
  if (shear && fma)
    set_up<true, true>(ray, r);
  else if (shear)
    set_up<true, false>(ray, r);
  else if (fma)
    set_up<false, true>(ray, r);
  else
    set_up<false, false>(ray, r);
  return r;
}

BlockForm block_form_for(TriangleTestKind test) {
  switch (test) {
    case TriangleTestKind::kWatertight:
      return BlockForm::kVertices;
    case TriangleTestKind::kMollerTrumboreNormal:
      return BlockForm::kEdgesNormals;
    case TriangleTestKind::kMollerTrumbore:
    case TriangleTestKind::kMollerTrumboreNoEpsilon:
      break;
  }
  return BlockForm::kEdges;
}

template <uint32_t N>
WideBvh<N> compile_wide(const Bvh& bvh, std::span<const Triangle> triangles, BlockForm form) {
  if (bvh.arity > N)
    throw Error("layout bvh" + std::to_string(N) + " takes trees of arity " + std::to_string(N) +
                " or less; this tree has arity " + std::to_string(bvh.arity));
  WideBvh<N> out;
  out.form = form;
  if (bvh.nodes.empty()) return out;
  for (uint32_t ref : bvh.prim_refs)
    if (ref >= triangles.size())
      throw Error("layout bvh" + std::to_string(N) + ": reference " + std::to_string(ref) +
                  " is beyond the " + std::to_string(triangles.size()) + " triangles");
  for (uint32_t axis = 0; axis < 3; ++axis) {
    out.root_planes[2 * axis] = finite_or(bvh.root().bounds.min[axis], -kInf);
    out.root_planes[2 * axis + 1] = finite_or(bvh.root().bounds.max[axis], kInf);
  }

  // First the arena's order (wide_bvh.h), sequentially: where each wide node and each leaf's blocks go.
  // A wide node holds the children [first, first + count) of a common-format node; a root that is a leaf
  // gets a wide node of its own, holding just it.
  struct WidePlan {
    uint32_t first, count, depth;
    uint32_t ref;  // the wide node's place in the arena
  };
  constexpr uint64_t kNodeUnits = sizeof(WideNode<N>) / kWideUnit;
  const uint64_t units_per_block = block_units(form);
  std::vector<WidePlan> plan;
  std::vector<uint32_t> ref_of(bvh.nodes.size(), 0);  // a common-format node's wide node or first block
  uint64_t used = 0;
  auto add_node = [&](uint32_t first, uint32_t count, uint32_t depth) {
    used = (used + 1) & ~uint64_t{1};  // 64-byte line
    plan.push_back({first, count, depth, static_cast<uint32_t>(used)});
    used += kNodeUnits;
    return plan.back().ref;
  };
  if (bvh.root().is_leaf())
    add_node(0, 1, 0);
  else
    add_node(bvh.root().first, bvh.root().child_count, 0);
  std::vector<std::size_t> stack{0};
  while (!stack.empty()) {
    const WidePlan p = plan[stack.back()];
    stack.pop_back();
    // The kernels' stack holds (N - 1) kMaxDepth + 1 entries (wide_kernels.inl), enough for wide nodes
    // at depths 0 .. kMaxDepth - 1.
    if (p.depth >= kMaxDepth)
      throw Error("layout bvh" + std::to_string(N) + ": the tree is deeper than " +
                  std::to_string(kMaxDepth) + " levels");
    for (uint32_t c = p.first; c < p.first + p.count; ++c) {
      if (!bvh.nodes[c].is_leaf()) continue;
      ref_of[c] = static_cast<uint32_t>(used);
      out.block_count += blocks_for(bvh.nodes[c].prim_count);
      used += blocks_for(bvh.nodes[c].prim_count) * units_per_block;
    }
    const std::size_t first_child = plan.size();
    for (uint32_t c = p.first; c < p.first + p.count; ++c) {
      const Node& child = bvh.nodes[c];
      if (!child.is_leaf()) ref_of[c] = add_node(child.first, child.child_count, p.depth + 1);
    }
    // Depth first, first child next.
    for (std::size_t i = plan.size(); i > first_child; --i) stack.push_back(i - 1);
    if (used > std::numeric_limits<uint32_t>::max())
      throw Error("layout bvh" + std::to_string(N) + ": the tree needs more than 128 GiB");
  }

  // Then the nodes and blocks themselves, in parallel.
  out.arena.resize(used);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, plan.size(), 64),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i < r.end(); ++i) {
                        WideNode<N> node = empty_node<N>();
                        for (uint32_t slot = 0; slot < plan[i].count; ++slot) {
                          const uint32_t c = plan[i].first + slot;
                          const Node& child = bvh.nodes[c];
                          set_box(node, slot, child.bounds);
                          node.child[slot] = ref_of[c];
                          if (!child.is_leaf()) continue;
                          node.count[slot] = blocks_for(child.prim_count);
                          fill_blocks(std::span(bvh.prim_refs).subspan(child.first, child.prim_count),
                                      triangles, form, out.arena.data() + ref_of[c]);
                        }
                        out.node(plan[i].ref) = node;
                      }
                    });
  out.node_count = plan.size();
  return out;
}

namespace {

// Parallel tasks per thread at the top of the tree, as in core/refit.cpp: enough that a lopsided
// tree still balances, few enough that spawning stays small next to the refit.
constexpr int kRefitTasksPerThread = 16;

// Post-order over the wide nodes, as refit() walks the common format: a slot's box is the union of its
// leaf's triangles (rewritten into the leaf's blocks on the way) or of its child node's slots, refitted
// first. Slots below `spawn_depth` are refitted on the calling thread, so each task is a whole subtree
// and a single thread pays nothing for the parallel path (the level-by-level pass this replaces ran one
// parallel_for per level and kept a list of nodes per level). Most of the time goes into rewriting the
// blocks' vertices, which the common format's refit does not have.
template <uint32_t N>
class WideRefitter {
 public:
  WideRefitter(WideBvh<N>& wide, std::span<const Triangle> triangles, uint32_t spawn_depth)
      : wide_(wide), triangles_(triangles.data()), spawn_depth_(spawn_depth) {}

  Aabb refit(uint32_t ref, uint32_t depth) const {
    WideNode<N>& node = wide_.node(ref);
    std::array<Aabb, N> boxes;
    auto refit_slot = [&](uint32_t i) {
      if (node.count[i] != 0)
        boxes[i] = refit_leaf(node.child[i], node.count[i]);
      else if (node.child[i] != 0)
        boxes[i] = refit(node.child[i], depth + 1);  // 0: empty (no child is the root)
    };
    if (depth < spawn_depth_) {
      tbb::parallel_for(uint32_t{0}, N, refit_slot);
    } else {
      for (uint32_t i = 0; i < N; ++i) refit_slot(i);
    }
    Aabb box = Aabb::empty();
    for (uint32_t i = 0; i < N; ++i) {
      if (node.count[i] == 0 && node.child[i] == 0) continue;
      set_box(node, i, boxes[i]);
      box.extend(boxes[i]);
    }
    return box;
  }

 private:
  Aabb refit_leaf(uint32_t first, uint32_t count) const {
    Aabb box = Aabb::empty();
    for (uint32_t b = 0; b < count; ++b) {
      TriangleBlock* block = &wide_.block(first, b);
      for (uint32_t lane = 0; lane < kBlockWidth; ++lane) {
        if (block->prim[lane] == kInvalidPrim) continue;
        const Triangle& t = triangles_[block->prim[lane]];
        set_lane(*block, lane, t, wide_.form);
        box.extend(t.bounds());
      }
    }
    return box;
  }

  WideBvh<N>& wide_;
  const Triangle* triangles_;
  uint32_t spawn_depth_;
};

}  // namespace

template <uint32_t N>
void refit_wide(WideBvh<N>& wide, std::span<const Triangle> triangles) {
  if (wide.empty()) return;
  const int threads = tbb::this_task_arena::max_concurrency();
  uint32_t spawn_depth = 0;
  if (threads > 1)
    spawn_depth = static_cast<uint32_t>(
        std::ceil(std::log(double(threads) * kRefitTasksPerThread) / std::log(double(N))));
  const Aabb root = WideRefitter<N>(wide, triangles, spawn_depth).refit(0, 0);
  for (uint32_t axis = 0; axis < 3; ++axis) {
    wide.root_planes[2 * axis] = finite_or(root.min[axis], -kInf);
    wide.root_planes[2 * axis + 1] = finite_or(root.max[axis], kInf);
  }
}

template WideBvh<4> compile_wide<4>(const Bvh&, std::span<const Triangle>, BlockForm);
template WideBvh<8> compile_wide<8>(const Bvh&, std::span<const Triangle>, BlockForm);
template void refit_wide<4>(WideBvh<4>&, std::span<const Triangle>);
template void refit_wide<8>(WideBvh<8>&, std::span<const Triangle>);

WideKernel find_wide_kernel(KernelIsa isa, uint32_t width, const KernelVariant& variant, bool any_hit,
                            bool counting) {
  if (isa == KernelIsa::kScalar)
    return detail::wide_kernel_scalar(width, variant.triangle, variant.box, any_hit, counting);
  if (counting) return nullptr;
#if defined(SAHBENCH_HAVE_X86_KERNELS)
  switch (isa) {
    case KernelIsa::kSse:
      return detail::wide_kernel_sse(width, variant.triangle, variant.box, any_hit);
    case KernelIsa::kAvx2:
      return detail::wide_kernel_avx2(width, variant.triangle, variant.box, any_hit);
    case KernelIsa::kAvx512:
      return detail::wide_kernel_avx512(width, variant.triangle, variant.box, any_hit);
    default:
      break;
  }
#endif
  return nullptr;
}

WideKernel find_wide_packet_kernel(KernelIsa isa, uint32_t width, const KernelVariant& variant, bool any_hit,
                                   uint32_t packet) {
#if defined(SAHBENCH_HAVE_X86_KERNELS)
  if (isa == KernelIsa::kAvx2)
    return detail::wide_packet_kernel_avx2(width, variant.triangle, variant.box, any_hit, packet);
  if (isa == KernelIsa::kAvx512)
    return detail::wide_packet_kernel_avx512(width, variant.triangle, variant.box, any_hit, packet);
#endif
  return nullptr;
}

WideBenchLoops find_wide_bench_loops(KernelIsa isa, uint32_t width, const KernelVariant& v) {
  switch (isa) {
    case KernelIsa::kScalar:
      return detail::wide_bench_loops_scalar(width, v.triangle, v.box);
#if defined(SAHBENCH_HAVE_X86_KERNELS)
    case KernelIsa::kSse:
      return detail::wide_bench_loops_sse(width, v.triangle, v.box);
    case KernelIsa::kAvx2:
      return detail::wide_bench_loops_avx2(width, v.triangle, v.box);
    case KernelIsa::kAvx512:
      return detail::wide_bench_loops_avx512(width, v.triangle, v.box);
#endif
    default:
      return {};
  }
}

}  // namespace sahbench
