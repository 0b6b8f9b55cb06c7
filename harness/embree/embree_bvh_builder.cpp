#include "harness/embree/embree_bvh_builder.h"

#include <embree3/rtcore_builder.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <memory>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include "builders/registry.h"
#include "core/error.h"
#include "core/threads.h"

namespace sahbench {
namespace {

constexpr const char* kBuilderName = "embree_bvh";
// Below this many primitives the RTCBuildPrimitive array is filled on the calling thread.
constexpr std::size_t kParallelFill = 1 << 14;

// A node of the temporary tree Embree builds through the callbacks. Inner nodes hold their children
// and the children's boxes (Embree gives a node's boxes to the node, not to the children), in arrays
// of the child count Embree asked for, allocated with the node; a leaf holds its primitive ids in the
// same allocation, right after the node.
struct TempNode {
  uint32_t child_count = 0;  // 0 for a leaf
  uint32_t prim_count = 0;
  TempNode** children = nullptr;  // inner: child_count children
  Aabb* child_bounds = nullptr;   // inner: their boxes
  uint32_t* prims = nullptr;      // leaf: prim_count ids
};
// Alignment requested from rtcThreadLocalAlloc: TempNode's own (the arrays after it need less).
constexpr std::size_t kTempNodeAlign = alignof(TempNode);
static_assert(sizeof(TempNode) % alignof(Aabb) == 0 && sizeof(Aabb) % alignof(TempNode*) == 0,
              "the child arrays follow the node, boxes first, each aligned");

// What the callbacks need: the triangles, for clipping in split_primitive.
struct BuildContext {
  std::span<const Triangle> triangles;
};

Aabb to_aabb(const RTCBounds& b) {
  return {{b.lower_x, b.lower_y, b.lower_z}, {b.upper_x, b.upper_y, b.upper_z}};
}

// RTCCreateNodeFunction: an empty inner node in Embree's thread-local allocator. Embree releases that
// memory with the RTCBVH, after we have flattened the tree.
void* create_node(RTCThreadLocalAllocator alloc, unsigned child_count, void* /*user*/) {
  const std::size_t bytes = sizeof(TempNode) + child_count * (sizeof(Aabb) + sizeof(TempNode*));
  auto* memory = static_cast<std::byte*>(rtcThreadLocalAlloc(alloc, bytes, kTempNodeAlign));
  auto* node = new (memory) TempNode;
  node->child_count = child_count;
  node->child_bounds = new (memory + sizeof(TempNode)) Aabb[child_count];
  node->children = new (memory + sizeof(TempNode) + child_count * sizeof(Aabb)) TempNode*[child_count]();
  return node;
}

// RTCSetNodeChildrenFunction. Embree passes the count it created the node with.
void set_node_children(void* node_ptr, void** children, unsigned count, void* /*user*/) {
  auto* node = static_cast<TempNode*>(node_ptr);
  node->child_count = std::min(count, node->child_count);
  for (unsigned c = 0; c < node->child_count; ++c) node->children[c] = static_cast<TempNode*>(children[c]);
}

// RTCSetNodeBoundsFunction.
void set_node_bounds(void* node_ptr, const RTCBounds** bounds, unsigned count, void* /*user*/) {
  auto* node = static_cast<TempNode*>(node_ptr);
  for (unsigned c = 0; c < std::min(count, node->child_count); ++c)
    node->child_bounds[c] = to_aabb(*bounds[c]);
}

// RTCCreateLeafFunction: the node and its primitive ids in one allocation.
void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t count,
                  void* /*user*/) {
  void* memory = rtcThreadLocalAlloc(alloc, sizeof(TempNode) + count * sizeof(uint32_t), kTempNodeAlign);
  auto* node = new (memory) TempNode;
  node->prim_count = static_cast<uint32_t>(count);
  node->prims = reinterpret_cast<uint32_t*>(static_cast<std::byte*>(memory) + sizeof(TempNode));
  for (size_t i = 0; i < count; ++i) std::construct_at(node->prims + i, prims[i].primID);
  return node;
}

// Our Vec3's operator[] is a chain of conditionals; the clipping loop indexes by a run-time axis.
using Floats = std::array<float, 3>;
static_assert(sizeof(Vec3) == sizeof(Floats), "Vec3 must be three packed floats");

// Outward rounding of a crossing point computed in double: moving x by 2^-23 |x| (at least half a
// float ulp of x, which is at most 2^-23 |x|) before rounding to nearest lands on the far side of x,
// and the absolute term covers x near 0 (FLT_MIN is far below any scene's resolution). Branch-free,
// unlike nextafter on the rounded value, whose 50/50 branches dominated the split callback's time.
constexpr double kRelativeUlp = 0x1p-23;
constexpr double kAbsolutePad = std::numeric_limits<float>::min();
float round_down(double x) {
  return static_cast<float>(x - (std::fabs(x) * kRelativeUlp + kAbsolutePad));
}
float round_up(double x) {
  return static_cast<float>(x + (std::fabs(x) * kRelativeUlp + kAbsolutePad));
}

// A box as two float arrays, extended and clipped per axis.
struct Box {
  Floats lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
            std::numeric_limits<float>::infinity()};
  Floats hi{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
            -std::numeric_limits<float>::infinity()};
};

// RTCSplitPrimitiveFunction for spatial splits (Stich, Friedrich and Dietrich 2009, "Spatial Splits in
// Bounding Volume Hierarchies", section 4.2; Embree's TriangleSplitter does the same): clip the
// reference's triangle at the plane `dim` = `pos`, bound each side's part (the vertices on that side
// and the points where edges cross the plane), and intersect those boxes with the reference's current
// box, which may already be a clipped part of the triangle. Crossing points are computed in double and
// rounded outward, so the boxes contain the exact clipped polygon. Embree calls this for every bin
// boundary a reference spans on every axis, millions of times per build, hence the plain arrays.
void split_primitive(const RTCBuildPrimitive* prim, unsigned dim, float pos, RTCBounds* left_out,
                     RTCBounds* right_out, void* user) {
  const auto& context = *static_cast<const BuildContext*>(user);
  const Triangle& tri = context.triangles[prim->primID];
  const Floats box_lo{prim->lower_x, prim->lower_y, prim->lower_z};
  const Floats box_hi{prim->upper_x, prim->upper_y, prim->upper_z};
  // Embree only splits references that straddle the plane; clamping keeps both halves well-formed
  // should it ever pass a plane on or outside the box.
  pos = std::clamp(pos, box_lo[dim], box_hi[dim]);

  const Floats v[3] = {std::bit_cast<Floats>(tri.v0), std::bit_cast<Floats>(tri.v1),
                       std::bit_cast<Floats>(tri.v2)};
  constexpr float kInf = std::numeric_limits<float>::infinity();
  Box left, right;
  // Selects instead of branches: which side a vertex lies on and whether an edge crosses are coin
  // flips to the branch predictor.
  for (int i = 0; i < 3; ++i) {
    const Floats& a = v[i];
    const Floats& b = v[i == 2 ? 0 : i + 1];
    const bool a_left = a[dim] <= pos, a_right = a[dim] >= pos;
    const bool crosses = ((a[dim] < pos) & (pos < b[dim])) | ((b[dim] < pos) & (pos < a[dim]));
    // Only used when the edge crosses, so b[dim] != a[dim].
    const double s = crosses ? (double(pos) - a[dim]) / (double(b[dim]) - a[dim]) : 0.0;
    for (std::size_t k = 0; k < 3; ++k) {
      const double x = double(a[k]) + s * (double(b[k]) - double(a[k]));
      const float lo = k == dim ? pos : round_down(x), hi = k == dim ? pos : round_up(x);
      left.lo[k] = std::min({left.lo[k], a_left ? a[k] : kInf, crosses ? lo : kInf});
      left.hi[k] = std::max({left.hi[k], a_left ? a[k] : -kInf, crosses ? hi : -kInf});
      right.lo[k] = std::min({right.lo[k], a_right ? a[k] : kInf, crosses ? lo : kInf});
      right.hi[k] = std::max({right.hi[k], a_right ? a[k] : -kInf, crosses ? hi : -kInf});
    }
  }

  // Each side's part clipped to its half of the current box. The triangle's part on a side may miss a
  // box that earlier clips already shrank (that box bounds a part, it is not the part); the half box
  // is then a loose but valid answer, and never inverted, which Embree's binning would not survive.
  auto write = [&](const Box& part, bool is_left, RTCBounds& out) {
    Floats lo = box_lo, hi = box_hi;
    (is_left ? hi : lo)[dim] = pos;
    Floats clo, chi;
    bool empty = false;
    for (std::size_t k = 0; k < 3; ++k) {
      clo[k] = std::max(part.lo[k], lo[k]);
      chi[k] = std::min(part.hi[k], hi[k]);
      empty |= clo[k] > chi[k];
    }
    if (!empty) lo = clo, hi = chi;
    out = {lo[0], lo[1], lo[2], 0.0f, hi[0], hi[1], hi[2], 0.0f};
  };
  write(left, true, *left_out);
  write(right, false, *right_out);
}

// Checks that need no input; run when a config is loaded, before any cell.
void check_param_values(const EmbreeBvhParams& p) {
  auto fail = [](const std::string& what) {
    throw Error(std::string("builder '") + kBuilderName + "': " + what);
  };
  if (p.min_leaf < 1 || p.max_leaf < 1 || p.max_leaf > kEmbreeMaxLeafPrims)
    fail("leaf sizes must lie in 1.." + std::to_string(kEmbreeMaxLeafPrims) +
         " (min_leaf=" + std::to_string(p.min_leaf) + ", max_leaf=" + std::to_string(p.max_leaf) + ")");
  if (p.min_leaf > p.max_leaf)
    fail("min_leaf=" + std::to_string(p.min_leaf) + " is larger than max_leaf=" + std::to_string(p.max_leaf));
  if (p.arity != 2 && p.arity != 4 && p.arity != 8)
    fail("arity=" + std::to_string(p.arity) + " is not 2, 4 or 8");
  if (p.max_depth < 1 || p.max_depth > kMaxDepth)
    fail("max_depth=" + std::to_string(p.max_depth) + " is outside 1.." + std::to_string(kMaxDepth));
  if (!std::has_single_bit(p.sah_block))
    fail("sah_block=" + std::to_string(p.sah_block) + " is not a power of two");
  if (!(p.split_factor >= 1.0f && p.split_factor <= kEmbreeMaxSplitFactor))
    fail("split_factor=" + std::to_string(p.split_factor) + " is outside 1.." +
         std::to_string(kEmbreeMaxSplitFactor));
}

void check_params(const BuildInput& input, const EmbreeBvhParams& p) {
  auto fail = [](const std::string& what) {
    throw Error(std::string("builder '") + kBuilderName + "': " + what);
  };
  check_param_values(p);
  if (p.quality == EmbreeQuality::kHigh && input.triangles.size() != input.size())
    fail("quality high (spatial splits) needs the triangles in the BuildInput (" +
         std::to_string(input.triangles.size()) + " triangles for " + std::to_string(input.size()) +
         " bounds)");
  if (input.size() > std::numeric_limits<uint32_t>::max() / 4)
    fail(std::to_string(input.size()) + " primitives are too many for 32-bit references");
}

// Flattens the temporary tree depth first: children of a node stored contiguously, the first child's
// subtree right after them, leaf references in visiting order. A one-child node (which Embree should
// never produce) is replaced by its child.
Bvh flatten(const TempNode* root, const Aabb& root_bounds, std::size_t reference_hint, uint32_t arity) {
  Bvh bvh;
  bvh.arity = arity;
  bvh.prim_refs.reserve(reference_hint);
  bvh.nodes.reserve(2 * reference_hint);
  struct Item {
    const TempNode* node;
    uint32_t index;
    uint32_t depth;
  };
  auto skip_single = [](const TempNode* n) {
    while (n->child_count == 1) n = n->children[0];
    return n;
  };
  bvh.nodes.push_back({root_bounds, 0, 0, 0});
  std::vector<Item> stack{{skip_single(root), 0, 0}};
  while (!stack.empty()) {
    const Item item = stack.back();
    stack.pop_back();
    if (item.depth > kMaxDepth)
      throw Error(std::string("builder '") + kBuilderName + "': Embree's tree is deeper than " +
                  std::to_string(kMaxDepth));
    const TempNode& t = *item.node;
    if (t.child_count > arity)
      throw Error(std::string("builder '") + kBuilderName + "': Embree made a node of " +
                  std::to_string(t.child_count) + " children for arity " + std::to_string(arity));
    if (t.child_count == 0) {
      if (t.prim_count == 0 || t.prim_count > kMaxLeafPrims)
        throw Error(std::string("builder '") + kBuilderName + "': Embree made a leaf of " +
                    std::to_string(t.prim_count) + " primitives");
      Node& leaf = bvh.nodes[item.index];
      leaf.first = static_cast<uint32_t>(bvh.prim_refs.size());
      leaf.prim_count = static_cast<uint16_t>(t.prim_count);
      bvh.prim_refs.insert(bvh.prim_refs.end(), t.prims, t.prims + t.prim_count);
      continue;
    }
    const auto first = static_cast<uint32_t>(bvh.nodes.size());
    bvh.nodes[item.index].first = first;
    bvh.nodes[item.index].child_count = static_cast<uint16_t>(t.child_count);
    for (uint32_t c = 0; c < t.child_count; ++c) bvh.nodes.push_back({t.child_bounds[c], 0, 0, 0});
    // Last child pushed first so the first child's subtree is laid out right after the children.
    for (uint32_t c = t.child_count; c-- > 0;)
      stack.push_back({skip_single(t.children[c]), first + c, item.depth + 1});
  }
  return bvh;
}

// Releases the RTCBVH (and with it every temporary node) on every path out of the build.
struct BvhHandle {
  RTCBVH bvh;
  ~BvhHandle() { rtcReleaseBVH(bvh); }
};

}  // namespace

Bvh build_embree_bvh(const BuildInput& input, const EmbreeBvhParams& params) {
  check_params(input, params);
  const std::size_t n = input.size();
  if (n == 0) return Bvh{};

  // One RTCBuildPrimitive per primitive: its box, geomID 0 and primID = our primitive index. Spatial
  // splits append references behind them, up to the capacity.
  const bool spatial = params.quality == EmbreeQuality::kHigh;
  const std::size_t capacity =
      spatial ? std::max(n, static_cast<std::size_t>(std::ceil(double(params.split_factor) * double(n)))) : n;
  // RTCBuildPrimitive is 32-byte aligned; new[] of an over-aligned type uses aligned operator new.
  auto prims = std::make_unique_for_overwrite<RTCBuildPrimitive[]>(capacity);
  Aabb root_bounds;
  auto fill = [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Aabb& b = input.bounds[i];
      prims[i] = {b.min.x, b.min.y, b.min.z, 0u, b.max.x, b.max.y, b.max.z, static_cast<unsigned>(i)};
    }
  };
  if (n < kParallelFill) {
    fill(0, n);
  } else {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n),
                      [&](const auto& r) { fill(r.begin(), r.end()); });
  }
  for (std::size_t i = 0; i < n; ++i) root_bounds.extend(input.bounds[i]);

  EmbreeDevice device(caller_threads());
  const BvhHandle handle{rtcNewBVH(device.get())};
  device.check("rtcNewBVH");

  BuildContext context{input.triangles};
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.buildQuality = to_rtc(params.quality);
  args.buildFlags = RTC_BUILD_FLAG_NONE;
  args.maxBranchingFactor = params.arity;
  args.maxDepth = params.max_depth;
  args.sahBlockSize = params.sah_block;
  args.minLeafSize = params.min_leaf;
  args.maxLeafSize = params.max_leaf;
  args.traversalCost = params.cost.c_trav;
  args.intersectionCost = params.cost.c_isect;
  args.bvh = handle.bvh;
  args.primitives = prims.get();
  args.primitiveCount = n;
  args.primitiveArrayCapacity = capacity;
  args.createNode = create_node;
  args.setNodeChildren = set_node_children;
  args.setNodeBounds = set_node_bounds;
  args.createLeaf = create_leaf;
  args.splitPrimitive = spatial ? split_primitive : nullptr;
  args.buildProgress = nullptr;
  args.userPtr = &context;

  const void* root = rtcBuildBVH(&args);
  device.check("rtcBuildBVH");
  if (!root) throw Error(std::string("builder '") + kBuilderName + "': rtcBuildBVH returned no tree");
  return flatten(static_cast<const TempNode*>(root), root_bounds, capacity, params.arity);
}

static_assert(static_cast<int>(EmbreeQuality::kLow) == 0 && static_cast<int>(EmbreeQuality::kMedium) == 1 &&
                  static_cast<int>(EmbreeQuality::kHigh) == 2,
              "the quality parameter's choices low, medium, high are EmbreeQuality's values 0, 1, 2");

void register_embree_builders() {
  for (const auto& b : builders())
    if (b.name == kBuilderName) return;
  const EmbreeBvhParams defaults;
  std::vector<ParamSpec> params = {
      // Named as for the `embree` builder (rtcCommitScene), so one config can ask both for "high".
      choice_param("quality", {"low", "medium", "high"}, static_cast<uint32_t>(defaults.quality),
                   "low (Morton codes), medium (binned SAH), high (binned SAH with spatial splits)"),
      {"arity", ParamType::kInt, double(defaults.arity), 2, kMaxArity,
       "maxBranchingFactor: children per inner node, 2, 4 or 8 (wide nodes filled by splitting the child of "
       "largest area, as Embree's BVH4/BVH8 builders do)"},
      {"min_leaf", ParamType::kInt, double(defaults.min_leaf), 1, kEmbreeMaxLeafPrims,
       "minLeafSize: nodes with this many primitives or fewer become leaves"},
      {"max_leaf", ParamType::kInt, double(defaults.max_leaf), 1, kEmbreeMaxLeafPrims,
       "maxLeafSize: nodes with more primitives are always split"},
      {"c_trav", ParamType::kFloat, defaults.cost.c_trav, 0, 1e6,
       "traversalCost: SAH cost of visiting an inner node"},
      {"c_isect", ParamType::kFloat, defaults.cost.c_isect, 1e-6, 1e6,
       "intersectionCost: SAH cost of one ray/triangle test"},
      {"max_depth", ParamType::kInt, double(defaults.max_depth), 1, kMaxDepth,
       "maxDepth: deepest node, root = 1; deeper builds fail"},
      {"sah_block", ParamType::kInt, double(defaults.sah_block), 1, kEmbreeMaxLeafPrims,
       "sahBlockSize: leaf SAH counts blocks of this many primitives (power of two)"},
      {"split_factor", ParamType::kFloat, kEmbreeDefaultSplitFactor, 1, kEmbreeMaxSplitFactor,
       "quality 2: reference capacity per primitive for spatial splits (1: none)"},
  };
  auto from = [](const ParamSet& p) {
    EmbreeBvhParams e;
    e.quality = static_cast<EmbreeQuality>(p.get_uint("quality"));
    e.arity = p.get_uint("arity");
    e.min_leaf = p.get_uint("min_leaf");
    e.max_leaf = p.get_uint("max_leaf");
    e.cost = sah_cost_of(p);
    e.max_depth = p.get_uint("max_depth");
    e.sah_block = p.get_uint("sah_block");
    e.split_factor = p.get_float("split_factor");
    return e;
  };
  register_builder(
      {kBuilderName,
       "Embree 3 rtcBuildBVH, 2-, 4- or 8-wide (Morton / binned SAH / spatial splits by quality)",
       std::move(params),
       [from](const BuildInput& input, const ParamSet& p) { return build_embree_bvh(input, from(p)); },
       [from](const ParamSet& p) { check_param_values(from(p)); },
       [](const ParamSet& p) { return p.get_uint("arity"); }});
}

}  // namespace sahbench
