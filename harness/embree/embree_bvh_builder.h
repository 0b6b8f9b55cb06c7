#pragma once
// Embree 3's generic BVH builder (rtcNewBVH + rtcBuildBVH, rtcore_builder.h) writing the common format,
// so that trees built by Embree's builders are traced by our kernels and costed by our SAH, next to
// ours. Embree builds into a temporary tree of our own nodes allocated in its thread-local allocator
// (rtcThreadLocalAlloc) through its create-node, set-children, set-bounds and create-leaf callbacks;
// that tree is then flattened into a Bvh of arity 2, 4 or 8 (maxBranchingFactor).

#include <cstdint>

#include "core/build_input.h"
#include "core/bvh.h"
#include "core/sah.h"
#include "harness/embree/embree_scene.h"

namespace sahbench {

/// RTCBuildArguments as sahbench parameters. Defaults as our top-down builders where the two overlap
/// (leaves of 1..8 primitives, SAH 1:1), Embree's own elsewhere.
struct EmbreeBvhParams {
  /// kLow: Morton-code builder (BVHBuilderMorton), which ignores the SAH constants and max_leaf: it
  /// splits every node down to min_leaf primitives or fewer; kMedium: binned SAH
  /// (BVHBuilderBinnedSAH); kHigh: binned SAH with spatial splits (BVHBuilderBinnedFastSpatialSAH),
  /// which clips triangles and so needs BuildInput::triangles.
  EmbreeQuality quality = EmbreeQuality::kMedium;
  /// maxBranchingFactor: 2, 4 or 8. Embree's generic builder fills a wide node by splitting the child
  /// of largest area until it has `arity` children or the SAH makes the rest leaves, as its BVH4 and
  /// BVH8 scene builders do; with sah_block = 4 and min_leaf = 4 it is their tree for Triangle4 leaves.
  uint32_t arity = 2;
  uint32_t min_leaf = 1;  ///< minLeafSize: nodes with this many primitives or fewer become leaves
  uint32_t max_leaf = 8;  ///< maxLeafSize: nodes with more are always split (Embree caps it at 32)
  SahCost cost;           ///< traversalCost, intersectionCost
  /// maxDepth. Embree counts the root as depth 1, so leaves lie at most max_depth - 1 below our root;
  /// within 8 levels of the limit it stops using the SAH and splits by count (createLargeLeaf), and
  /// fails the build ("depth limit reached") when even that cannot fit. Default kMaxDepth, the depth
  /// our kernels' stacks are sized for (Embree's own default is 32).
  uint32_t max_depth = kMaxDepth;
  /// sahBlockSize: the SAH counts a leaf of n primitives as ceil(n / block) blocks (a power of two).
  uint32_t sah_block = 1;
  /// kHigh only: the primitive array holds split_factor * n references (primitiveArrayCapacity), the
  /// room Embree has for the references that spatial splits add. 1.2 is what rtcCommitScene uses
  /// (the device setting max_spatial_split_replications, printed by verbose=2); 1 disables splits.
  float split_factor = 1.2f;
};

/// EmbreeBvhParams{}.split_factor as the registry's default (a double, so the CSV says 1.2).
inline constexpr double kEmbreeDefaultSplitFactor = 1.2;

/// Embree's SAH cap on leaf size (RTC_BUILD_MAX_PRIMITIVES_PER_LEAF).
inline constexpr uint32_t kEmbreeMaxLeafPrims = RTC_BUILD_MAX_PRIMITIVES_PER_LEAF;
/// The largest split_factor accepted: beyond 4 references per primitive, a scene's split budget is far
/// past what any spatial-split builder uses (Stich et al. 2009 report 1.1 to 1.5).
inline constexpr float kEmbreeMaxSplitFactor = 4.0f;

/// Builds `input` with Embree's generic builder. Threads: rtcBuildBVH runs Embree's TBB code in the
/// caller's arena, so the caller's tbb::global_control and task_arena decide how many threads build.
/// The builder makes its own short-lived device per call (~0.1 to 0.4 ms of set-up, included in the
/// build time) with "threads=N", N the caller's current TBB limit, so that it neither lifts nor keeps
/// the limit of another live EmbreeDevice (see EmbreeDevice). 0 primitives give an empty Bvh without
/// calling Embree (Embree would return a leaf of 0 primitives, which the format cannot hold).
/// Invalid parameters and Embree errors throw sahbench::Error.
Bvh build_embree_bvh(const BuildInput& input, const EmbreeBvhParams& params);

/// Registers "embree_bvh" with builders/registry.h (parameters quality, arity, min_leaf, max_leaf, c_trav,
/// c_isect, max_depth, sah_block, split_factor). Calling it again does nothing. Not thread-safe: call
/// at startup, like register_builder.
void register_embree_builders();

}  // namespace sahbench
