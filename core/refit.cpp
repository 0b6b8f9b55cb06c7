#include "core/refit.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/simd.h"

namespace sahbench {

namespace {

// Parallel tasks per thread at the top of the tree: enough spare tasks that a lopsided tree still
// balances across threads, few enough that spawning stays negligible next to the refit itself.
constexpr int kTasksPerThread = 16;

// A box as two SIMD vectors (x, y, z in lanes 0 to 2; lane 3 is never stored).
struct Box4 {
  simd::Vec4f min = simd::splat(std::numeric_limits<float>::infinity());
  simd::Vec4f max = simd::splat(-std::numeric_limits<float>::infinity());

  void extend(simd::Vec4f lo, simd::Vec4f hi) {
    min = simd::min(min, lo);
    max = simd::max(max, hi);
  }
  Aabb to_aabb() const {
    float lo[4], hi[4];
    simd::store4(lo, min);
    simd::store4(hi, max);
    return {{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}};
  }
};

class Refitter {
 public:
  Refitter(Bvh& bvh, std::span<const Triangle> triangles, uint32_t spawn_depth)
      : nodes_(bvh.nodes.data()),
        refs_(bvh.prim_refs.data()),
        triangles_(triangles.data()),
        spawn_depth_(spawn_depth) {}

  // Post-order: the children's boxes first, then this node's. Subtrees below spawn_depth_ run on the
  // calling thread, so each task is a whole subtree.
  Box4 refit(uint32_t index, uint32_t depth) const {
    Node& node = nodes_[index];
    Box4 box;
    if (node.is_leaf()) {
      const uint32_t* ref = refs_ + node.first;
      for (uint32_t i = 0; i < node.prim_count; ++i) {
        const Triangle& t = triangles_[ref[i]];
        // v0 and v1 load four floats each (the fourth is the next vertex's x, within the triangle);
        // v2 is the triangle's last 12 bytes, so it is assembled rather than read past its end.
        const simd::Vec4f a = simd::load4(&t.v0), b = simd::load4(&t.v1);
        const simd::Vec4f c = simd::make4(t.v2.x, t.v2.y, t.v2.z, t.v2.z);
        box.extend(simd::min(a, simd::min(b, c)), simd::max(a, simd::max(b, c)));
      }
    } else if (depth < spawn_depth_) {
      tbb::parallel_for(uint32_t{0}, uint32_t{node.child_count},
                        [&](uint32_t c) { refit(node.first + c, depth + 1); });
      for (uint32_t c = 0; c < node.child_count; ++c) {
        // min.xyz then max.x, and max.xyz then `first`: both loads stay inside the 32-byte node.
        const Aabb& b = nodes_[node.first + c].bounds;
        box.extend(simd::load4(&b.min), simd::load4(&b.max));
      }
    } else {
      for (uint32_t c = 0; c < node.child_count; ++c) {
        const Box4 child = refit(node.first + c, depth + 1);
        box.extend(child.min, child.max);
      }
    }
    node.bounds = box.to_aabb();
    return box;
  }

 private:
  Node* nodes_;
  const uint32_t* refs_;
  const Triangle* triangles_;
  uint32_t spawn_depth_;
};

}  // namespace

void refit(Bvh& bvh, std::span<const Triangle> triangles) {
  if (bvh.nodes.empty()) return;
  // Spawn down to the depth where a balanced tree has kTasksPerThread subtrees per thread; none at all
  // with one thread, so the single-threaded refit pays nothing for the parallel path.
  const int threads = tbb::this_task_arena::max_concurrency();
  uint32_t spawn_depth = 0;
  if (threads > 1) {
    const double arity = std::max<uint32_t>(2, bvh.arity);
    spawn_depth =
        static_cast<uint32_t>(std::ceil(std::log(double(threads) * kTasksPerThread) / std::log(arity)));
  }
  Refitter(bvh, triangles, spawn_depth).refit(0, 0);
}

}  // namespace sahbench
