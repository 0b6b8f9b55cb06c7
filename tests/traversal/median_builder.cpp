#include "tests/traversal/median_builder.h"

#include <algorithm>
#include <numeric>
#include <vector>

#include "core/aabb.h"

namespace sahbench::test {
namespace {

class MedianBuilder {
 public:
  MedianBuilder(std::span<const Triangle> triangles, uint32_t arity, uint32_t max_leaf_prims)
      : triangles_(triangles), arity_(arity), max_leaf_prims_(max_leaf_prims) {
    centroids_.reserve(triangles.size());
    for (const Triangle& t : triangles) centroids_.push_back(t.centroid());
  }

  Bvh run() {
    bvh_.arity = arity_;
    if (triangles_.empty()) return std::move(bvh_);
    bvh_.prim_refs.resize(triangles_.size());
    std::iota(bvh_.prim_refs.begin(), bvh_.prim_refs.end(), 0u);
    bvh_.nodes.emplace_back();
    build(0, 0, static_cast<uint32_t>(triangles_.size()));
    return std::move(bvh_);
  }

 private:
  // Fills nodes[index] with the subtree over prim_refs[begin, end).
  void build(uint32_t index, uint32_t begin, uint32_t end) {
    Aabb bounds, centroid_bounds;
    for (uint32_t r = begin; r < end; ++r) {
      bounds.extend(triangles_[bvh_.prim_refs[r]].bounds());
      centroid_bounds.extend(centroids_[bvh_.prim_refs[r]]);
    }
    bvh_.nodes[index].bounds = bounds;
    const uint32_t count = end - begin;
    if (count <= max_leaf_prims_) {
      bvh_.nodes[index].first = begin;
      bvh_.nodes[index].prim_count = static_cast<uint16_t>(count);
      return;
    }
    // Sort along the longest centroid axis and cut into equal parts: the median for two children.
    const std::size_t axis = largest_axis(centroid_bounds.extent());
    std::sort(bvh_.prim_refs.begin() + begin, bvh_.prim_refs.begin() + end,
              [&](uint32_t a, uint32_t b) { return centroids_[a][axis] < centroids_[b][axis]; });
    const uint32_t children = std::min(arity_, count);
    const auto first = static_cast<uint32_t>(bvh_.nodes.size());
    bvh_.nodes.resize(bvh_.nodes.size() + children);  // invalidates references: index only
    bvh_.nodes[index].first = first;
    bvh_.nodes[index].child_count = static_cast<uint16_t>(children);
    for (uint32_t c = 0; c < children; ++c)
      build(first + c, begin + count * c / children, begin + count * (c + 1) / children);
  }

  std::span<const Triangle> triangles_;
  uint32_t arity_;
  uint32_t max_leaf_prims_;
  std::vector<Vec3> centroids_;
  Bvh bvh_;
};

}  // namespace

Bvh build_median_bvh(std::span<const Triangle> triangles, uint32_t arity, uint32_t max_leaf_prims) {
  return MedianBuilder(triangles, arity, max_leaf_prims).run();
}

}  // namespace sahbench::test
