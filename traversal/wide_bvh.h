#pragma once
// The 4- and 8-wide layouts: a common-format tree of arity <= N compiled into nodes whose N child boxes
// are stored as structure of arrays, so one SIMD instruction tests a ray against all of them (Wald,
// Benthin and Boulos 2008, "Getting Rid of Packets"; Ernst and Greiner 2008, "Multi Bounding Volume
// Hierarchies"; Embree's BVH4/BVH8 AABB nodes), and leaves whose triangles are packed four at a time,
// vertex components as arrays, for 4-wide triangle tests.
//
// Node formats (bytes per node; both are multiples of a 64-byte cache line):
//   WideNode<4>: planes[6][4] floats (96) + child[4] (16) + count[4] (16)  = 128 bytes
//   WideNode<8>: planes[6][8] floats (192) + child[8] (32) + count[8] (32) = 256 bytes
// planes[] holds min x, max x, min y, max y, min z, max z of each child, so a ray picks its near and
// far plane per axis by index (2 axis + sign). A child slot is
//   inner: count = 0, child = reference of its WideNode;
//   leaf:  count = number of blocks (TriangleBlocks, or NormalBlocks for tri=mtn), child = reference of
//          the first (the others follow it);
//   empty: count = 0, child = 0, and an inverted box (min +inf, max -inf) that no ray can enter.
// TriangleBlock: v0, v1, v2 as [component][lane] floats (144) + prim[4] (16) = 160 bytes per 4 triangles;
// unused lanes have prim = kInvalidPrim and NaN vertices, which no test can hit. In the edge form, which
// the Möller–Trumbore layouts use, v1 and v2 hold the edges v1 - v0 and v2 - v0 instead (BlockForm).
// NormalBlock (tri=mtn): a TriangleBlock in edge form + the normals e1 x e2 as [component][lane] floats
// (48) + a lane mask and 12 unused bytes = 224 bytes per 4 triangles, as Embree's Triangle4 stores v0,
// e1, e2 and Ng.
//
// Nodes and blocks share one array, the arena, and a reference counts 32-byte units from its start.
// Its order is depth first, as a recursive builder allocating from one pool lays out its tree (Embree's
// BVH builders with their FastAllocator): the root; then, on entering a node, the blocks of its leaf
// slots, its child nodes side by side, and each child's part in turn. Nodes start on a 64-byte line.
// A ray going down the tree so reads forward through memory, and a subtree's nodes and triangles share
// pages. With nodes and blocks in two arrays the layouts traced 1-3% slower; the arena is also advised
// for huge pages (core/huge_pages.h), which took 6-10% more on a 1M-triangle scene.
//
// This header and wide_kernels.inl are also compiled for each SIMD instruction set
// (wide_kernels_*.cpp), so the types here are plain data: no functions a kernel might share with
// another instruction set's translation unit (the kernels call none of WideBvh's accessors).

#include <cassert>
#include <cstdint>
#include <span>
#include <vector>

#include "core/bvh.h"
#include "core/huge_pages.h"
#include "core/ray.h"
#include "core/triangle.h"
#include "traversal/kernel_variant.h"

namespace sahbench {

template <uint32_t N>
struct alignas(64) WideNode {
  float planes[6][N];
  uint32_t child[N];
  uint32_t count[N];
};
static_assert(sizeof(WideNode<4>) == 128 && sizeof(WideNode<8>) == 256, "node formats as documented");

/// Triangles tested together by the 4-wide triangle kernels.
inline constexpr uint32_t kBlockWidth = 4;
/// A block's lanes as the low bits of a mask.
inline constexpr uint32_t kBlockLanes = (1u << kBlockWidth) - 1;

/// What a TriangleBlock's v1 and v2 hold. The Möller–Trumbore test starts from the edges v1 - v0 and
/// v2 - v0; stored once at compile time (as Embree's Triangle4 stores e1 and e2), they are the same
/// floats the test would compute, so its hits are unchanged, and each block test is six subtractions
/// per lane shorter: 1-4% more rays/second on Sponza and the 1M terrain (A/B, 3 rounds, `bvh8:tri=mt0,
/// box=fma`), the bunny and the dragon within 1% either way.
/// The watertight test needs the vertices themselves: v0 + (v1 - v0) is not v1 in float.
enum class BlockForm : uint8_t {
  kVertices,      ///< v1, v2 are the triangle's second and third vertices
  kEdges,         ///< v1, v2 are the edges v1 - v0 and v2 - v0
  kEdgesNormals,  ///< kEdges in a NormalBlock, with each triangle's normal (stored_normal, triangle_tests.h)
};

/// The form the kernels of triangle test `test` read.
BlockForm block_form_for(TriangleTestKind test);

struct alignas(16) TriangleBlock {
  float v0[3][kBlockWidth];
  float v1[3][kBlockWidth];
  float v2[3][kBlockWidth];
  uint32_t prim[kBlockWidth];
};
static_assert(sizeof(TriangleBlock) == 160, "block format as documented");

/// The block of BlockForm::kEdgesNormals: MollerTrumboreNormalTest reads the normal where the other
/// Möller–Trumbore tests compute a second cross product. `in_double` has bit i set when lane i's triangle
/// is outside the float test's range (triangle_tests.h: mtn_triangle_in_range), so that the kernels test
/// it in double as the scalar test does; the rest of the last 16 bytes keeps blocks whole arena units.
struct alignas(16) NormalBlock {
  TriangleBlock tri;  ///< in edge form
  float normal[3][kBlockWidth];
  uint32_t in_double;
  uint32_t unused[kBlockWidth - 1];
};
static_assert(sizeof(NormalBlock) == 224, "block format as documented");

/// A ray as the wide kernels read it, set up once per ray outside the kernels (wide_bvh.cpp): origin,
/// direction, reciprocal direction and origin times it, the
/// near and far plane index per axis (chosen by the sign bit, so -0 counts as negative, as in
/// ray_box.h), and the watertight test's shear (triangle_tests.h).
///
/// IntOrder: whether the box=fma kernels for AVX2 and AVX-512 may take the maximum and minimum of a
/// ray's slab distances, and compare them, on the floats' bits as integers (wide_kernels.inl: kInt),
/// which order as the floats do when no distance is negative zero and the interval starts at +0 or later.
/// - kFree: tmin is +0 or positive, tmax is not negative, and |org_inv| is in [2^-100, inf) on each axis
///   (inv_dir is finite and non-zero for the rays box=fma takes, FmaRayBox::takes): no slab distance is
///   -0 or NaN.
/// - kGuarded: the same but for some |org_inv| below 2^-100 (an origin on or near a coordinate plane):
///   a distance below 2^-150 in magnitude may round to -0, and the kernels test the nodes where it does
///   again on the float path.
/// - kNone: the float path (tmin negative or -0, tmax negative, an origin so far out that org * inv
///   overflows).
enum class IntOrder : uint8_t { kNone, kGuarded, kFree };

struct WideRay {
  float org[3];
  float dir[3];
  float inv_dir[3];
  float org_inv[3];
  float tmin, tmax;
  uint32_t near_plane[3];
  uint32_t far_plane[3];
  uint32_t kx, ky, kz;
  float sx, sy, sz;
  /// box=fma only: whether the AVX2 and AVX-512 kernels may order this ray's slab distances by their
  /// bits as integers (IntOrder).
  IntOrder int_order;
  /// box=fma only: the ray is outside the fma test's domain (FmaRayBox::takes) and takes the robust box
  /// test, as the binary kernels do.
  bool robust_box;
  /// tri=mtn: the ray is outside the float test's range (triangle_tests.h: mtn_ray_in_range), and every
  /// lane is tested in double.
  bool mtn_in_double;
};

/// What the kernels need to know of a batch of set-up rays: the lowest of their WideRay::int_order, and
/// whether any takes the robust box test.
struct WideRaysInfo {
  IntOrder int_order;
  bool robust_box;
};

/// `shear`: also the watertight test's shear; the Möller–Trumbore kernels do not read it, and leaving it
/// out takes 3 divisions and a branchy axis choice off every ray. `box`: the box test the ray is for.
WideRay make_wide_ray(const Ray& ray, bool shear = true, BoxTestKind box = BoxTestKind::kRobust);
/// make_wide_ray for each of `rays`, into out[0, rays.size()): what the layouts call, with the choices
/// made once per batch rather than once per ray, and the same bits computed for blocks of rays at once.
WideRaysInfo make_wide_rays(std::span<const Ray> rays, WideRay* out, bool shear, BoxTestKind box);

/// The arena's unit (wide_bvh.h): references to nodes and blocks count these from the arena's start.
inline constexpr std::size_t kWideUnit = 32;
struct alignas(kWideUnit) WideUnit {
  unsigned char bytes[kWideUnit];
};
static_assert(sizeof(TriangleBlock) % kWideUnit == 0 && sizeof(NormalBlock) % kWideUnit == 0 &&
                  sizeof(WideNode<4>) % kWideUnit == 0,
              "blocks and nodes are whole units");

/// The arena units of one block in `form`.
constexpr uint32_t block_units(BlockForm form) {
  return (form == BlockForm::kEdgesNormals ? sizeof(NormalBlock) : sizeof(TriangleBlock)) / kWideUnit;
}

/// A compiled wide tree. The root node is at reference 0 (always an inner node: a tree that is a single
/// leaf gets a root with one leaf slot); children come after their parents.
template <uint32_t N>
struct WideBvh {
  /// The root's box as six planes (min x, max x, min y, ...): tested first, so rays that miss the scene
  /// cost one box test, and so the kernels visit exactly the nodes bvh2_traversal.h visits on the same tree.
  float root_planes[6] = {};
  std::vector<WideUnit, HugePageAllocator<WideUnit>> arena;
  std::size_t node_count = 0;
  std::size_t block_count = 0;
  BlockForm form = BlockForm::kVertices;

  bool empty() const { return arena.empty(); }
  std::size_t bytes() const { return arena.size() * sizeof(WideUnit); }
  WideNode<N>& node(uint32_t ref) { return *reinterpret_cast<WideNode<N>*>(arena.data() + ref); }
  const WideNode<N>& node(uint32_t ref) const {
    return *reinterpret_cast<const WideNode<N>*>(arena.data() + ref);
  }
  /// Block `i` of the leaf whose first block is at `ref` (in every form; a NormalBlock starts with it).
  TriangleBlock& block(uint32_t ref, uint32_t i = 0) {
    return *reinterpret_cast<TriangleBlock*>(arena.data() + ref + i * block_units(form));
  }
  const TriangleBlock& block(uint32_t ref, uint32_t i = 0) const {
    return *reinterpret_cast<const TriangleBlock*>(arena.data() + ref + i * block_units(form));
  }
  /// The same block as a NormalBlock: form kEdgesNormals only.
  NormalBlock& normal_block(uint32_t ref, uint32_t i = 0) {
    assert(form == BlockForm::kEdgesNormals);
    return reinterpret_cast<NormalBlock&>(block(ref, i));
  }
  const NormalBlock& normal_block(uint32_t ref, uint32_t i = 0) const {
    assert(form == BlockForm::kEdgesNormals);
    return reinterpret_cast<const NormalBlock&>(block(ref, i));
  }
};

/// Compiles `bvh` (arity <= N) over `triangles`, blocks in `form` (block_form_for the layout's triangle
/// test). Throws Error for a wider or deeper tree than the kernels take (arity > N, depth > kMaxDepth) or
/// a leaf reference out of range.
template <uint32_t N>
WideBvh<N> compile_wide(const Bvh& bvh, std::span<const Triangle> triangles,
                        BlockForm form = BlockForm::kVertices);

/// Refit: copies the new positions of `triangles` (same indices as at compile time) into the blocks and
/// recomputes every child box bottom up, subtrees near the root in parallel. The topology is
/// kept, so the tree may lose quality as the geometry moves (configs/animation.toml measures refit against
/// rebuild).
template <uint32_t N>
void refit_wide(WideBvh<N>& wide, std::span<const Triangle> triangles);

extern template WideBvh<4> compile_wide<4>(const Bvh&, std::span<const Triangle>, BlockForm);
extern template WideBvh<8> compile_wide<8>(const Bvh&, std::span<const Triangle>, BlockForm);
extern template void refit_wide<4>(WideBvh<4>&, std::span<const Triangle>);
extern template void refit_wide<8>(WideBvh<8>&, std::span<const Triangle>);

/// Work counted by the counting kernels (summed over a batch).
struct WideCounts {
  uint64_t rays = 0;
  uint64_t inner_visits = 0;  ///< wide nodes whose child boxes were tested
  uint64_t leaf_visits = 0;   ///< leaves whose triangles were tested
  uint64_t prim_tests = 0;    ///< triangles tested (occupied lanes)
};

/// One call of a kernel: `count` rays, answers into `hits` (closest) or `occluded` (any hit), work into
/// `counts` (counting kernels only).
struct WideBatch {
  const float* root_planes;  ///< WideBvh::root_planes
  const WideUnit* arena;     ///< WideBvh::arena
  const WideRay* rays;
  std::size_t count;
  Hit* hits;
  uint8_t* occluded;
  WideCounts* counts;
  /// The order in which any hit visits children (not kAuto), resolved by the layout from its anyhit
  /// option and the tree (bvh2_traversal.h: resolve_any_hit_order).
  AnyHitOrder any_hit_order;
  /// The lowest of the rays' WideRay::int_order (make_wide_rays' answer): the path the box=fma kernels
  /// take for the batch.
  IntOrder int_order = IntOrder::kNone;
  /// box=fma: some rays take the robust box test (WideRay::robust_box).
  bool robust_box = false;
  /// Any hit: test first where the last ray to the same end point found its hit (wide_kernels.inl:
  /// ShadowCache; LayoutSpec::shadow_cache).
  bool shadow_cache = false;
  /// For the tests: where set, [0] counts the rays the shadow cache settled by its leaf, [1] those it
  /// settled by the leaf's subtree.
  std::size_t* shadow_cache_settled = nullptr;
};

using WideKernel = void (*)(const WideBatch&);

/// The kernel for a width, variant and query, compiled for `isa` (not kAuto). Counting kernels exist for
/// kScalar only: every instruction set computes the same distances and visits nodes in the same order,
/// so the counts are the same. Null when that combination is not compiled in.
WideKernel find_wide_kernel(KernelIsa isa, uint32_t width, const KernelVariant& variant, bool any_hit,
                            bool counting);

/// The packet kernel (wide_packets.inl: `packet` rays at a time, 8 or 16) for a width, variant and query,
/// compiled for `isa`: kAvx2 (8) or kAvx512 (8 and 16). Null for another instruction set, packet width or
/// a combination not compiled in.
WideKernel find_wide_packet_kernel(KernelIsa isa, uint32_t width, const KernelVariant& variant, bool any_hit,
                                   uint32_t packet);

/// Micro-benchmark loops (bench/): `ray_count` rays each against `count` nodes (of the width asked) or
/// triangle blocks in turn, returning a checksum.
struct WideBenchLoops {
  double (*nodes)(const void* nodes, std::size_t count, const WideRay* rays, std::size_t ray_count);
  /// `blocks`: `count` consecutive blocks of the form block_form_for(the variant's triangle test).
  double (*blocks)(const void* blocks, std::size_t count, const WideRay* rays, std::size_t ray_count);
  /// For the tests: one node of the width asked against one ray, on the path the kernels take for it.
  /// Returns the hit mask and writes each slot's entry distance to t_entry[0, width).
  uint32_t (*node)(const void* node, const WideRay& ray, float* t_entry);
};

/// The loops compiled for `isa` (not kAuto); all null when that set is not compiled in.
WideBenchLoops find_wide_bench_loops(KernelIsa isa, uint32_t width, const KernelVariant& variant);

}  // namespace sahbench
