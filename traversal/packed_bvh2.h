#pragma once
// bvh2_packed: a binary tree compiled for tracing. Every inner node is one 64-byte line that holds its two
// children's boxes plane by plane, and what each child is (an inner node's index, or a leaf's triangles):
// the node layout of Aila and Laine 2009 ("Understanding the Efficiency of Ray Traversal on GPUs"), which
// tinybvh's BVH_SoA brings to CPUs. A step down the tree then reads one line and tests both children in one
// SIMD pass, where the common format reads the parent for its children's index and then the children for
// their boxes: two dependent loads per step, which is what the binary kernel on the common format waits on.
//
// The box tests are the ones of ray_box.h, lane by lane: the same IEEE operations on the same planes and
// the same NaN rule, so the kernel visits the nodes the common-format kernel visits, in the same order,
// but for closest hit's order of two children entered at one distance (PackedWalk), and the layout tests
// hold it to the general loop in that order. A leaf's triangles are tested four at a time
// (triangle_lanes.h), with the same answers as one at a time (test_leaf).

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <memory>
#include <span>
#include <type_traits>
#include <vector>

#include "core/aabb.h"
#include "core/bvh.h"
#include "core/huge_pages.h"
#include "core/ray.h"
#include "core/triangle.h"
#include "traversal/bvh2_traversal.h"
#include "traversal/layout.h"
#include "traversal/ray_box.h"
#include "traversal/triangle_lanes.h"
#include "traversal/triangle_tests.h"

#if defined(__SSE4_1__)
#include <immintrin.h>
#endif

namespace sahbench {

/// An inner node of bvh2_packed: its children's boxes and what they are.
struct alignas(64) PairNode {
  /// planes[axis] = (left min, right min, left max, right max) on that axis.
  float planes[3][4];
  /// Per child: an inner child's PairNode index, or a leaf's first triangle in leaf order.
  uint32_t child[2];
  /// Per child: 0 for an inner node, else the leaf's triangle count (never 0: core/bvh.h).
  uint32_t count[2];

  Aabb box(int c) const {
    return {{planes[0][c], planes[1][c], planes[2][c]},
            {planes[0][c + 2], planes[1][c + 2], planes[2][c + 2]}};
  }
  void set_box(int c, const Aabb& b) {
    for (int axis = 0; axis < 3; ++axis) {
      planes[axis][c] = b.min[static_cast<std::size_t>(axis)];
      planes[axis][c + 2] = b.max[static_cast<std::size_t>(axis)];
    }
  }
};
static_assert(sizeof(PairNode) == 64, "a PairNode is one cache line");

/// A binary tree in PairNodes, its triangles copied into leaf order.
struct PackedBvh2 {
  // On huge pages from 2 MiB (core/huge_pages.h), as the wide layouts' arena and Embree's trees: a walk
  // reads lines all over these arrays, and on small pages the large scenes' walks miss the TLB.
  std::vector<PairNode, HugePageAllocator<PairNode>> nodes;      ///< depth first: inner children after it
  std::vector<Triangle, HugePageAllocator<Triangle>> triangles;  ///< in leaf order
  std::vector<uint32_t, HugePageAllocator<uint32_t>> ids;        ///< scene index of each packed triangle
  Aabb root_box;
  uint32_t root = 0;        ///< the root: a PairNode index, or (a tree that is one leaf) its first triangle
  uint32_t root_count = 0;  ///< 0 when the root is an inner node, else its triangle count
  bool empty = true;        ///< no nodes at all: every ray misses

  /// Compiles a valid binary tree over `triangles`: nodes depth first, left subtrees before right ones
  /// and a node's two inner children side by side, so that a ray going down the tree reads lines close
  /// in memory whatever order the builder wrote them in; a leaf's triangles are copied where its parent
  /// is laid out, so they follow the same order.
  static PackedBvh2 compile(const Bvh& bvh, std::span<const Triangle> triangles);

  /// New positions of the same triangles (scene order): every box recomputed bottom up.
  void refit(std::span<const Triangle> scene_triangles);

  std::size_t bytes() const {
    return nodes.size() * sizeof(PairNode) + triangles.size() * sizeof(Triangle) +
           ids.size() * sizeof(uint32_t);
  }
};

namespace detail {

/// Both children of a PairNode against one ray, with the operations of the box test `Box` (RobustRayBox,
/// FastRayBox or FmaRayBox) lane by lane. Near planes are picked by the direction's sign bit, as
/// SlabSetup does, by swapping the min and max halves of an axis's planes where the direction is negative.
/// The far distances are negated so that one max per axis clamps both ends of the interval: max(-t1,
/// -tmax) is -min(t1, tmax) exactly, and `_mm_max_ps(t, interval)` returns the interval's bound for a NaN t,
/// which is the slab tests' NaN rule (an origin on a face plane of a zero-direction axis is inside that
/// slab).
template <class Box>
class PairSlabs {
 public:
#if defined(__SSE4_1__)
  /// A ray's interval as intersect() takes it: (tmin, tmin, -tmax, -tmax), made once per change of tmax
  /// rather than once per node.
  using Interval = __m128;
  static Interval interval(float tmin, float tmax) {
    return _mm_setr_ps(tmin, tmin, -tmax, -tmax);
  }

  explicit PairSlabs(const Ray& ray) {
    const SlabSetup setup(ray);
    for (int axis = 0; axis < 3; ++axis) {
      const auto a = static_cast<std::size_t>(axis);
      org_[axis] = _mm_set1_ps(setup.org[a]);
      inv_[axis] = _mm_set1_ps(setup.inv_dir[a]);
      org_inv_[axis] = _mm_set1_ps(setup.org[a] * setup.inv_dir[a]);
      near_far_[axis] = setup.negative[a]
                            ? _mm_setr_epi8(8, 9, 10, 11, 12, 13, 14, 15, 0, 1, 2, 3, 4, 5, 6, 7)
                            : _mm_setr_epi8(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    }
  }
#else
  struct Interval {
    float tmin, tmax;
  };
  static Interval interval(float tmin, float tmax) {
    return {tmin, tmax};
  }

  explicit PairSlabs(const Ray& ray) : box_(ray) {}
#endif

  /// Bit 0: the left child is met within `interval`, bit 1: the right one; their entry distances in
  /// t_left and t_right, their exit distances in e_left and e_right.
  [[gnu::always_inline]] unsigned intersect(const PairNode& node, const Interval& interval, float& t_left,
                                            float& t_right, float& e_left, float& e_right) const {
#if defined(__SSE4_1__)
    __m128 m = axis_distances(node, 0);
    m = _mm_max_ps(m, interval);
    m = _mm_max_ps(m, _mm_max_ps(axis_distances(node, 1), interval));
    m = _mm_max_ps(m, _mm_max_ps(axis_distances(node, 2), interval));
    // Lanes 0 and 1: entry distances; lanes 2 and 3: minus the exit distances.
    const __m128 exit = _mm_xor_ps(_mm_shuffle_ps(m, m, _MM_SHUFFLE(3, 2, 3, 2)), _mm_set1_ps(-0.0f));
    t_left = _mm_cvtss_f32(m);
    t_right = _mm_cvtss_f32(_mm_shuffle_ps(m, m, _MM_SHUFFLE(1, 1, 1, 1)));
    e_left = _mm_cvtss_f32(exit);
    e_right = _mm_cvtss_f32(_mm_shuffle_ps(exit, exit, _MM_SHUFFLE(1, 1, 1, 1)));
    return static_cast<unsigned>(_mm_movemask_ps(_mm_cmple_ps(m, exit))) & 3u;
#else
    return unsigned(box_.intersect(node.box(0), interval.tmin, interval.tmax, t_left, e_left)) |
           unsigned(box_.intersect(node.box(1), interval.tmin, interval.tmax, t_right, e_right)) << 1;
#endif
  }

 private:
#if defined(__SSE4_1__)
  // (left near, right near, -left far, -right far) on `axis`, before clamping to the interval. The near
  // planes are put first by one byte shuffle (SSSE3, so every x86 kernel that has SSE4.1 takes the same
  // path) whose control the ray's direction fixes (near_far_), where a blend by the sign would take a
  // compare and a blend at every node.
  [[gnu::always_inline]] __m128 axis_distances(const PairNode& node, int axis) const {
    const __m128 planes = _mm_castsi128_ps(_mm_shuffle_epi8(
        _mm_load_si128(reinterpret_cast<const __m128i*>(node.planes[axis])), near_far_[axis]));
    const __m128 far_sign = _mm_setr_ps(0.0f, 0.0f, -0.0f, -0.0f);
    if constexpr (std::is_same_v<Box, FmaRayBox>) {
#if defined(__FMA__)
      return _mm_xor_ps(_mm_fmsub_ps(planes, inv_[axis], org_inv_[axis]), far_sign);
#else
      alignas(16) float p[4], t[4];
      _mm_store_ps(p, planes);
      for (int i = 0; i < 4; ++i) t[i] = std::fma(p[i], inv_[axis][0], -org_inv_[axis][0]);
      return _mm_xor_ps(_mm_load_ps(t), far_sign);
#endif
    } else {
      const __m128 t = _mm_mul_ps(_mm_sub_ps(planes, org_[axis]), inv_[axis]);
      if constexpr (std::is_same_v<Box, RobustRayBox>) {
        // Ize's scaling of the far distances (RobustRayBox), and their sign, in one product.
        constexpr float s = RobustRayBox::kFarScale;
        return _mm_mul_ps(t, _mm_setr_ps(1.0f, 1.0f, -s, -s));
      } else {
        return _mm_xor_ps(t, far_sign);
      }
    }
  }
#endif

#if defined(__SSE4_1__)
  __m128 org_[3], inv_[3], org_inv_[3];
  __m128i near_far_[3];  // per axis: the byte shuffle that puts the near planes first
#else
  Box box_;  // the scalar test, where SSE4.1 is not there
#endif
};

// The while-while loop of BinaryWalk (bvh2_traversal.h) on PairNodes, one step at a time: the same
// visits in the same order, with a child's box read from its parent's line and a leaf's triangles reached
// without a node, but for closest hit's order of two children entered at one distance. A step is one
// inner node, or one leaf and the pops after it, so that several walks can be stepped in turn
// (trace_walks, bvh2_traversal.h).
//
// Children entered at one distance: closest hit takes first the one the ray leaves first
// (ClosestTies::kExitFirst), where BinaryWalk takes the second. Such ties are the boxes a ray starts
// inside (a camera inside the scene, a ray leaving a surface), where both entry distances are tmin; of
// two such boxes, the one left first holds what lies nearer along the ray, whichever way the ray looks (a
// fixed slot, as in tinybvh's BVH::Intersect, suits only rays that look one way along the split axes).
// The exit distances are the pair test's own lanes. BinaryWalk keeps the slot: there the same order
// traced scenes with few such ties slower than it saved (cde00b1).
template <class TriangleTest, class BoxTest, bool kAnyHit, bool kCount>
class PackedWalk {
 public:
  PackedWalk(const PackedBvh2& tree, const Ray& ray, [[maybe_unused]] TraversalCounters* counters,
             AnyHitOrder any_order)
      : slabs_(ray),
        leaf_test_(ray),
        nodes_(tree.nodes.data()),
        triangles_(tree.triangles.data()),
        ids_(tree.ids.data()),
        counters_(counters),
        any_order_(any_order),
        tmin_(ray.tmin),
        best_t_(far_limit(ray)),
        interval_(PairSlabs<BoxTest>::interval(tmin_, best_t_)),
        current_(tree.root),
        count_(tree.root_count) {
    if constexpr (kCount) ++counters_->rays;
    if (tree.empty || !traceable(ray)) return;
    if constexpr (kCount) ++counters_->box_tests;
    float t_root;
    active_ = BoxTest(ray).intersect(tree.root_box, tmin_, best_t_, t_root);
  }

  /// Whether the walk has steps left; once false, hit() is its answer.
  bool active() const { return active_; }
  const Hit& hit() const { return best_; }

  /// One step; returns active().
  [[gnu::always_inline]] bool step() {
    if (count_ == 0) {
      if constexpr (kCount) {
        ++counters_->inner_visits;
        counters_->box_tests += 2;
      }
      const PairNode& node = nodes_[current_];
      float t0, t1, e0, e1;
      const unsigned hits = slabs_.intersect(node, interval_, t0, t1, e0, e1);
      if (hits == 3) {
        bool second_first = kAnyHit ? !(t0 < t1) : second_goes_first<ClosestTies::kExitFirst>(t0, t1, e0, e1);
        if constexpr (kAnyHit) {
          if (any_order_ == AnyHitOrder::kStored) second_first = false;
          if (any_order_ == AnyHitOrder::kNearestStored) second_first = t1 < t0;
          if (any_order_ == AnyHitOrder::kFarthestStored) second_first = t1 > t0;
        }
        if (size_ == kStackCapacity) [[unlikely]]
          throw_stack_overflow(current_, 2);
        // The nearer child as an index, as BinaryWalk takes it.
        const uint32_t near = second_first ? 1u : 0u;
        stack_[size_++] = {node.child[near ^ 1u], node.count[near ^ 1u], std::max(t0, t1)};
        current_ = node.child[near];
        count_ = node.count[near];
        return true;
      }
      if (hits != 0) {
        const unsigned c = hits >> 1;
        current_ = node.child[c];
        count_ = node.count[c];
        return true;
      }
    } else {
      if constexpr (kCount) {
        ++counters_->leaf_visits;
        counters_->prim_tests += count_;
      }
      if (test_leaf<kAnyHit, TriangleTest>(leaf_test_, PackedLeaf{triangles_, ids_, current_, count_}, tmin_,
                                           best_t_, best_))
        return active_ = false;  // an any-hit query's hit
      if constexpr (!kAnyHit) interval_ = PairSlabs<BoxTest>::interval(tmin_, best_t_);
    }
    do {
      if (size_ == 0) return active_ = false;
      --size_;
    } while (!kAnyHit && stack_[size_].t_entry > best_t_);
    current_ = stack_[size_].index;
    count_ = stack_[size_].count;
    return true;
  }

 private:
  struct Entry {
    uint32_t index, count;
    float t_entry;
  };

  // A leaf of bvh2_packed: its triangles, copied in leaf order, and their scene indices.
  struct PackedLeaf {
    const Triangle* triangles;
    const uint32_t* ids;
    uint32_t first, size;
    const Triangle& triangle(uint32_t k) const { return triangles[first + k]; }
    uint32_t prim(uint32_t k) const { return first + k; }
    uint32_t scene_index(uint32_t prim) const { return ids[prim]; }
#if defined(__SSE2__)
    template <bool kRefine, class Lanes>
    unsigned four(const Lanes& test, uint32_t k, uint32_t n, float tmin, float tmax, float* t, float* u,
                  float* v) const {
      return test.template intersect<kRefine>(triangles + first + k, n, tmin, tmax, t, u, v);
    }
#endif
  };

  PairSlabs<BoxTest> slabs_;
  LeafTestOf<TriangleTest> leaf_test_;
  const PairNode* nodes_;
  const Triangle* triangles_;
  const uint32_t* ids_;
  [[maybe_unused]] TraversalCounters* counters_;
  AnyHitOrder any_order_;
  float tmin_, best_t_;
  typename PairSlabs<BoxTest>::Interval interval_;  // [tmin_, best_t_] as slabs_ takes it
  uint32_t current_, count_;
  uint32_t size_ = 0;
  bool active_ = false;
  Hit best_;
  Entry stack_[kStackCapacity];
};

// One ray; box=fma's rays outside its domain take the robust box test (FmaRayBox::takes).
template <class TriangleTest, class BoxTest, bool kAnyHit, bool kCount>
Hit traverse_packed(const PackedBvh2& tree, const Ray& ray, TraversalCounters* counters,
                    AnyHitOrder any_order) {
  if constexpr (std::is_same_v<BoxTest, FmaRayBox>) {
    if (!FmaRayBox::takes(ray)) [[unlikely]]
      return traverse_packed<TriangleTest, RobustRayBox, kAnyHit, kCount>(tree, ray, counters, any_order);
  }
  PackedWalk<TriangleTest, BoxTest, kAnyHit, kCount> walk(tree, ray, counters, any_order);
  while (walk.active()) walk.step();
  return walk.hit();
}

}  // namespace detail

/// A packet kernel of bvh2_packed (pair_packets.inl): the rays of `mask` among rays [0, n) (n at most 8 or
/// 16) as one packet (rays detail::pair_packable takes, of any direction octants), over a tree whose root
/// is an inner node;
/// their closest hits (packed triangle indices, PackedBvh2::ids maps them to the scene's) into `hits` or
/// occlusion into `occluded`. Any hit visits children in `order`.
using PairPacketKernel = void (*)(const PackedBvh2& tree, const Ray* rays, uint32_t n, uint32_t mask,
                                  AnyHitOrder order, Hit* hits, uint8_t* occluded);

/// The bvh2_packed layout of a binary `bvh` over `triangles`, with `spec`'s triangle and box tests; with
/// packet=8 or 16, its rays traced in packets by the kernels of the instruction set isa=auto picks.
std::unique_ptr<CompiledLayout> compile_packed_bvh2(const Bvh& bvh, std::span<const Triangle> triangles,
                                                    const LayoutSpec& spec);

}  // namespace sahbench
