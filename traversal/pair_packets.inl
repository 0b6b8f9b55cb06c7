// Packet kernels on the binary layouts (bvh2_packed's PairNodes, and bvh2, the common format as built): K
// rays go down the tree together, each node read once for all of them and each of its two child boxes
// tested against the K rays in one K-lane slab test, the
// packet traversal of binary BVHs of Wald, Boulos and Shirley 2007 ("Ray Tracing Deformable Scenes Using
// Dynamic Bounding Volume Hierarchies"), without its frustum test. A binary tree takes several times as
// many node visits per ray as a wide one, and one ray's visit is a chain of a dependent load, a box test
// and a branch; a packet pays that chain once for K rays. Compiled for AVX2 and AVX-512 only
// (wide_kernels_avx2.cpp, wide_kernels_avx512.cpp include it after wide_packets.inl, whose lanes, packet
// rays and box test it uses).
//
// Packets are the batch's rays K at a time, in the ray set's own order, as for the wide packet kernels.
// A packet's rays go down the tree together whatever their directions (box=fma: those in that test's
// domain; the others are traced by the single-ray kernel, eight walks in turn (trace_walks)). Where they
// agree on the sign of each direction component, one near and one far plane per axis serve all K; where they
// do not (shadow rays to several lights, diffuse and AO rays), each lane picks its planes by its own signs, a
// blend before the same arithmetic (Embree's packet node test takes the min and max of both planes' distances
// per lane, to the same end), rather than the packet being split by octant into fragments of two or
// three rays. Each lane computes the single-ray kernel's slab
// test (PairSlabs: the same products, the far distances scaled the same way, the same NaN rule) and every
// leaf's triangles are tested ray by ray by the single-ray walks' leaf loop (detail::test_leaf, four
// triangles at a time) or, tri=watertight and tri=mtn where enough of the packet enters the leaf, a
// triangle at a time against all its rays with each lane's ray's own operations (packet_leaf_watertight,
// packet_leaf_mtn), so every ray gets the hit it gets alone, up to a tie within a rounding that the other
// order of the visits breaks the other way.

// The BoxTestKind of a box test class of ray_box.h.
template <class Box>
inline constexpr BoxTestKind kBoxKindOf = std::is_same_v<Box, FmaRayBox>    ? BoxTestKind::kFma
                                          : std::is_same_v<Box, FastRayBox> ? BoxTestKind::kFast
                                                                            : BoxTestKind::kRobust;

// A binary tree as the packet kernel walks it: bvh2_packed's PairNodes, a node's line holding both
// children's boxes plane by plane (seen two floats apart, one child's planes are min x, max x, min y, ...)
// and what each child is; a leaf's triangles copied into leaf order, hits reported by their packed index.
struct PackedPairTree {
  const PackedBvh2& tree;
  static constexpr uint32_t kStride = 2;
  // The index of a child's plane on `axis` (max: its far plane for a positive direction).
  static constexpr uint32_t plane(uint32_t axis, bool max) { return 2 * axis + (max ? 1 : 0); }
  uint32_t root() const { return tree.root; }
  const Aabb& root_box() const { return tree.root_box; }
  SAHBENCH_KERNEL_INLINE const float* child_planes(uint32_t node, int c) const {
    return &tree.nodes[node].planes[0][c];
  }
  // Child c of inner node `node`: an inner node's index (count 0), or a leaf's first triangle and count.
  SAHBENCH_KERNEL_INLINE void child(uint32_t node, int c, uint32_t& index, uint32_t& count) const {
    index = tree.nodes[node].child[c];
    count = tree.nodes[node].count[c];
  }
  // The triangle at position `slot` of a leaf, the index a hit reports and the scene index ties go by.
  SAHBENCH_KERNEL_INLINE const Triangle& triangle(uint32_t slot) const { return tree.triangles[slot]; }
  // Asks for the line a child's visit reads first: its node, or its leaf's first triangle.
  SAHBENCH_KERNEL_INLINE void prefetch(uint32_t index, uint32_t count) const {
    __builtin_prefetch(count != 0 ? static_cast<const void*>(&tree.triangles[index])
                                  : static_cast<const void*>(&tree.nodes[index]));
  }
  SAHBENCH_KERNEL_INLINE uint32_t prim(uint32_t slot) const { return slot; }
  SAHBENCH_KERNEL_INLINE uint32_t scene_index(uint32_t prim) const { return tree.ids[prim]; }
  // The triangles at slots [slot, slot + n) against one ray by a four-lane test (triangle_lanes.h).
  template <bool kRefine, class Lanes>
  SAHBENCH_KERNEL_INLINE unsigned four(const Lanes& test, uint32_t slot, uint32_t n, float tmin, float tmax,
                                       float* t, float* u, float* v) const {
    return test.template intersect<kRefine>(&tree.triangles[slot], n, tmin, tmax, t, u, v);
  }
};

// The common format as built: a node's two children side by side from its `first`, each with its box
// (min x, min y, min z, max x, ...); a leaf's triangles through the references, hits reported by scene
// index.
struct CommonPairTree {
  const Bvh& bvh;
  const Triangle* triangles;
  static constexpr uint32_t kStride = 1;
  static constexpr uint32_t plane(uint32_t axis, bool max) { return axis + (max ? 3 : 0); }
  uint32_t root() const { return 0; }
  const Aabb& root_box() const { return bvh.nodes[0].bounds; }
  SAHBENCH_KERNEL_INLINE const float* child_planes(uint32_t node, int c) const {
    static_assert(sizeof(Aabb) == 6 * sizeof(float), "a box is its six planes, min then max");
    return &bvh.nodes[bvh.nodes[node].first + static_cast<uint32_t>(c)].bounds.min.x;
  }
  SAHBENCH_KERNEL_INLINE void child(uint32_t node, int c, uint32_t& index, uint32_t& count) const {
    const uint32_t n = bvh.nodes[node].first + static_cast<uint32_t>(c);
    const Node& child = bvh.nodes[n];
    index = child.is_leaf() ? child.first : n;
    count = child.prim_count;
  }
  SAHBENCH_KERNEL_INLINE const Triangle& triangle(uint32_t slot) const {
    return triangles[bvh.prim_refs[slot]];
  }
  // Asks for the line a child's visit reads first: its children's boxes, or its leaf's references.
  SAHBENCH_KERNEL_INLINE void prefetch(uint32_t index, uint32_t count) const {
    __builtin_prefetch(count != 0 ? static_cast<const void*>(&bvh.prim_refs[index])
                                  : static_cast<const void*>(&bvh.nodes[bvh.nodes[index].first]));
  }
  SAHBENCH_KERNEL_INLINE uint32_t prim(uint32_t slot) const { return bvh.prim_refs[slot]; }
  SAHBENCH_KERNEL_INLINE uint32_t scene_index(uint32_t prim) const { return prim; }
  template <bool kRefine, class Lanes>
  SAHBENCH_KERNEL_INLINE unsigned four(const Lanes& test, uint32_t slot, uint32_t n, float tmin, float tmax,
                                       float* t, float* u, float* v) const {
    return test.template intersect<kRefine>(triangles, &bvh.prim_refs[slot], n, tmin, tmax, t, u, v);
  }
};

// A leaf of `Tree` as the single-ray walks' leaf loop takes it (detail::test_leaf): its triangles at
// slots [first, first + size).
template <class Tree>
struct PairTreeLeaf {
  const Tree& tree;
  uint32_t first, size;
  SAHBENCH_KERNEL_INLINE const Triangle& triangle(uint32_t k) const { return tree.triangle(first + k); }
  SAHBENCH_KERNEL_INLINE uint32_t prim(uint32_t k) const { return tree.prim(first + k); }
  SAHBENCH_KERNEL_INLINE uint32_t scene_index(uint32_t prim) const { return tree.scene_index(prim); }
  template <bool kRefine, class Lanes>
  SAHBENCH_KERNEL_INLINE unsigned four(const Lanes& test, uint32_t k, uint32_t n, float tmin, float tmax,
                                       float* t, float* u, float* v) const {
    return tree.template four<kRefine>(test, first + k, n, tmin, tmax, t, u, v);
  }
};

// tri=watertight: each lane's ray's permutation and shear (WatertightShear), for the test of one
// triangle against all the packet's rays (packet_leaf_watertight). A triangle's coordinates are the same
// in every lane, each lane takes them in its own ray's order: `uniform` where the packet's rays share
// one order (a common largest axis, and the same sign along it: the usual case), else per lane by selects.
template <class P>
struct PacketShear {
  using V = typename P::V;
  V org[3];    // each lane's origin on its kx, ky and kz
  V shear[3];  // its sx, sy and sz
  bool uniform;
  uint32_t axis[3];           // uniform: the packet's kx, ky and kz
  uint32_t is_x[3], is_y[3];  // else: the lanes whose kx (ky, kz) is x, y (z in the others)

  // (x, y, z)'s coordinate on kx (slot 0), ky (1) or kz (2) of each lane's ray.
  SAHBENCH_KERNEL_INLINE V permuted(const Vec3& p, uint32_t slot) const {
    const detail::Components c = detail::components(p);
    if (uniform) return P::set1(c[axis[slot]]);
    return P::select(is_x[slot], P::set1(c[0]), P::select(is_y[slot], P::set1(c[1]), P::set1(c[2])));
  }
};

template <class P>
SAHBENCH_KERNEL_INLINE PacketShear<P> make_packet_shear(const WatertightLanes* tests, uint32_t mask) {
  alignas(64) float lanes[6][P::kWidth];
  PacketShear<P> s;
  const WatertightShear& lead = tests[__builtin_ctz(mask)].one().shear();
  s.uniform = true;
  for (uint32_t slot = 0; slot < 3; ++slot) s.is_x[slot] = s.is_y[slot] = 0;
  s.axis[0] = lead.kx;
  s.axis[1] = lead.ky;
  s.axis[2] = lead.kz;
  for (uint32_t j = 0; j < P::kWidth; ++j) {
    const WatertightShear& w = tests[j].one().shear();  // unused lanes hold ray 0's test
    const detail::Components o = detail::components(tests[j].one().org());
    const uint8_t k[3] = {w.kx, w.ky, w.kz};
    for (uint32_t slot = 0; slot < 3; ++slot) {
      lanes[slot][j] = o[k[slot]];
      s.is_x[slot] |= uint32_t{k[slot] == 0} << j;
      s.is_y[slot] |= uint32_t{k[slot] == 1} << j;
      if (mask >> j & 1u && k[slot] != s.axis[slot]) s.uniform = false;
    }
    lanes[3][j] = w.sx;
    lanes[4][j] = w.sy;
    lanes[5][j] = w.sz;
  }
  for (uint32_t slot = 0; slot < 3; ++slot) {
    s.org[slot] = P::load(lanes[slot]);
    s.shear[slot] = P::load(lanes[3 + slot]);
  }
  return s;
}

// Whether a leaf of `triangles` is cheaper tested a triangle at a time against the packet's `rays`
// entering it (packet_leaf_watertight, packet_leaf_mtn) than ray by ray four triangles at a time
// (test_leaf): one triangle against K lanes costs about what one ray against four triangles does.
SAHBENCH_KERNEL_INLINE bool packet_leaf_pays(uint32_t rays, uint32_t triangles) {
  return rays * ((triangles + 3) / 4) > triangles;
}

// Each lane j of `hits` hit triangle slot `k` of `tree` at t[j] (u[j], v[j]): taken as test_leaf takes a
// hit where `keep(j)` keeps it (which may first refine t[j] in place). Any hit ends the ray's walk (its
// best_t becomes NaN and its lane leaves `lanes`); closest hit keeps the nearer (detail::take_closer).
template <bool kAnyHit, class Tree, class Keep>
SAHBENCH_KERNEL_INLINE void take_lane_hits(const Tree& tree, uint32_t k, uint32_t hits, float* t,
                                           const float* u, const float* v, const Keep& keep, Hit* best,
                                           float* best_t, uint32_t& lanes) {
  const uint32_t prim = tree.prim(k);
  for (; hits; hits &= hits - 1) {
    const uint32_t j = static_cast<uint32_t>(__builtin_ctz(hits));
    if (!keep(j)) continue;
    if constexpr (kAnyHit) {
      best[j] = {prim, t[j], u[j], v[j]};
      best_t[j] = __builtin_nanf("");
      lanes &= ~(1u << j);
    } else {
      detail::take_closer(
          prim, t[j], u[j], v[j], [&](uint32_t p) { return tree.scene_index(p); }, best_t[j], best[j]);
    }
  }
}

// tri=watertight: the triangles of a leaf (slots [first, first + count) of `tree`) against the packet's
// rays in `lanes`, one triangle at a time in K lanes (watertight_in_lanes with the rays in the lanes),
// as Embree's packet intersectors test a triangle against K rays. Each lane computes the scalar test's
// float operations on its own ray, against that ray's closest hit so far, and a hit is checked (closest
// hit: its distance refined; any hit: any_hit_holds) and taken as test_leaf takes it, in leaf order: each
// ray gets the hits it gets alone. Updates best and
// best_t as test_leaf and its caller do (any hit: a ray that hits gets a NaN best_t).
template <class P, bool kAnyHit, class Tree>
SAHBENCH_KERNEL_INLINE void packet_leaf_watertight(const Tree& tree, uint32_t first, uint32_t count,
                                                   const PacketShear<P>& s, const WatertightLanes* tests,
                                                   const float* tmin, uint32_t lanes, Hit* best,
                                                   float* best_t) {
  using V = typename P::V;
  const auto in_double = [](float ax, float ay, float az, float bx, float by, float bz, float cx, float cy,
                            float cz, float lo, float hi, float& t, float& u, float& v) {
    return watertight_in_double(ax, ay, az, bx, by, bz, cx, cy, cz, lo, hi, t, u, v);
  };
  const V lo = P::load(tmin);
  for (uint32_t k = first; k < first + count && lanes; ++k) {
    const Triangle& tri = tree.triangle(k);
    const V vertex[3][3] = {{s.permuted(tri.v0, 0), s.permuted(tri.v0, 1), s.permuted(tri.v0, 2)},
                            {s.permuted(tri.v1, 0), s.permuted(tri.v1, 1), s.permuted(tri.v1, 2)},
                            {s.permuted(tri.v2, 0), s.permuted(tri.v2, 1), s.permuted(tri.v2, 2)}};
    alignas(64) float t[P::kWidth], u[P::kWidth], v[P::kWidth];
    uint32_t hits = watertight_in_lanes<typename P::Ops>(vertex, s.org, s.shear, P::mask_vector(lanes), lo,
                                                         P::load(best_t), t, u, v, in_double);
    // Closest hit refines every hit; any hit only those whose float decision cannot stand (any_hit_holds).
    const auto keep = [&](uint32_t j) __attribute__((always_inline)) {
      const WatertightTriangleTest& one = tests[j].one();
      if constexpr (kAnyHit) return any_hit_holds(one, tri, tmin[j], best_t[j], t[j]);
      return refine_watertight_t(tri.v0, tri.v1, tri.v2, one.org(), one.dir(), tmin[j], best_t[j], t[j]);
    };
    take_lane_hits<kAnyHit>(tree, k, hits, t, u, v, keep, best, best_t, lanes);
  }
}

// tri=mtn: the triangles of a leaf against the packet's rays in `lanes`, a triangle at a time in K lanes
// (intersect_mtn_lanes with the rays in the lanes; the wide packets' packet_leaf_mtn on a binary leaf):
// the triangle's edges and normal computed once by the scalar test's operations, each lane the scalar
// test's float operations on its own ray. A triangle or a ray outside the float test's range
// (mtn_triangle_in_range, MollerTrumboreNormalTest::ray_in_range) goes through the scalar test, which
// decides it in double. Each ray's hits are taken in leaf order as test_leaf takes them.
template <class P, bool kAnyHit, class Tree>
SAHBENCH_KERNEL_INLINE void packet_leaf_mtn(const Tree& tree, uint32_t first, uint32_t count,
                                            const RayLanes<typename P::Ops>& rays, uint32_t in_range,
                                            const MollerTrumboreNormalLanes* tests, const float* tmin,
                                            uint32_t lanes, Hit* best, float* best_t) {
  for (uint32_t k = first; k < first + count && lanes; ++k) {
    const Triangle& tri = tree.triangle(k);
    const Vec3 edge1 = tri.v1 - tri.v0, edge2 = tri.v2 - tri.v0;
    const Vec3 normal = stored_normal(edge1, edge2);
    alignas(64) float t[P::kWidth], u[P::kWidth], v[P::kWidth];
    uint32_t alone = lanes, hits = 0;
    if (mtn_triangle_in_range(tri.v0, edge1, edge2, normal)) {
      const detail::Components parts[4] = {detail::components(tri.v0), detail::components(edge1),
                                           detail::components(edge2), detail::components(normal)};
      auto load = [&](int part, int axis) __attribute__((always_inline)) {
        return P::set1(parts[part][axis]);
      };
      RayLanes<typename P::Ops> r = rays;
      r.tmax = P::load(best_t);
      hits = intersect_mtn_lanes<typename P::V, typename P::Ops>(P::mask_vector(lanes & in_range), load, r, t,
                                                                 u, v);
      alone = lanes & ~in_range;
    }
    for (uint32_t m = alone; m; m &= m - 1) [[unlikely]] {
        const uint32_t j = static_cast<uint32_t>(__builtin_ctz(m));
        if (tests[j].one().intersect(tri, tmin[j], best_t[j], t[j], u[j], v[j])) hits |= 1u << j;
      }
    const auto keep = [](uint32_t) { return true; };  // the scalar test's t needs no refinement
    take_lane_hits<kAnyHit>(tree, k, hits, t, u, v, keep, best, best_t, lanes);
  }
}

// The packet's slab constants from each ray's SlabSetup, as the single-ray box tests take them, and the
// near and far planes of `Tree`'s numbering: those of the octant of ray `lead`, or (kPerLane) the min
// and max planes, with the lanes of a negative direction on each axis.
template <class P, class Tree, bool kPerLane>
SAHBENCH_KERNEL_INLINE PacketRays<P> make_pair_packet(const Ray* rays, uint32_t n, uint32_t lead) {
  alignas(64) float lanes[13][P::kWidth];
  PacketRays<P> p;
  p.mtn_in_double = 0;
  p.negative[0] = p.negative[1] = p.negative[2] = 0;
  for (uint32_t j = 0; j < P::kWidth; ++j) {
    const Ray& r = rays[j < n ? j : 0];  // unused lanes copy ray 0 and are never active
    const detail::SlabSetup setup(r);
    const float dir[3] = {r.dir.x, r.dir.y, r.dir.z};
    for (uint32_t axis = 0; axis < 3; ++axis) {
      lanes[axis][j] = setup.org[axis];
      lanes[3 + axis][j] = dir[axis];
      lanes[6 + axis][j] = setup.inv_dir[axis];
      lanes[9 + axis][j] = setup.org[axis] * setup.inv_dir[axis];
      p.negative[axis] |= uint32_t{setup.negative[axis]} << j;
    }
    lanes[12][j] = r.tmin;
  }
  const detail::SlabSetup first(rays[lead]);
  for (uint32_t axis = 0; axis < 3; ++axis) {
    p.org[axis] = P::load(lanes[axis]);
    p.dir[axis] = P::load(lanes[3 + axis]);
    p.inv[axis] = P::load(lanes[6 + axis]);
    p.org_inv[axis] = P::load(lanes[9 + axis]);
    const bool negative = !kPerLane && first.negative[axis];
    p.near_plane[axis] = Tree::plane(axis, negative);
    p.far_plane[axis] = Tree::plane(axis, !negative);
  }
  p.tmin = P::load(lanes[12]);
  return p;
}

// The rays of `mask` among rays [0, n) as one packet (kPerLane: of more than one direction octant),
// closest hits (the indices Tree::prim reports) into hits[j] or occlusion into occluded[j] for each j of
// `mask`. The tree's root is an inner node. Flattened: the single-ray code it calls (the triangle tests, the
// ray set-up) is inlined here, compiled for this instruction set, and leaves no out-of-line copy that the
// linker could pick for the baseline callers. Closest hit goes first to the child that more of the rays
// entering both enter nearer, and skips, per lane, entries beyond that ray's closest hit so far; any hit
// takes `order` as the single-ray walk does, nearer by the same vote, and drops each ray at its first hit.
template <class P, class Tri, class Box, bool kAnyHit, bool kPerLane, class Tree>
[[gnu::flatten]] void trace_pair_packet(const Tree& tree, const Ray* rays, uint32_t n, uint32_t mask,
                                        AnyHitOrder order, Hit* hits, uint8_t* occluded) {
  using V = typename P::V;
  constexpr uint32_t K = P::kWidth;
  constexpr BoxTestKind kBox = kBoxKindOf<Box>;
  const PacketRays<P> p =
      make_pair_packet<P, Tree, kPerLane>(rays, n, static_cast<uint32_t>(__builtin_ctz(mask)));
  const V nan = P::set1(__builtin_nanf(""));
  alignas(64) float best_t[K];
  alignas(64) float tmin[K];
  for (uint32_t j = 0; j < K; ++j) {
    best_t[j] = mask >> j & 1u ? far_limit(rays[j]) : __builtin_nanf("");
    tmin[j] = rays[j < n ? j : 0].tmin;
  }
  Hit best[K];
  // Each ray's leaf test, set up once (the watertight test's shear, for one): the single-ray walks'
  // four-lane form where the test has one.
  using LeafTest = LeafTestOf<Tri>;
  union Tests {
    Tests() {}
    LeafTest lane[K];
  } tests;
  for (uint32_t j = 0; j < K; ++j) new (&tests.lane[j]) LeafTest(rays[j < n ? j : 0]);
  static_assert(std::is_trivially_destructible_v<LeafTest>);
  constexpr bool kWatertight = std::is_same_v<Tri, WatertightTriangleTest>;
  constexpr bool kMtn = std::is_same_v<Tri, MollerTrumboreNormalTest>;
  [[maybe_unused]] PacketShear<P> shear;
  if constexpr (kWatertight) shear = make_packet_shear<P>(tests.lane, mask);
  // tri=mtn: the rays' origins and directions in lanes, and the rays within the float test's range.
  [[maybe_unused]] RayLanes<typename P::Ops> mtn_rays;
  [[maybe_unused]] uint32_t mtn_in_range = 0;
  if constexpr (kMtn) {
    alignas(64) float lanes[6][K];
    for (uint32_t j = 0; j < K; ++j) {
      const MollerTrumboreNormalTest& one = tests.lane[j].one();
      const detail::Components o = detail::components(one.org()), d = detail::components(one.dir());
      for (uint32_t axis = 0; axis < 3; ++axis) {
        lanes[axis][j] = o[axis];
        lanes[3 + axis][j] = d[axis];
      }
      mtn_in_range |= uint32_t{one.ray_in_range()} << j;
    }
    for (uint32_t axis = 0; axis < 3; ++axis) {
      mtn_rays.org[axis] = P::load(lanes[axis]);
      mtn_rays.dir[axis] = P::load(lanes[3 + axis]);
    }
    mtn_rays.tmin = P::load(tmin);
    mtn_rays.tmax = mtn_rays.tmin;  // each triangle's test takes the rays' closest hits so far
  }

  float root_planes[6];  // the root's box in Tree's numbering, one float apart
  for (uint32_t axis = 0; axis < 3; ++axis) {
    root_planes[Tree::plane(axis, false)] = tree.root_box().min[axis];
    root_planes[Tree::plane(axis, true)] = tree.root_box().max[axis];
  }
  uint32_t root_mask;
  const V t_root = packet_enter<P, kBox, kPerLane>(root_planes, 1, p, P::load(best_t), root_mask);
  const bool nearest_first =
      !kAnyHit || order == AnyHitOrder::kNearest || order == AnyHitOrder::kNearestStored;
  const bool farthest_first = kAnyHit && order == AnyHitOrder::kFarthestStored;

  PacketEntry<P> stack[detail::kStackCapacity];
  uint32_t size = 0;
  PacketEntry<P> entry{P::select(root_mask, t_root, nan), tree.root(), 0};
  while (root_mask != 0) {
    const V tmax = P::load(best_t);
    const uint32_t lanes = P::le(entry.t_entry, tmax);
    if (lanes != 0) {
      if (entry.count != 0) {
        // A triangle at a time against the rays entering the leaf where that pays (tri=watertight, mtn),
        // else ray by ray by the single-ray walks' leaf loop, its triangles four at a time where the test
        // has lanes: either way a ray's answer is the one it gets alone (on a tie the lowest scene index
        // wins).
        uint32_t alone = lanes;  // the rays that test the leaf one at a time
        if constexpr (kWatertight) {
          if (packet_leaf_pays(static_cast<uint32_t>(std::popcount(lanes)), entry.count)) {
            packet_leaf_watertight<P, kAnyHit>(tree, entry.child, entry.count, shear, tests.lane, tmin, lanes,
                                               best, best_t);
            alone = 0;
          }
        }
        if constexpr (kMtn) {
          if (packet_leaf_pays(static_cast<uint32_t>(std::popcount(lanes)), entry.count)) {
            packet_leaf_mtn<P, kAnyHit>(tree, entry.child, entry.count, mtn_rays, mtn_in_range, tests.lane,
                                        tmin, lanes, best, best_t);
            alone = 0;
          }
        }
        const PairTreeLeaf<Tree> leaf{tree, entry.child, entry.count};
        for (uint32_t m = alone; m; m &= m - 1) {
          const uint32_t j = static_cast<uint32_t>(__builtin_ctz(m));
          if (detail::test_leaf<kAnyHit, Tri>(tests.lane[j], leaf, tmin[j], best_t[j], best[j]))
            best_t[j] = __builtin_nanf("");  // an any-hit query's hit: the lane takes no entry again
        }
        if constexpr (kAnyHit) {
          if (P::ordered(P::load(best_t)) == 0) break;
        }
      } else {
        const V active_tmax = P::select(lanes, tmax, nan);
        uint32_t enters[2], index[2], count[2];
        const V t0 = packet_enter<P, kBox, kPerLane>(tree.child_planes(entry.child, 0), Tree::kStride, p,
                                                     active_tmax, enters[0]);
        const V t1 = packet_enter<P, kBox, kPerLane>(tree.child_planes(entry.child, 1), Tree::kStride, p,
                                                     active_tmax, enters[1]);
        tree.child(entry.child, 0, index[0], count[0]);
        tree.child(entry.child, 1, index[1], count[1]);
        // Both children's lines asked for now, before the packet has chosen one: where the tree is
        // larger than the caches, a step down waits on memory (the 1M terrain of configs/tune.toml:
        // 17% more rays/s in 16-ray packets, Sponza and the bunny 2 to 5%).
        tree.prefetch(index[0], count[0]);
        tree.prefetch(index[1], count[1]);
        const PacketEntry<P> child[2] = {{P::select(enters[0], t0, nan), index[0], count[0]},
                                         {P::select(enters[1], t1, nan), index[1], count[1]}};
        if (enters[0] != 0 && enters[1] != 0) {
          int first = 0;
          if (nearest_first || farthest_first) {
            // The child nearer for more of the rays that enter both goes first (the left one on a tie):
            // a vote of two compares, where the nearest ray's entry into each takes two reductions
            // across the lanes on the way to the next node. The entries of those lanes are not NaN.
            const uint32_t both = enters[0] & enters[1];
            const int votes1 = std::popcount(both & ~P::le(t0, t1));
            const int votes0 = std::popcount(both & ~P::le(t1, t0));
            first = (farthest_first ? votes0 > votes1 : votes1 > votes0) ? 1 : 0;
          }
          if (size == detail::kStackCapacity) [[unlikely]]
            detail::throw_stack_overflow(entry.child, 2);
          stack[size++] = child[1 - first];
          entry = child[first];
          continue;
        }
        if ((enters[0] | enters[1]) != 0) {
          entry = child[enters[0] != 0 ? 0 : 1];
          continue;
        }
      }
    }
    if (size == 0) break;
    entry = stack[--size];
  }
  for (uint32_t m = mask; m; m &= m - 1) {
    const uint32_t j = static_cast<uint32_t>(__builtin_ctz(m));
    if constexpr (kAnyHit)
      occluded[j] = best[j].found();
    else
      hits[j] = best[j];
  }
}

// Whether the rays of `mask` differ in the sign of a direction component.
SAHBENCH_KERNEL_INLINE bool mixed_octants(const Ray* rays, uint32_t mask) {
  const uint32_t lead = static_cast<uint32_t>(__builtin_ctz(mask));
  const uint32_t octant = detail::direction_octant(rays[lead]);
  for (uint32_t m = mask & (mask - 1); m; m &= m - 1)
    if (detail::direction_octant(rays[__builtin_ctz(m)]) != octant) return true;
  return false;
}
// The entry points of the two trees (PairPacketKernel, BinaryPacketKernel), flattened as the loop is;
// per-lane planes only for a packet whose rays differ in a sign.
template <class P, class Tri, class Box, bool kAnyHit>
[[gnu::flatten]] void trace_packed_pair_packet(const PackedBvh2& tree, const Ray* rays, uint32_t n,
                                               uint32_t mask, AnyHitOrder order, Hit* hits,
                                               uint8_t* occluded) {
  if (mixed_octants(rays, mask))
    trace_pair_packet<P, Tri, Box, kAnyHit, true>(PackedPairTree{tree}, rays, n, mask, order, hits, occluded);
  else
    trace_pair_packet<P, Tri, Box, kAnyHit, false>(PackedPairTree{tree}, rays, n, mask, order, hits,
                                                   occluded);
}
template <class P, class Tri, class Box, bool kAnyHit>
[[gnu::flatten]] void trace_binary_packet(const Bvh& bvh, const Triangle* triangles, const Ray* rays,
                                          uint32_t n, uint32_t mask, AnyHitOrder order, Hit* hits,
                                          uint8_t* occluded) {
  if (mixed_octants(rays, mask))
    trace_pair_packet<P, Tri, Box, kAnyHit, true>(CommonPairTree{bvh, triangles}, rays, n, mask, order, hits,
                                                  occluded);
  else
    trace_pair_packet<P, Tri, Box, kAnyHit, false>(CommonPairTree{bvh, triangles}, rays, n, mask, order, hits,
                                                   occluded);
}

// The bvh2_packed packet kernel of this instruction set for `variant` and packets of `packet` rays: 8,
// or (AVX-512) 16; nullptr for a width this set has no kernels for.
inline PairPacketKernel select_pair_packet_kernel(const KernelVariant& variant, bool any_hit,
                                                  uint32_t packet) {
  auto table = [&]<class P>() {
    return with_test_types(variant, [&]<class Tri, class Box>() -> PairPacketKernel {
      return any_hit ? &trace_packed_pair_packet<P, Tri, Box, true>
                     : &trace_packed_pair_packet<P, Tri, Box, false>;
    });
  };
  if (packet == Lanes8::kWidth) return table.template operator()<Lanes8>();
#if defined(SAHBENCH_WIDE_AVX512)
  if (packet == Lanes16::kWidth) return table.template operator()<Lanes16>();
#endif
  return nullptr;
}

// The same for bvh2's packets on the common format.
inline BinaryPacketKernel select_binary_packet_kernel(const KernelVariant& variant, bool any_hit,
                                                      uint32_t packet) {
  auto table = [&]<class P>() {
    return with_test_types(variant, [&]<class Tri, class Box>() -> BinaryPacketKernel {
      return any_hit ? &trace_binary_packet<P, Tri, Box, true> : &trace_binary_packet<P, Tri, Box, false>;
    });
  };
  if (packet == Lanes8::kWidth) return table.template operator()<Lanes8>();
#if defined(SAHBENCH_WIDE_AVX512)
  if (packet == Lanes16::kWidth) return table.template operator()<Lanes16>();
#endif
  return nullptr;
}
