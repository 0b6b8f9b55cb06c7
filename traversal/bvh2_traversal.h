#pragma once
// Scalar closest-hit and any-hit kernels on the common format (core/bvh.h), for trees of arity 2 to 8.
// The ray/box and ray/triangle tests are template parameters, so each combination is its own kernel
// with no indirect calls, and the statistics kernels are separate instantiations of the same body.

#include <algorithm>
#include <bit>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <span>
#include <type_traits>

#include "core/bvh.h"
#include "core/ray.h"
#include "core/triangle.h"
#include "traversal/kernel_variant.h"
#include "traversal/ray_box.h"
#include "traversal/triangle_lanes.h"
#include "traversal/triangle_tests.h"
#include "traversal/walks_in_flight.h"

namespace sahbench {

/// Work done by the statistics kernels, summed over every ray traced with the same counters. Per-ray
/// figures (DESIGN.md's nodes_per_ray, prims_per_ray) are these divided by `rays`.
struct TraversalCounters {
  uint64_t rays = 0;
  uint64_t inner_visits = 0;  ///< inner nodes popped and not culled, i.e. whose children were box-tested
  uint64_t leaf_visits = 0;   ///< leaves popped and not culled, i.e. whose primitives were tested
  uint64_t box_tests = 0;     ///< ray/box tests, the root's included
  uint64_t prim_tests = 0;    ///< ray/triangle tests (a repeated reference counts each time)

  /// Nodes visited: inner nodes and leaves whose contents were examined.
  uint64_t nodes_visited() const { return inner_visits + leaf_visits; }

  TraversalCounters& operator+=(const TraversalCounters& o) {
    rays += o.rays;
    inner_visits += o.inner_visits;
    leaf_visits += o.leaf_visits;
    box_tests += o.box_tests;
    prim_tests += o.prim_tests;
    return *this;
  }
  friend bool operator==(const TraversalCounters&, const TraversalCounters&) = default;
};

/// The order in which any hit visits a node's children on `bvh`: `order`, with kAuto resolved.
/// - Wide trees (arity above 2): kStored. Their builders store first the children likeliest to hold an
///   occluder per unit of cost (builders/child_order.h), and storage order costs no sort or search on
///   the way to the next node. Going first to the nearest child (ties to the earlier) and then in
///   storage order (kNearestStored) traced the shadow rays of the 1M terrain
///   1-8% faster, the bunny's 4-5% faster and the dragon's within 2%, and Sponza's, seen from inside its
///   atrium (configs/wide.toml's camera), 17% slower: 0.77 of Embree against 0.92, with about as many
///   nodes and triangles per ray (`bvh8:tri=mtn,box=fma`, wide_collapse with min_leaf 4; two A/Bs of 3
///   interleaved rounds and 3 runs of wide.toml). The shadow rays of an
///   interior start on a floor or wall whose box is the nearest, and their occluders are far. Storage
///   order's worst case is the smaller, hence the default. (From outside Sponza, before the configs had
///   a camera, the nearest first had looked no worse there.)
///   Nearest first only where the ray starts in none of the children was worse than both on all but
///   Sponza (0.82).
/// - Binary trees: kNearest. Storage order cost their shadow rays 10 to 16% (measured against Embree in
///   one run).
/// The layout option anyhit=nearest|stored|nearest_stored|farthest_stored overrides it.
inline AnyHitOrder resolve_any_hit_order(const Bvh& bvh, AnyHitOrder order = AnyHitOrder::kAuto) {
  if (order != AnyHitOrder::kAuto) return order;
  return bvh.arity > 2 ? AnyHitOrder::kStored : AnyHitOrder::kNearest;
}

namespace detail {

// Stack bound. Popping an inner node at depth d and pushing its (at most kMaxArity) children leaves at
// most kMaxArity - 1 entries per level from the root down, and inner nodes lie at depth
// <= kMaxDepth - 1 when leaves lie at depth <= kMaxDepth. So the stack never holds more than
// (kMaxArity - 1) * (kMaxDepth - 1) + kMaxArity = (kMaxArity - 1) * kMaxDepth + 1 entries.
inline constexpr uint32_t kStackBound = (kMaxArity - 1) * kMaxDepth + 1;
// Rounded up to a power of two as margin; 512 entries of 8 to 12 bytes are 4 to 6 KiB on the call stack. A
// tree deeper than kMaxDepth is still caught by the per-node capacity check (which throws), never overrun.
inline constexpr uint32_t kStackCapacity = 512;
static_assert(kStackCapacity >= kStackBound, "traversal stack too small for kMaxDepth and kMaxArity");

struct StackEntry {
  uint32_t node;
  /// Distance at which the ray enters the node's box, to cull it after a closer hit. Closest hit only:
  /// any hit reads none, and the binary walks push the farther child distance whichever child they push.
  float t_entry;
};

/// Throws sahbench::Error naming the node: a tree deeper than kMaxDepth (the builders guarantee it).
[[noreturn]] void throw_stack_overflow(uint32_t node, uint32_t child_count);

/// Closest hit's rule for a hit of `prim` at `t` (no farther than best_t: the test met best_t as its
/// tmax): the nearer hit, on a tie the one of lower scene index, so that every kernel keeps the hit that
/// testing all triangles in scene order would. `scene_index(prim)` maps a kernel's triangle to the scene's.
template <class SceneIndex>
[[gnu::always_inline]] inline void take_closer(uint32_t prim, float t, float u, float v,
                                               const SceneIndex& scene_index, float& best_t, Hit& best) {
  if (t < best_t || !best.found() || scene_index(prim) < scene_index(best.prim)) {
    best = {prim, t, u, v};
    best_t = t;
  }
}

/// A binary walk's leaf: its triangles `leaf.triangle(k)`, k < `leaf.size`, tested in order against
/// the closest hit so far (`best`, at `best_t`); `leaf.prim(k)` is what a hit names and
/// `leaf.scene_index(prim)` that hit's index in the scene, which breaks ties (the lowest wins, as in the
/// general loop below). Returns true when an any-hit query found its hit.
///
/// Where the test has a four-lane form (triangle_lanes.h) the triangles are taken four at a time
/// (`leaf.four`) against the closest hit before them; where one of them lowered it, the hits after that one
/// are tested again by the scalar test against the lowered distance, as the one-at-a-time loop would have
/// tested them (a triangle missed at the higher distance is missed at the lower one too): the answers are the
/// same, hit for hit.
template <class L>
concept BinaryLeaf = requires(const L& leaf, uint32_t k) {
  { leaf.size } -> std::convertible_to<uint32_t>;
  { leaf.triangle(k) } -> std::same_as<const Triangle&>;
  { leaf.prim(k) } -> std::same_as<uint32_t>;
  { leaf.scene_index(k) } -> std::same_as<uint32_t>;
};

template <bool kAnyHit, class TriangleTest, BinaryLeaf Leaf>
[[gnu::always_inline]] inline bool test_leaf(const LeafTestOf<TriangleTest>& test, const Leaf& leaf,
                                             float tmin, float& best_t, Hit& best) {
  auto take = [&](uint32_t prim, float t, float u, float v) {
    take_closer(
        prim, t, u, v, [&](uint32_t p) { return leaf.scene_index(p); }, best_t, best);
  };
  if constexpr (kTestsInLanes<TriangleTest>) {
    for (uint32_t first = 0; first < leaf.size; first += 4) {
      alignas(16) float t[4], u[4], v[4];
      const uint32_t n = std::min<uint32_t>(4, leaf.size - first);
      const float tmax = best_t;
      for (unsigned mask = leaf.template four<!kAnyHit>(test, first, n, tmin, tmax, t, u, v); mask != 0;
           mask &= mask - 1) {
        const uint32_t k = first + static_cast<uint32_t>(std::countr_zero(mask));
        const uint32_t i = k - first;
        if constexpr (kAnyHit) {
          if (!any_hit_holds(test.one(), leaf.triangle(k), tmin, tmax, t[i])) continue;
          best = {leaf.prim(k), t[i], u[i], v[i]};
          return true;
        } else {
          if (best_t < tmax && !test.one().intersect(leaf.triangle(k), tmin, best_t, t[i], u[i], v[i]))
            continue;
          take(leaf.prim(k), t[i], u[i], v[i]);
        }
      }
    }
  } else {
    for (uint32_t k = 0; k < leaf.size; ++k) {
      float t, u, v;
      const bool hit = kAnyHit ? intersect_any(test, leaf.triangle(k), tmin, best_t, t, u, v)
                               : test.intersect(leaf.triangle(k), tmin, best_t, t, u, v);
      if (!hit) continue;
      if constexpr (kAnyHit) {
        best = {leaf.prim(k), t, u, v};
        return true;
      } else {
        take(leaf.prim(k), t, u, v);
      }
    }
  }
  return false;
}

/// How closest hit orders two children of a binary node that a ray enters at one distance: the later
/// slot first (bvh2's walk, BinaryWalk), or the one the ray leaves first (bvh2_packed's, PackedWalk, which
/// says why). The general loop below takes either, so that the tests hold each walk to it.
enum class ClosestTies { kLaterSlot, kExitFirst };

// Of two children a ray meets, entered at t0 and t1 and left at e0 and e1, whether the second goes first:
// the one entered first; on equal entries, with kExitFirst the one left first, and otherwise (or on
// equal exits too) the second.
template <ClosestTies kTies>
[[gnu::always_inline]] inline bool second_goes_first(float t0, float t1, float e0, float e1) {
  if constexpr (kTies == ClosestTies::kExitFirst) {
    return !(t0 < t1) & !((t0 == t1) & (e0 < e1));
  } else {
    return !(t0 < t1);
  }
}

// The loop for binary trees (every inner node of a valid arity-2 tree has two children), the shape of
// Aila and Laine 2009's "while-while" kernel and of tinybvh's BVH::Intersect: both children are tested
// where their parent is visited, the ray goes on to the nearer one without a trip through the stack and
// pushes the other with its entry distance, and a popped node entered beyond the closest hit is skipped.
// It visits the nodes that the general loop below visits, in the same order (on equal entry distances
// the second child first, ClosestTies::kLaterSlot), so results and counters are the same.
//
// One step at a time: a step is one inner node, or one leaf and the pops after it, so that several walks
// can be stepped in turn (trace_walks below). The walk starts with the root's box test and counts the
// ray, as the general loop does.
template <class TriangleTest, class BoxTest, bool kAnyHit, bool kCount>
class BinaryWalk {
 public:
  /// A walk of `ray` (one BoxTest takes, see FmaRayBox::takes) through the binary `bvh` over `triangles`;
  /// any hit visits children in `any_order` (resolved).
  BinaryWalk(const Bvh& bvh, const Triangle* triangles, const Ray& ray,
             [[maybe_unused]] TraversalCounters* counters, AnyHitOrder any_order)
      : box_test_(ray),
        triangle_test_(ray),
        nodes_(bvh.nodes.data()),
        refs_(bvh.prim_refs.data()),
        triangles_(triangles),
        counters_(counters),
        any_order_(any_order),
        tmin_(ray.tmin),
        best_t_(far_limit(ray)) {
    if constexpr (kCount) ++counters_->rays;
    if (bvh.nodes.empty() || !traceable(ray)) return;
    if constexpr (kCount) ++counters_->box_tests;
    float t_root;
    active_ = box_test_.intersect(nodes_[0].bounds, tmin_, best_t_, t_root);
  }

  /// Whether the walk has steps left; once false, hit() is its answer.
  bool active() const { return active_; }
  const Hit& hit() const { return best_; }

  /// One step; returns active().
  [[gnu::always_inline]] bool step() {
    const Node& node = nodes_[current_];
    if (!node.is_leaf()) {
      if constexpr (kCount) {
        ++counters_->inner_visits;
        counters_->box_tests += 2;
      }
      const uint32_t first = node.first;
      float t0, t1;
      const unsigned hits =
          box_test_.intersect_pair(nodes_[first].bounds, nodes_[first + 1].bounds, tmin_, best_t_, t0, t1);
      if (hits == 3) {
        bool second_first = !(t0 < t1);
        if constexpr (kAnyHit) {
          if (any_order_ == AnyHitOrder::kStored) second_first = false;
          if (any_order_ == AnyHitOrder::kNearestStored) second_first = t1 < t0;
          if (any_order_ == AnyHitOrder::kFarthestStored) second_first = t1 > t0;
        }
        if (size_ == kStackCapacity) [[unlikely]]
          throw_stack_overflow(current_, 2);
        // The nearer child as an index rather than a branch: which one it is changes from node to node, and
        // a branch on it is often mispredicted. The pushed entry distance is the farther one, read only by
        // closest hit's culling (there it is the other child's); PackedWalk takes its children the same way.
        const uint32_t near = second_first ? 1u : 0u;
        stack_[size_++] = {first + (near ^ 1u), std::max(t0, t1)};
        current_ = first + near;
        return true;
      }
      if (hits != 0) {
        current_ = first + (hits >> 1);
        return true;
      }
    } else {
      if constexpr (kCount) {
        ++counters_->leaf_visits;
        counters_->prim_tests += node.prim_count;
      }
      if (test_leaf<kAnyHit, TriangleTest>(triangle_test_,
                                           RefLeaf{refs_ + node.first, triangles_, node.prim_count}, tmin_,
                                           best_t_, best_))
        return active_ = false;  // an any-hit query's hit
    }
    // Next: the top of the stack, skipping nodes entered beyond the closest hit (equal is kept for the
    // tie rule).
    do {
      if (size_ == 0) return active_ = false;
      --size_;
    } while (!kAnyHit && stack_[size_].t_entry > best_t_);
    current_ = stack_[size_].node;
    return true;
  }

 private:
  // A leaf of the common format: its references into the scene's triangles.
  struct RefLeaf {
    const uint32_t* refs;
    const Triangle* triangles;
    uint32_t size;
    const Triangle& triangle(uint32_t k) const { return triangles[refs[k]]; }
    uint32_t prim(uint32_t k) const { return refs[k]; }
    static uint32_t scene_index(uint32_t prim) { return prim; }
#if defined(__SSE2__)
    template <bool kRefine, class Lanes>
    unsigned four(const Lanes& test, uint32_t k, uint32_t n, float tmin, float tmax, float* t, float* u,
                  float* v) const {
      return test.template intersect<kRefine>(triangles, refs + k, n, tmin, tmax, t, u, v);
    }
#endif
  };

  BoxTest box_test_;
  LeafTestOf<TriangleTest> triangle_test_;
  const Node* nodes_;
  const uint32_t* refs_;
  const Triangle* triangles_;
  [[maybe_unused]] TraversalCounters* counters_;
  AnyHitOrder any_order_;
  float tmin_, best_t_;
  uint32_t current_ = 0;
  uint32_t size_ = 0;
  bool active_ = false;
  Hit best_;
  StackEntry stack_[kStackCapacity];
};

// The one traversal loop. kAnyHit stops at the first hit in [tmin, tmax]; otherwise the interval's end
// shrinks to the closest hit so far. kCount adds the statistics, compiled out of the timed kernels.
//
// Order: the children hit are pushed sorted so that the nearest entry is popped first (for two children
// one compare and swap), and closest hit skips a popped node entered beyond the current closest hit.
// Any hit sorts too on binary trees, but visits the children of wide trees in storage order, or the
// nearest first and then the rest in storage order (resolve_any_hit_order), as the wide kernels do.
//
// Ties: a hit at exactly the current closest t replaces it only when its primitive index is lower, so
// among hits at the same float t the lowest index wins, as in the brute-force reference.
//
// kBinaryLoop sends binary trees to BinaryWalk; the tests turn it off to check that both loops agree,
// and give the general loop `ties` to hold each binary walk to its own order.
template <class TriangleTest, class BoxTest, bool kAnyHit, bool kCount, bool kBinaryLoop = true>
Hit traverse(const Bvh& bvh, std::span<const Triangle> triangles, const Ray& ray,
             [[maybe_unused]] TraversalCounters* counters, AnyHitOrder order,
             ClosestTies ties = ClosestTies::kLaterSlot) {
  if constexpr (std::is_same_v<BoxTest, FmaRayBox>) {
    // A ray outside box=fma's domain takes the robust box test (ray_box.h: FmaRayBox).
    if (!FmaRayBox::takes(ray)) [[unlikely]]
      return traverse<TriangleTest, RobustRayBox, kAnyHit, kCount, kBinaryLoop>(bvh, triangles, ray, counters,
                                                                                order, ties);
  }
  if (kBinaryLoop && bvh.arity == 2) {
    const AnyHitOrder any_order = kAnyHit ? resolve_any_hit_order(bvh, order) : AnyHitOrder::kNearest;
    BinaryWalk<TriangleTest, BoxTest, kAnyHit, kCount> walk(bvh, triangles.data(), ray, counters, any_order);
    while (walk.active()) walk.step();
    return walk.hit();
  }
  if constexpr (kCount) ++counters->rays;
  if (bvh.nodes.empty() || !traceable(ray)) return {};
  const BoxTest box_test(ray);
  const TriangleTest triangle_test(ray);
  if constexpr (kCount) ++counters->box_tests;

  StackEntry stack[kStackCapacity];
  uint32_t size = 0;
  float t_entry;
  const float tmax = far_limit(ray);
  if (!box_test.intersect(bvh.nodes[0].bounds, ray.tmin, tmax, t_entry)) return {};
  const AnyHitOrder any_order = kAnyHit ? resolve_any_hit_order(bvh, order) : AnyHitOrder::kNearest;
  stack[size++] = {0, t_entry};

  Hit best;
  float best_t = tmax;
  while (size > 0) {
    const StackEntry entry = stack[--size];
    if constexpr (!kAnyHit) {
      // Entered beyond the closest hit: nothing inside can be closer. Equal is kept for the tie rule.
      if (entry.t_entry > best_t) continue;
    }
    const Node& node = bvh.nodes[entry.node];

    if (node.is_leaf()) {
      if constexpr (kCount) {
        ++counters->leaf_visits;
        counters->prim_tests += node.prim_count;
      }
      const uint32_t end = node.first + node.prim_count;
      for (uint32_t r = node.first; r < end; ++r) {
        const uint32_t prim = bvh.prim_refs[r];
        float t, u, v;
        const bool hit = kAnyHit ? intersect_any(triangle_test, triangles[prim], ray.tmin, best_t, t, u, v)
                                 : triangle_test.intersect(triangles[prim], ray.tmin, best_t, t, u, v);
        if (!hit) continue;
        if constexpr (kAnyHit) {
          return {prim, t, u, v};
        } else {
          // The test guarantees t <= best_t, so this is "closer, or as close with a lower index".
          if (t < best_t || prim < best.prim) {
            best = {prim, t, u, v};
            best_t = t;
          }
        }
      }
      continue;
    }

    if constexpr (kCount) {
      ++counters->inner_visits;
      counters->box_tests += node.child_count;
    }
    if (size + node.child_count > kStackCapacity) [[unlikely]]
      throw_stack_overflow(entry.node, node.child_count);
    const uint32_t end = node.first + node.child_count;
    const uint32_t base = size;
    if (any_order == AnyHitOrder::kStored) {
      // Storage order: pushed last child first, so the first child entered is popped first.
      for (uint32_t child = end; child-- > node.first;)
        if (box_test.intersect(bvh.nodes[child].bounds, ray.tmin, best_t, t_entry))
          stack[size++] = {child, t_entry};
      continue;
    }
    if (any_order == AnyHitOrder::kNearestStored || any_order == AnyHitOrder::kFarthestStored) {
      // As storage order, then the nearest (farthest) child entered, ties to the earlier slot, moved to
      // the top.
      const bool farthest = any_order == AnyHitOrder::kFarthestStored;
      uint32_t first = size;
      for (uint32_t child = end; child-- > node.first;) {
        if (!box_test.intersect(bvh.nodes[child].bounds, ray.tmin, best_t, t_entry)) continue;
        if (first == size || (farthest ? t_entry >= stack[first].t_entry : t_entry <= stack[first].t_entry))
          first = size;
        stack[size++] = {child, t_entry};
      }
      if (first + 1 < size) std::rotate(stack + first, stack + first + 1, stack + size);
      continue;
    }
    // Insertion sort into this node's part of the stack, popped first on top (highest index): nearest
    // entry first, ties as second_goes_first orders two children (exits[k] is stack[base + k]'s exit).
    const bool by_exit = !kAnyHit && bvh.arity == 2 && ties == ClosestTies::kExitFirst;
    const auto goes_first = [by_exit](const StackEntry& earlier, float earlier_exit, float t, float exit) {
      return by_exit ? second_goes_first<ClosestTies::kExitFirst>(earlier.t_entry, t, earlier_exit, exit)
                     : second_goes_first<ClosestTies::kLaterSlot>(earlier.t_entry, t, earlier_exit, exit);
    };
    float exits[kMaxArity];
    for (uint32_t child = node.first; child < end; ++child) {
      float t_exit;
      if (!box_test.intersect(bvh.nodes[child].bounds, ray.tmin, best_t, t_entry, t_exit)) continue;
      uint32_t slot = size++;
      while (slot > base && !goes_first(stack[slot - 1], exits[slot - 1 - base], t_entry, t_exit)) {
        stack[slot] = stack[slot - 1];
        exits[slot - base] = exits[slot - 1 - base];
        --slot;
      }
      stack[slot] = {child, t_entry};
      exits[slot - base] = t_exit;
    }
  }
  return best;
}

// Single rays of the binary layouts go down the tree eight at a time, their walks stepped in turn
// (walks_in_flight.h): against two walks in turn, bvh2 and bvh2_packed traced the primary and shadow
// rays of configs/tune.toml's scenes 2 to 23% faster (the 1M terrain's shadow rays most); against four
// walks, shadow rays 1 to 7% faster and primary rays 6% slower to 1% faster (medians of one run).
inline constexpr std::size_t kBinaryWalks = 8;

// Rays rays[index(j)], j in [0, n), with kBinaryWalks walks in flight (step_interleaved); `put(i, hit)`
// takes ray i's answer. `emplace(slot, ray)` starts a ray's walk (BinaryWalk, PackedWalk) in `slot`;
// box=fma's rays outside that test's domain (FmaRayBox::takes) go alone, `hit = alone(ray)`, on the
// robust box test.
template <class Walk, class BoxTest, class Index, class Emplace, class Alone, class Put>
void trace_walks(std::span<const Ray> rays, std::size_t n, Index&& index, Emplace&& emplace, Alone&& alone,
                 Put&& put) {
  step_interleaved<Walk, kBinaryWalks>(
      n,
      [&](std::optional<Walk>& walk, std::size_t j) {
        const std::size_t i = index(j);
        if constexpr (std::is_same_v<BoxTest, FmaRayBox>) {
          if (!FmaRayBox::takes(rays[i])) [[unlikely]] {
            put(i, alone(rays[i]));
            return false;
          }
        }
        emplace(walk, rays[i]);
        if (walk->active()) return true;
        put(i, walk->hit());
        return false;
      },
      [&](std::size_t j, const Walk& walk) { put(index(j), walk.hit()); });
}

// The octant of a ray's direction: bit i set for a negative component i.
inline uint32_t direction_octant(const Ray& r) {
  return uint32_t{std::signbit(r.dir.x)} | uint32_t{std::signbit(r.dir.y)} << 1 |
         uint32_t{std::signbit(r.dir.z)} << 2;
}

// Whether a ray can go down the tree in a packet of pair_packets.inl (the binary layouts' packet kernels):
// not one that is not traceable, nor (box=fma) one outside the box test's domain.
template <class BoxTest>
bool pair_packable(const Ray& r) {
  if constexpr (std::is_same_v<BoxTest, FmaRayBox>)
    return traceable(r) && FmaRayBox::takes(r);
  else
    return traceable(r);
}

// Rays [begin, end) of a binary layout in packets of `width` rays (8 or 16): a packet's rays that can
// (pair_packable) go down the tree together, `packet(rays, n, mask, hits, occluded)` with those lanes
// among the packet's n rays, where two or more can; the others one at a time, `walks(m, index, put)` with
// rays index(0) ... index(m - 1) (trace_walks). With `packets` false (a tree that is one leaf or none)
// every ray goes alone. Closest hits go into `hits`, occlusion into `occluded`.
template <class BoxTest, bool kAnyHit, class Packet, class Walks>
void trace_in_packets(std::span<const Ray> rays, std::size_t begin, std::size_t end, uint32_t width,
                      bool packets, Hit* hits, uint8_t* occluded, Packet&& packet, Walks&& walks) {
  auto put = [&](std::size_t i, const Hit& hit) {
    if constexpr (kAnyHit)
      occluded[i] = hit.found();
    else
      hits[i] = hit;
  };
  for (std::size_t first = begin; first < end; first += width) {
    const auto n = static_cast<uint32_t>(std::min<std::size_t>(width, end - first));
    uint32_t together = 0;
    for (uint32_t j = 0; j < n; ++j)
      if (packets && pair_packable<BoxTest>(rays[first + j])) together |= 1u << j;
    uint32_t alone = ((1u << n) - 1u) & ~together;  // n is at most 16
    if (std::popcount(together) >= 2)
      packet(&rays[first], n, together, kAnyHit ? nullptr : hits + first,
             kAnyHit ? occluded + first : nullptr);
    else
      alone |= together;
    std::size_t index[16];
    std::size_t m = 0;
    for (; alone != 0; alone &= alone - 1)
      index[m++] = first + static_cast<uint32_t>(std::countr_zero(alone));
    if (m != 0)
      walks(
          m, [&](std::size_t j) { return index[j]; }, put);
  }
}

}  // namespace detail

/// Closest hit of `ray` within [ray.tmin, ray.tmax] among `triangles`, traversing `bvh` (any arity up to
/// 8, built over `triangles`) depth first with an explicit stack, nearest child first by entry distance
/// (pbrt-v4's BVHAggregate::Intersect does the same ordered traversal but orders two children by the
/// sign of the ray direction on the split axis). Among hits at the same t the lowest primitive index
/// wins. An empty `bvh` (no nodes) is a miss. Throws sahbench::Error for a tree deeper than kMaxDepth.
template <class TriangleTest = WatertightTriangleTest, class BoxTest = RobustRayBox>
Hit closest_hit(const Bvh& bvh, std::span<const Triangle> triangles, const Ray& ray) {
  return detail::traverse<TriangleTest, BoxTest, false, false>(bvh, triangles, ray, nullptr,
                                                               AnyHitOrder::kAuto);
}

/// Whether any triangle is hit within [ray.tmin, ray.tmax] (shadow rays): stops at the first hit found.
/// Children are visited in `order` (resolve_any_hit_order).
template <class TriangleTest = WatertightTriangleTest, class BoxTest = RobustRayBox>
bool any_hit(const Bvh& bvh, std::span<const Triangle> triangles, const Ray& ray,
             AnyHitOrder order = AnyHitOrder::kAuto) {
  return detail::traverse<TriangleTest, BoxTest, true, false>(bvh, triangles, ray, nullptr, order).found();
}

/// closest_hit, also adding this ray's work to `counters`. Same traversal, same result; not for timing.
template <class TriangleTest = WatertightTriangleTest, class BoxTest = RobustRayBox>
Hit closest_hit_counted(const Bvh& bvh, std::span<const Triangle> triangles, const Ray& ray,
                        TraversalCounters& counters) {
  return detail::traverse<TriangleTest, BoxTest, false, true>(bvh, triangles, ray, &counters,
                                                              AnyHitOrder::kAuto);
}

/// any_hit, also adding this ray's work to `counters`. Same traversal, same result; not for timing.
template <class TriangleTest = WatertightTriangleTest, class BoxTest = RobustRayBox>
bool any_hit_counted(const Bvh& bvh, std::span<const Triangle> triangles, const Ray& ray,
                     TraversalCounters& counters, AnyHitOrder order = AnyHitOrder::kAuto) {
  return detail::traverse<TriangleTest, BoxTest, true, true>(bvh, triangles, ray, &counters, order).found();
}

/// A packet kernel of bvh2 (pair_packets.inl): the rays of `mask` among rays [0, n) (n at most 8 or 16)
/// as one packet (rays detail::pair_packable takes, of any direction octants), over the binary `bvh`
/// (whose root is an inner node) over `triangles`; their closest hits into `hits` or occlusion into
/// `occluded`. Any hit visits children in `order`.
using BinaryPacketKernel = void (*)(const Bvh& bvh, const Triangle* triangles, const Ray* rays, uint32_t n,
                                    uint32_t mask, AnyHitOrder order, Hit* hits, uint8_t* occluded);

}  // namespace sahbench
