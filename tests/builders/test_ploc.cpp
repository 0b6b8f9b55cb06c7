// The PLOC builder: its clustering against a plain serial transcription of Meister and Bittner's loop and,
// at a radius over every cluster, against global greedy clustering; the same tree byte for byte on one
// and two threads, identical boxes, and a chain of exponentially spaced triangles deeper than the kernels
// allow. (The shared scene cases run through BuilderVsReference.)

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "builders/leaf_collapse.h"
#include "builders/morton.h"
#include "builders/ploc.h"
#include "builders/registry.h"
#include "core/bvh_stats.h"
#include "core/validate.h"
#include "tests/builders/builder_cases.h"
#include "tests/support/hit_check.h"
#include "tests/support/test_scenes.h"
#include "traversal/brute_force.h"
#include "traversal/bvh2_traversal.h"

namespace sahbench {
namespace {

// The tree under a node as nested pairs of primitive indices, "(a,(b,c))".
std::string shape(const Bvh& bvh, uint32_t index = 0) {
  const Node& node = bvh.nodes[index];
  if (node.is_leaf()) return std::to_string(bvh.prim_refs[node.first]);
  return "(" + shape(bvh, node.first) + "," + shape(bvh, node.first + 1) + ")";
}

// Meister and Bittner 2018, Algorithm 1, one cluster at a time: nearest neighbours within the radius by
// the area of the merged box (equal areas ordered by the pair: closer in the order, then lower index
// even, then lower index, as the builder documents), mutual pairs merged at the lower place.
std::string reference_shape(const std::vector<Triangle>& tris, uint32_t radius) {
  const BuildInput input = BuildInput::from_triangles(tris);
  const MortonOrder<uint32_t> order = sort_by_morton<uint32_t>(input.bounds.span());
  struct Cluster {
    Aabb box;
    std::string shape;
  };
  std::vector<Cluster> clusters;
  for (uint32_t id : order.ids) clusters.push_back({tris[id].bounds(), std::to_string(id)});
  auto distance = [](const Aabb& a, const Aabb& b) {
    const Vec3 e = merge(a, b).extent();
    const float area = e.x * e.y + e.y * e.z + e.z * e.x;
    return std::isnan(area) ? std::numeric_limits<float>::infinity() : area;
  };
  auto rank = [](std::size_t i, std::size_t j) {
    const std::size_t lo = std::min(i, j), hi = std::max(i, j);
    return std::tuple(hi - lo, lo % 2, lo);
  };
  while (clusters.size() > 1) {
    const std::size_t n = clusters.size();
    std::vector<std::size_t> nearest(n);
    for (std::size_t i = 0; i < n; ++i) {
      std::size_t best = n;
      float best_d = 0;
      for (std::size_t j = i > radius ? i - radius : 0; j <= std::min(n - 1, i + radius); ++j) {
        if (j == i) continue;
        const float d = distance(clusters[i].box, clusters[j].box);
        if (best == n || d < best_d || (d == best_d && rank(i, j) < rank(i, best))) best = j, best_d = d;
      }
      nearest[i] = best;
    }
    std::vector<Cluster> next;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t j = nearest[i];
      if (nearest[j] != i) {
        next.push_back(clusters[i]);
      } else if (i < j) {
        next.push_back({merge(clusters[i].box, clusters[j].box),
                        "(" + clusters[i].shape + "," + clusters[j].shape + ")"});
      }
    }
    clusters = std::move(next);
  }
  return clusters[0].shape;
}

TEST(Ploc, ClustersAsTheSerialAlgorithmDoes) {
  std::vector<Triangle> clustered;  // many equal boxes: the tie rule decides
  for (int i = 0; i < 2000; ++i) clustered.push_back(test::random_triangles(1, i % 5)[0]);
  struct Case {
    std::string name;
    std::vector<Triangle> tris;
    uint32_t radius;
  };
  const std::vector<Case> cases = {
      {"random r=1", test::random_triangles(3000, 1), 1},
      {"random r=16", test::random_triangles(3000, 2), 16},
      // More clusters than one task's chunk: neighbours across chunks.
      {"random r=8 large", test::random_triangles(20000, 3), 8},
      {"clustered r=4", clustered, 4},
      {"identical r=16", std::vector<Triangle>(500, test::random_triangles(1, 9)[0]), 16}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Bvh bvh =
        test::build_tree("ploc", c.tris, {{"radius", std::to_string(c.radius)}, {"max_leaf", "1"}});
    ASSERT_TRUE(validate(bvh, c.tris).ok());
    EXPECT_EQ(shape(bvh), reference_shape(c.tris, c.radius));
  }
}

// Walter et al. 2008, "Fast agglomerative clustering for rendering": always merging the globally closest
// pair of clusters, here each merge put at the lower of the two places in the Morton order, as PLOC does.
std::string global_greedy_shape(const std::vector<Triangle>& tris) {
  const BuildInput input = BuildInput::from_triangles(tris);
  const MortonOrder<uint32_t> order = sort_by_morton<uint32_t>(input.bounds.span());
  std::vector<Aabb> boxes;
  std::vector<std::string> shapes;
  for (uint32_t id : order.ids) boxes.push_back(tris[id].bounds()), shapes.push_back(std::to_string(id));
  while (boxes.size() > 1) {
    std::size_t best_i = 0, best_j = 1;
    float best = std::numeric_limits<float>::infinity();
    for (std::size_t i = 0; i < boxes.size(); ++i)
      for (std::size_t j = i + 1; j < boxes.size(); ++j)
        if (const float a = merge(boxes[i], boxes[j]).half_area(); a < best) best = a, best_i = i, best_j = j;
    boxes[best_i] = merge(boxes[best_i], boxes[best_j]);
    shapes[best_i] = "(" + shapes[best_i] + "," + shapes[best_j] + ")";
    boxes.erase(boxes.begin() + static_cast<std::ptrdiff_t>(best_j));
    shapes.erase(shapes.begin() + static_cast<std::ptrdiff_t>(best_j));
  }
  return shapes[0];
}

TEST(Ploc, WithARadiusOverEveryClusterBuildsTheGlobalGreedyTree) {
  // Merged-box area never falls as a cluster grows, so merging mutual nearest neighbours gives the tree
  // that merging the closest pair first gives (Walter et al. 2008; Meister and Bittner 2018, section 3):
  // a check of the clustering against another algorithm, where the test above transcribes the same one.
  // Two candidates tie where their merged boxes with a cluster are one box (both lie inside it, as a
  // mesh's neighbours often do), and the two algorithms break ties differently: so small random
  // triangles, in a volume and, flattened, on a sheet.
  std::vector<Triangle> sheet = test::random_triangles(250, 6);
  for (Triangle& t : sheet)
    for (Vec3* v : {&t.v0, &t.v1, &t.v2}) v->y *= 0.05f;
  for (const auto& [name, tris] : {std::pair{"random", test::random_triangles(200, 5)}, {"sheet", sheet}}) {
    SCOPED_TRACE(name);
    ASSERT_LE(tris.size(), kPlocMaxRadius + 1);
    const Bvh bvh =
        test::build_tree("ploc", tris, {{"radius", std::to_string(kPlocMaxRadius)}, {"max_leaf", "1"}});
    ASSERT_TRUE(validate(bvh, tris).ok());
    EXPECT_EQ(shape(bvh), global_greedy_shape(tris));
  }
}

TEST(Ploc, SameTreeByteForByteOnOneAndTwoThreads) {
  // Several chunks per round in the first rounds, one in the last.
  const auto tris = test::random_triangles(100000, 21, 100.0f);
  for (const char* radius : {"1", "16"}) {
    auto with = [&](int threads) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      return test::build_tree("ploc", tris, {{"radius", radius}});
    };
    const Bvh one = with(1), two = with(2);
    ASSERT_EQ(one.nodes.size(), two.nodes.size());
    ASSERT_EQ(one.prim_refs.size(), two.prim_refs.size());
    EXPECT_EQ(std::memcmp(one.nodes.data(), two.nodes.data(), one.nodes.size() * sizeof(Node)), 0) << radius;
    EXPECT_EQ(
        std::memcmp(one.prim_refs.data(), two.prim_refs.data(), one.prim_refs.size() * sizeof(uint32_t)), 0)
        << radius;
  }
}

TEST(Ploc, IdenticalBoxesPairUpIntoABalancedTree) {
  // Every distance equal: the even-odd rule halves the clusters each round.
  const std::vector<Triangle> tris(4096, test::random_triangles(1, 4)[0]);
  const Bvh bvh = test::build_tree("ploc", tris, {{"max_leaf", "1"}});
  ASSERT_TRUE(validate(bvh, tris).ok());
  EXPECT_EQ(compute_stats(bvh, tris.size(), SahCost{}).max_depth, 12u);
}

TEST(Ploc, ChainsOfExponentiallySpacedTrianglesAreRebuiltWithinTheDepthLimit) {
  // Triangles at x = 2^k: each one's nearest neighbour is the one before it, so the clusters grow one
  // triangle at a time, a chain 119 deep.
  std::vector<Triangle> tris;
  for (int k = 0; k < 120; ++k) {
    const float x = std::ldexp(1.0f, k);
    tris.push_back({{x, 0, 0}, {x, 1, 0}, {x, 0, 1}});
  }
  for (const char* max_leaf : {"1", "8"}) {
    SCOPED_TRACE(max_leaf);
    const Bvh bvh = test::build_tree("ploc", tris, {{"max_leaf", max_leaf}});
    const ValidationReport report = validate(bvh, tris);
    ASSERT_TRUE(report.ok()) << report.summary();
    const BvhStats stats = compute_stats(bvh, tris.size(), SahCost{});
    EXPECT_LE(stats.max_depth, kClusterDepthLimit);
    EXPECT_GE(stats.max_depth, 50u);  // the chain above the rebuilt part stays
    const auto rays = test::random_rays(tris, 2000, 3);
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const Hit ref = brute_force_closest(tris, rays[i]);
      ASSERT_TRUE(test::same_closest_hit(closest_hit(bvh, tris, rays[i]), ref, tris, rays[i])) << "ray " << i;
    }
  }
}

TEST(Ploc, RejectsBadParameters) {
  const auto& info = find_builder("ploc");
  EXPECT_THROW(resolve_params(info.name, info.params, {{"radius", "0"}}), Error);
  EXPECT_THROW(resolve_params(info.name, info.params, {{"radius", "257"}}), Error);
  EXPECT_THROW(resolve_params(info.name, info.params, {{"bits", "64"}}), Error);
}

}  // namespace
}  // namespace sahbench
