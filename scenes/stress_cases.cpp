#include "scenes/stress_cases.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <utility>

#include "core/error.h"
#include "scenes/generators.h"
#include "scenes/rng.h"
#include "scenes/triangle_filter.h"

namespace sahbench {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

using Point3 = std::array<double, 3>;
using Face = std::array<uint32_t, 3>;

// Every kind's one-off draws use this item number, far from the ray numbers 0, 1, 2, ...
constexpr uint64_t kSetupItem = ~uint64_t{0};

// ---------------------------------------------------------------------------------------------------
// Closed meshes with shared vertices, in double on the unit scale; placed once into float, so that every
// triangle around a vertex holds bit-identical copies of it (the meshes are watertight in float).

struct IndexedMesh {
  std::vector<Point3> unit;
  std::vector<Face> faces;
};

/// An icosahedron subdivided `levels` times (each triangle into four, new vertices pushed onto the unit
/// sphere): 20 * 4^levels triangles, every vertex shared by 5 or 6 of them.
IndexedMesh icosphere(int levels) {
  const double p = (1.0 + std::sqrt(5.0)) / 2.0;  // the golden ratio: the icosahedron's corners
  IndexedMesh m;
  m.unit = {{-1, p, 0},  {1, p, 0},  {-1, -p, 0}, {1, -p, 0}, {0, -1, p},  {0, 1, p},
            {0, -1, -p}, {0, 1, -p}, {p, 0, -1},  {p, 0, 1},  {-p, 0, -1}, {-p, 0, 1}};
  m.faces = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
             {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
             {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  auto normalise = [](Point3 v) {
    const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return Point3{v[0] / len, v[1] / len, v[2] / len};
  };
  for (auto& v : m.unit) v = normalise(v);
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoint;  // edge -> its new vertex, made once
    auto middle = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto [it, inserted] = midpoint.try_emplace(key, static_cast<uint32_t>(m.unit.size()));
      if (inserted) {
        const Point3 &pa = m.unit[a], &pb = m.unit[b];
        m.unit.push_back(normalise({pa[0] + pb[0], pa[1] + pb[1], pa[2] + pb[2]}));
      }
      return it->second;
    };
    std::vector<Face> next;
    next.reserve(4 * m.faces.size());
    for (const Face& f : m.faces) {
      const uint32_t ab = middle(f[0], f[1]), bc = middle(f[1], f[2]), ca = middle(f[2], f[0]);
      next.insert(next.end(), {{f[0], ab, ca}, {f[1], bc, ab}, {f[2], ca, bc}, {ab, bc, ca}});
    }
    m.faces = std::move(next);
  }
  return m;
}

/// The surface of the cube [-1, 1]^3 as an n x n grid of quads per face, two triangles each:
/// 12 n^2 triangles; vertices on the cube's edges and corners are shared between faces.
IndexedMesh cube_grid_mesh(int n) {
  IndexedMesh m;
  std::map<std::array<int, 3>, uint32_t> index;  // lattice coordinates (0..n per axis) -> vertex
  auto vertex = [&](std::array<int, 3> q) {
    const auto [it, inserted] = index.try_emplace(q, static_cast<uint32_t>(m.unit.size()));
    if (inserted) {
      Point3 p;
      for (int a = 0; a < 3; ++a) p[a] = -1.0 + 2.0 * q[a] / n;
      m.unit.push_back(p);
    }
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (const int side : {0, n}) {
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          auto at = [&](int di, int dj) {
            std::array<int, 3> q;
            q[axis] = side, q[u] = i + di, q[v] = j + dj;
            return vertex(q);
          };
          m.faces.push_back({at(0, 0), at(1, 0), at(1, 1)});
          m.faces.push_back({at(0, 0), at(1, 1), at(0, 1)});
        }
    }
  }
  return m;
}

/// A unit-scale point placed at `scale` about the centre (offset, offset, offset), rounded once.
Vec3 place(const Point3& p, double scale, double offset) {
  return {to_float(p[0] * scale + offset), to_float(p[1] * scale + offset), to_float(p[2] * scale + offset)};
}

struct PlacedMesh {
  std::vector<Vec3> vertices;
  std::vector<Face> faces;
  std::vector<std::pair<uint32_t, uint32_t>> edges;  // each shared edge once
  Vec3 centre;

  Triangle triangle(const Face& f) const { return {vertices[f[0]], vertices[f[1]], vertices[f[2]]}; }
};

PlacedMesh place_mesh(const IndexedMesh& m, double scale, double offset) {
  PlacedMesh out;
  out.vertices.reserve(m.unit.size());
  for (const Point3& p : m.unit) out.vertices.push_back(place(p, scale, offset));
  out.faces = m.faces;
  std::set<std::pair<uint32_t, uint32_t>> edges;
  for (const Face& f : m.faces)
    for (int e = 0; e < 3; ++e) edges.insert(std::minmax(f[e], f[(e + 1) % 3]));
  out.edges.assign(edges.begin(), edges.end());
  out.centre = place({0, 0, 0}, scale, offset);
  return out;
}

// Levels of subdivision for about `size` triangles (20 * 4^levels), at most 6 (81,920 triangles).
int icosphere_levels(uint64_t size) {
  int levels = 0;
  while (levels < 6 && 20.0 * std::pow(4.0, levels) < static_cast<double>(size)) ++levels;
  return levels;
}

int cube_grid_side(uint64_t size) {
  return std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(size) / 12.0))));
}

// ---------------------------------------------------------------------------------------------------
// Small helpers for rays.

class CaseBuilder {
 public:
  explicit CaseBuilder(const StressCaseSpec& spec) {
    c_.spec = spec;
    c_.scene.name = spec.name;
    c_.scene.source = "stress:" + spec.kind;
    c_.closed = find_stress_kind(spec.kind).closed;
    c_.rays.reserve(spec.rays);
    c_.must_hit.reserve(spec.rays);
  }
  void add(const Triangle& t) { TriangleFilter(c_.scene).add(t); }
  void add_invalid(const Triangle& t) {
    ++c_.invalid_made;
    add(t);
  }
  void add_mesh(const PlacedMesh& m) {
    for (const Face& f : m.faces) add(m.triangle(f));
  }
  void ray(Vec3 org, Vec3 dir, bool must_hit = false, float tmin = 0.0f, float tmax = kInf) {
    c_.rays.push_back({org, tmin, dir, tmax});
    c_.must_hit.push_back(must_hit ? 1 : 0);
  }
  uint32_t ray_count() const { return c_.spec.rays; }
  SplitMix64 rng(uint64_t item) const { return SplitMix64::for_item(c_.spec.seed, item); }
  const std::vector<Triangle>& triangles() const { return c_.scene.triangles; }
  StressCase take() { return std::move(c_); }

 private:
  StressCase c_;
};

Vec3 random_point(SplitMix64& rng, double lo, double hi) {
  return {static_cast<float>(rng.uniform(lo, hi)), static_cast<float>(rng.uniform(lo, hi)),
          static_cast<float>(rng.uniform(lo, hi))};
}

// A point of triangle t at random barycentrics, computed in float (so within rounding of the surface).
Vec3 point_on(const Triangle& t, SplitMix64& rng) {
  auto a = static_cast<float>(rng.uniform()), b = static_cast<float>(rng.uniform());
  if (a + b > 1.0f) a = 1.0f - a, b = 1.0f - b;
  return t.v0 + (t.v1 - t.v0) * a + (t.v2 - t.v0) * b;
}

// An axis-parallel unit direction with +0 or -0 in the other two components.
Vec3 axis_direction(SplitMix64& rng) {
  const uint64_t bits = rng.next();
  Vec3 d{bits & 1 ? 0.0f : -0.0f, bits & 2 ? 0.0f : -0.0f, bits & 4 ? 0.0f : -0.0f};
  d[(bits >> 3) % 3] = bits & 32 ? 1.0f : -1.0f;
  return d;
}

// ---------------------------------------------------------------------------------------------------
// Closed meshes: rays from the centre and from outside through vertices and edge midpoints (exact
// targets where the float subtractions are exact, e.g. centre 0 or a centre within a factor 2 of the
// vertices (Sterbenz)), from random interior points in random directions, and axis-parallel from the
// centre. Every one must hit.
void closed_mesh_rays(CaseBuilder& b, const PlacedMesh& m, float inner_radius) {
  for (uint32_t i = 0; i < b.ray_count(); ++i) {
    SplitMix64 rng = b.rng(i);
    const uint64_t pick = rng.next();
    const Vec3 vertex = m.vertices[pick % m.vertices.size()];
    const auto& [ea, eb] = m.edges[pick % m.edges.size()];
    const Vec3 edge_mid = (m.vertices[ea] + m.vertices[eb]) * 0.5f;
    switch (i % 6) {
      case 0:
        b.ray(m.centre, vertex - m.centre, true);
        break;
      case 1:
        b.ray(m.centre, edge_mid - m.centre, true);
        break;
      case 2:
      case 3: {  // from outside: o = target + w, dir = -w, so o + dir is the target when o is exact
        const Vec3 target = i % 6 == 2 ? vertex : edge_mid;
        const Vec3 w = target - m.centre;
        b.ray(target + w, -w, true);
        break;
      }
      case 4: {
        const Vec3 org =
            m.centre + rng.unit_vector() * (inner_radius * static_cast<float>(rng.uniform(0.0, 0.5)));
        b.ray(org, rng.unit_vector(), true);
        break;
      }
      default:
        b.ray(m.centre, axis_direction(rng), true);
        break;
    }
  }
}

void make_sphere(CaseBuilder& b, const StressCaseSpec& s) {
  const PlacedMesh m = place_mesh(icosphere(icosphere_levels(s.size)), s.scale, s.offset);
  b.add_mesh(m);
  // The level-0 icosahedron's inscribed sphere has radius 0.79; subdivisions only move faces outwards.
  closed_mesh_rays(b, m, static_cast<float>(0.79 * s.scale));
}

void make_cube_grid(CaseBuilder& b, const StressCaseSpec& s) {
  const PlacedMesh m = place_mesh(cube_grid_mesh(cube_grid_side(s.size)), s.scale, s.offset);
  b.add_mesh(m);
  closed_mesh_rays(b, m, static_cast<float>(s.scale));
}

// Axis-parallel rays (+-0 in the other components) through thin triangles far along them: each ray
// starts at `offset` on its axis (0 on the others) and crosses, at a distance of 1 to 1e6 beyond
// max(1, |offset| 2^-20) (so that the crossing is a float apart from the origin), a triangle reaching
// only `scale` across the axis, tilted along it. The crossing is strictly inside, so every ray must hit.
// Narrower than 1e-18 times the distance, such a triangle's box was missed by a reciprocal clamped to
// 1e18, and origins beyond 3.4e20 made org * 1e18 overflow (ray_box.h: FmaRayBox's domain).
void make_axis_thin(CaseBuilder& b, const StressCaseSpec& s) {
  const auto width = static_cast<float>(s.scale);
  const double base = std::max(1.0, std::abs(s.offset) * 0x1p-20);
  for (uint32_t r = 0; r < b.ray_count(); ++r) {
    SplitMix64 rng = b.rng(r);
    Vec3 dir = axis_direction(rng);
    const auto axis = static_cast<std::size_t>(dir.x != 0.0f ? 0 : dir.y != 0.0f ? 1 : 2);
    const std::size_t u = (axis + 1) % 3, v = (axis + 2) % 3;
    Vec3 org{0.0f, 0.0f, 0.0f};
    org[axis] = static_cast<float>(s.offset);
    const float along =
        org[axis] + dir[axis] * static_cast<float>(base * std::pow(10.0, rng.uniform(0.0, 6.0)));
    const float tilt = along + dir[axis] * static_cast<float>(base);
    Triangle t;
    t.v0[axis] = along, t.v0[u] = -width, t.v0[v] = -width;
    t.v1[axis] = tilt, t.v1[u] = width, t.v1[v] = -width;
    t.v2[axis] = along, t.v2[u] = 0.0f, t.v2[v] = width;
    b.add(t);
    b.ray(org, dir, true);
  }
}

// Unit cubes [2i, 2i+1] x [2j, 2j+1] x [2k, 2k+1] (12 triangles each), and rays whose origins lie on
// their face planes, edges and corners, or in the gaps, with axis-parallel directions (+-0 elsewhere)
// and directions lying in a coordinate plane: rays in the planes of leaf and node box faces.
void make_axis_rays(CaseBuilder& b, const StressCaseSpec& s) {
  const int k = std::max(1, static_cast<int>(std::lround(std::cbrt(static_cast<double>(s.size) / 12.0))));
  const IndexedMesh unit_cube = cube_grid_mesh(1);
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j)
      for (int l = 0; l < k; ++l) {
        PlacedMesh m = place_mesh(unit_cube, 0.5, 0.0);
        for (Vec3& v : m.vertices) v = v + Vec3{2.0f * i + 0.5f, 2.0f * j + 0.5f, 2.0f * l + 0.5f};
        b.add_mesh(m);
      }
  for (uint32_t r = 0; r < b.ray_count(); ++r) {
    SplitMix64 rng = b.rng(r);
    Vec3 lo;
    for (int a = 0; a < 3; ++a) lo[a] = 2.0f * static_cast<float>(rng.next() % static_cast<uint64_t>(k));
    Vec3 org;
    bool on_plane[3];
    int planes = 0, gaps = 0;
    for (int a = 0; a < 3; ++a) {
      // On the min or max face plane, the middle, the gap before the cube, or a random interior point.
      const uint64_t choice = rng.next() % 5;
      on_plane[a] = choice <= 1;
      planes += on_plane[a];
      gaps += choice == 3;
      switch (choice) {
        case 0:
          org[a] = lo[a];
          break;
        case 1:
          org[a] = lo[a] + 1.0f;
          break;
        case 2:
          org[a] = lo[a] + 0.5f;
          break;
        case 3:
          org[a] = lo[a] - 0.5f;
          break;
        default:
          org[a] = lo[a] + static_cast<float>(rng.uniform(0.01, 0.99));
          break;
      }
    }
    if (planes == 3) {  // a corner: move off one of its planes, to the middle of that axis
      const auto a = static_cast<int>(rng.next() % 3);
      org[a] = lo[a] + 0.5f;
      on_plane[a] = false;
      --planes;
    }
    Vec3 dir = axis_direction(rng);
    if (rng.next() % 3 == 0) {  // in a coordinate plane: one component +-0, the others random
      dir = rng.unit_vector();
      dir[rng.next() % 3] = rng.next() % 2 ? 0.0f : -0.0f;
    }
    // An origin on the cube's surface (on a face plane, not in the gap on another axis) moves only
    // within the planes it lies on: a ray leaving the surface from it would hit at exactly t = 0,
    // which is self-intersection (the surface_origin kind's subject), not a crossing.
    if (planes > 0 && gaps == 0) {
      int free_axis = 0;
      for (int a = 0; a < 3; ++a) {
        if (on_plane[a])
          dir[a] = rng.next() % 2 ? 0.0f : -0.0f;
        else
          free_axis = a;
      }
      if (dir == Vec3{0.0f}) dir[free_axis] = rng.next() % 2 ? 1.0f : -1.0f;
    }
    b.ray(org, dir, planes == 0 && gaps == 0);
  }
}

// A square in the plane z = 0 (two triangles sharing a diagonal) and randomly rotated squares, with rays
// nearly parallel to them (descending 1e-1 .. 1e-12 per unit of travel), exactly in the plane z = 0,
// parallel just above it, and grazing along the shared diagonal.
void make_grazing(CaseBuilder& b, const StressCaseSpec& s) {
  b.add({{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}});
  b.add({{-1, -1, 0}, {1, 1, 0}, {-1, 1, 0}});
  struct Square {
    Vec3 centre, e1, e2, normal;
  };
  std::vector<Square> squares;
  const std::size_t count = std::max<uint64_t>(1, s.size / 2);
  for (std::size_t i = 0; i < count; ++i) {
    SplitMix64 rng = b.rng(kSetupItem - 1 - i);
    Square q;
    q.centre = random_point(rng, -20.0, 20.0);
    q.normal = rng.unit_vector();
    q.e1 = normalize(cross(q.normal, rng.unit_vector()));
    q.e2 = cross(q.normal, q.e1);
    const Vec3 c00 = q.centre - q.e1 - q.e2, c10 = q.centre + q.e1 - q.e2;
    const Vec3 c11 = q.centre + q.e1 + q.e2, c01 = q.centre - q.e1 + q.e2;
    b.add({c00, c10, c11});
    b.add({c00, c11, c01});
    squares.push_back(q);
  }
  for (uint32_t i = 0; i < b.ray_count(); ++i) {
    SplitMix64 rng = b.rng(i);
    const auto slope = static_cast<float>(std::pow(10.0, -rng.uniform(1.0, 12.0)));
    const double phi = rng.uniform(0.0, 6.283185307179586);
    const Vec3 flat{static_cast<float>(std::cos(phi)), static_cast<float>(std::sin(phi)), 0.0f};
    switch (i % 5) {
      case 0: {  // grazing onto the z = 0 square
        const Vec3 target{static_cast<float>(rng.uniform(-0.9, 0.9)),
                          static_cast<float>(rng.uniform(-0.9, 0.9)), 0};
        const Vec3 dir{flat.x, flat.y, -slope};
        b.ray(target - dir * 2.0f, dir);
        break;
      }
      case 1: {  // grazing onto a rotated square
        const Square& q = squares[rng.next() % squares.size()];
        const Vec3 target = q.centre + q.e1 * static_cast<float>(rng.uniform(-0.9, 0.9)) +
                            q.e2 * static_cast<float>(rng.uniform(-0.9, 0.9));
        const Vec3 along = normalize(q.e1 * flat.x + q.e2 * flat.y);
        const Vec3 dir = along - q.normal * slope;
        b.ray(target - dir * 2.0f, dir);
        break;
      }
      case 2: {  // exactly in the plane z = 0, with +0 or -0 components
        const float z = rng.next() % 2 ? 0.0f : -0.0f;
        b.ray({static_cast<float>(rng.uniform(-2.0, 2.0)), static_cast<float>(rng.uniform(-2.0, 2.0)), z},
              {flat.x, flat.y, rng.next() % 2 ? 0.0f : -0.0f});
        break;
      }
      case 3: {  // parallel, just above the plane
        const float z = rng.next() % 2 ? std::numeric_limits<float>::denorm_min() : 1e-30f;
        b.ray({static_cast<float>(rng.uniform(-2.0, 2.0)), static_cast<float>(rng.uniform(-2.0, 2.0)), z},
              {flat.x, flat.y, 0.0f});
        break;
      }
      default: {  // grazing onto the shared diagonal x = y
        const auto x = static_cast<float>(rng.uniform(-0.9, 0.9));
        const Vec3 dir{flat.x, flat.y, -slope};
        b.ray(Vec3{x, x, 0} - dir * 2.0f, dir);
        break;
      }
    }
  }
}

// Triangles at distances around 1e18 and 1e30 (Embree drops those beyond about 1.8e18), two sheets
// spanning +-1e30, and triangles with edges of 1e-20 within 1e-18 of the origin, plus tiny ones near
// (1, 1, 1), where float cannot hold their extent: they collapse to zero area and are removed.
void make_huge_tiny(CaseBuilder& b, const StressCaseSpec& s) {
  const std::size_t huge = std::max<uint64_t>(2, s.size / 4), tiny = std::max<uint64_t>(2, s.size / 2);
  constexpr std::size_t kCollapsing = 8;
  for (std::size_t i = 0; i < 2 * huge; ++i) {
    SplitMix64 rng = b.rng(kSetupItem - 1 - i);
    const float radius = i < huge ? 1e18f : 1e30f;
    const Vec3 centre = rng.unit_vector() * (radius * static_cast<float>(rng.uniform(0.5, 1.0)));
    b.add({centre + rng.unit_vector() * (0.3f * radius), centre + rng.unit_vector() * (0.3f * radius),
           centre + rng.unit_vector() * (0.3f * radius)});
  }
  b.add({{-1e30f, -1e30f, 5}, {1e30f, -1e30f, 5}, {0, 1e30f, 5}});
  b.add({{-7, -1e30f, -1e30f}, {-7, 1e30f, -1e30f}, {-7, 0, 1e30f}});
  const std::size_t first_tiny = b.triangles().size();
  for (std::size_t i = 0; i < tiny; ++i) {
    SplitMix64 rng = b.rng(kSetupItem - 1 - 2 * huge - i);
    const Vec3 centre = random_point(rng, -1e-18, 1e-18);
    b.add({centre + rng.unit_vector() * 1e-20f, centre + rng.unit_vector() * 1e-20f,
           centre + rng.unit_vector() * 1e-20f});
  }
  const std::size_t end_tiny = b.triangles().size();
  for (std::size_t i = 0; i < kCollapsing; ++i) {
    SplitMix64 rng = b.rng(kSetupItem - 1 - 2 * huge - tiny - i);
    const Vec3 centre{1, 1, 1};
    b.add_invalid({centre + rng.unit_vector() * 1e-20f, centre + rng.unit_vector() * 1e-20f,
                   centre + rng.unit_vector() * 1e-20f});
  }
  const std::size_t huge_count = first_tiny;  // the huge triangles and the sheets come first
  for (uint32_t i = 0; i < b.ray_count(); ++i) {
    SplitMix64 rng = b.rng(i);
    switch (i % 5) {
      case 0:
      case 1: {  // at a tiny triangle, from 1e-18 away (case 0) or from 1 away (case 1)
        if (end_tiny == first_tiny) break;
        const Triangle& t = b.triangles()[first_tiny + rng.next() % (end_tiny - first_tiny)];
        const Vec3 target = point_on(t, rng);
        const Vec3 org = target + rng.unit_vector() * (i % 5 == 0 ? 1e-18f : 1.0f);
        b.ray(org, target - org);
        break;
      }
      case 2: {  // at a huge triangle from near the origin
        const Triangle& t = b.triangles()[rng.next() % huge_count];
        const Vec3 org = random_point(rng, -1.0, 1.0);
        b.ray(org, point_on(t, rng) - org);
        break;
      }
      case 3:  // random directions from near the origin, into the sheets
        b.ray(random_point(rng, -1.0, 1.0), rng.unit_vector());
        break;
      default:  // tiny directions: t in the 1e18 range for unit distances
        b.ray(random_point(rng, -1e-18, 1e-18), rng.unit_vector() * 1e-18f);
        break;
    }
  }
}

// Random valid triangles (scenes' soup generator) mixed with invalid ones: a repeated vertex, all three
// equal, exactly collinear (dyadic coordinates, so the float cross product is exactly zero), a NaN,
// +inf and -inf coordinate; plus slivers that are nearly collinear but valid.
void make_degenerate(CaseBuilder& b, const StressCaseSpec& s) {
  for (const Triangle& t : generate_soup(s.size, s.seed)) b.add(t);
  const std::size_t invalid = std::max<uint64_t>(6, s.size / 4);
  std::vector<Vec3> invalid_sites;
  for (std::size_t i = 0; i < invalid; ++i) {
    SplitMix64 rng = b.rng(kSetupItem - 1 - i);
    auto dyadic = [&] { return static_cast<float>(static_cast<int64_t>(rng.next() % 129) - 64) / 64.0f; };
    const Vec3 v{dyadic(), dyadic(), dyadic()}, e{dyadic() / 4, dyadic() / 4, dyadic() / 4};
    invalid_sites.push_back(v + e);
    switch (i % 6) {
      case 0:
        b.add_invalid({v, v, v + e + Vec3{0.5f}});
        break;
      case 1:
        b.add_invalid({v, v, v});
        break;
      case 2:
        b.add_invalid({v, v + e, v + e * 2.0f});
        break;
      case 3:
        b.add_invalid({v, {kNaN, v.y, v.z}, v + Vec3{0.1f, 0.2f, 0.0f}});
        break;
      case 4:
        b.add_invalid({v, v + Vec3{0.1f, 0.0f, 0.3f}, {v.x, kInf, v.z}});
        break;
      default:
        b.add_invalid({{v.x, v.y, -kInf}, v + Vec3{0.1f, 0.2f, 0.0f}, v + Vec3{0.0f, 0.2f, 0.1f}});
        break;
    }
  }
  for (std::size_t i = 0; i < std::max<uint64_t>(1, s.size / 8); ++i) {
    SplitMix64 rng = b.rng(kSetupItem - 1 - invalid - i);
    const Vec3 a = random_point(rng, -1.0, 1.0), d = rng.unit_vector() * 0.3f;
    b.add({a, a + d, a + d * 0.5f + rng.unit_vector() * 1e-6f});
  }
  const std::size_t valid = b.triangles().size();
  for (uint32_t i = 0; i < b.ray_count(); ++i) {
    SplitMix64 rng = b.rng(i);
    const Vec3 target = i % 3 == 2 ? invalid_sites[rng.next() % invalid_sites.size()]
                                   : point_on(b.triangles()[rng.next() % valid], rng);
    const Vec3 org = target + rng.unit_vector() * 3.0f;
    b.ray(org, target - org);
  }
}

// Triangles of every shape whose centroids are all the same point: v0 = c + a, v1 = c + b,
// v2 = c - a - b with dyadic a, b, so the sums are exact and every float centroid is identical.
void make_same_centroid(CaseBuilder& b, const StressCaseSpec& s) {
  const Vec3 c{0.25f, -0.5f, 0.75f};
  for (std::size_t i = 0; i < s.size; ++i) {
    SplitMix64 rng = b.rng(kSetupItem - 1 - i);
    auto dyadic = [&] { return static_cast<float>(static_cast<int64_t>(rng.next() % 129) - 64) / 64.0f; };
    const Vec3 a{dyadic(), dyadic(), dyadic()}, e{dyadic(), dyadic(), dyadic()};
    const Triangle t{c + a, c + e, c - a - e};
    if (t.normal() == Vec3{0.0f}) {
      b.add_invalid(t);
    } else {
      b.add(t);
    }
  }
  for (uint32_t i = 0; i < b.ray_count(); ++i) {
    SplitMix64 rng = b.rng(i);
    if (b.triangles().empty()) break;
    const Vec3 target = i % 4 == 3 ? c : point_on(b.triangles()[rng.next() % b.triangles().size()], rng);
    const Vec3 org = target + rng.unit_vector() * 3.0f;
    b.ray(org, target - org);
  }
}

// `size` bitwise-identical triangles, and rays at their interior, edge midpoints and vertices, and
// just beside their edges.
void make_coincident(CaseBuilder& b, const StressCaseSpec& s) {
  SplitMix64 setup = b.rng(kSetupItem);
  const Triangle t{random_point(setup, -1.0, 1.0), random_point(setup, -1.0, 1.0),
                   random_point(setup, -1.0, 1.0)};
  for (std::size_t i = 0; i < s.size; ++i) b.add(t);
  const Vec3 v[3] = {t.v0, t.v1, t.v2};
  for (uint32_t i = 0; i < b.ray_count(); ++i) {
    SplitMix64 rng = b.rng(i);
    const int e = static_cast<int>(rng.next() % 3);
    Vec3 target;
    switch (i % 4) {
      case 0:
        target = point_on(t, rng);
        break;
      case 1:
        target = (v[e] + v[(e + 1) % 3]) * 0.5f;
        break;
      case 2:
        target = v[e];
        break;
      default: {  // just outside an edge: its midpoint pushed away from the opposite vertex
        const Vec3 mid = (v[e] + v[(e + 1) % 3]) * 0.5f;
        target = mid + (mid - v[(e + 2) % 3]) * 1e-6f;
        break;
      }
    }
    const Vec3 org = target + rng.unit_vector() * 3.0f;
    b.ray(org, target - org);
  }
}

// Long thin needles (the scenes' generator) and rays at random points of them or in random directions.
void make_needles(CaseBuilder& b, const StressCaseSpec& s) {
  for (const Triangle& t : generate_needles(s.size, s.seed, s.aspect)) b.add(t);
  for (uint32_t i = 0; i < b.ray_count(); ++i) {
    SplitMix64 rng = b.rng(i);
    if (i % 3 == 2 || b.triangles().empty()) {
      b.ray(random_point(rng, -1.0, 1.0), rng.unit_vector());
      continue;
    }
    const Vec3 target = point_on(b.triangles()[rng.next() % b.triangles().size()], rng);
    const Vec3 org = target + rng.unit_vector() * 2.0f;
    b.ray(org, target - org);
  }
}

// Tiny spheres inside a huge closed cube (the scenes' multiscale generator): every ray starts inside
// the cube, so every ray must hit; half are aimed at the spheres.
void make_tiny_in_huge(CaseBuilder& b, const StressCaseSpec& s) {
  constexpr std::size_t kEnclosure = 12;  // generate_multiscale's first 12 triangles
  for (const Triangle& t : generate_multiscale(s.size, s.seed, s.outer)) b.add(t);
  const std::size_t n = b.triangles().size();
  for (uint32_t i = 0; i < b.ray_count(); ++i) {
    SplitMix64 rng = b.rng(i);
    const Vec3 org = random_point(rng, -1.0, 1.0);
    if (i % 2 == 0 && n > kEnclosure) {
      const Vec3 target = point_on(b.triangles()[kEnclosure + rng.next() % (n - kEnclosure)], rng);
      b.ray(org, target - org, true);
    } else {
      b.ray(org, rng.unit_vector(), true);
    }
  }
}

// Rays starting on a sphere's surface (at float points of its triangles, so just above or below it):
// outwards, inwards (these must hit: the far side if not their own triangle), and along an edge of
// their own triangle (in its plane). A ray that hits its own triangle at t ~ 0 is self-intersection.
void make_surface_origin(CaseBuilder& b, const StressCaseSpec& s) {
  const PlacedMesh m = place_mesh(icosphere(icosphere_levels(s.size)), s.scale, s.offset);
  b.add_mesh(m);
  for (uint32_t i = 0; i < b.ray_count(); ++i) {
    SplitMix64 rng = b.rng(i);
    const Triangle t = m.triangle(m.faces[rng.next() % m.faces.size()]);
    const Vec3 org = point_on(t, rng);
    const Vec3 n = normalize(t.normal());
    Vec3 dir = rng.unit_vector();
    switch (i % 3) {
      case 0:
        b.ray(org, dot(dir, n) < 0 ? -dir : dir);
        break;
      case 1:
        b.ray(org, dot(dir, n) > 0 ? -dir : dir, true);
        break;
      default:
        b.ray(org, t.v1 - t.v0);
        break;
    }
  }
}

// Rays with tmin = tmax inside a cube grid of half-size 1 (faces at +-1, grid lines at multiples of
// 0.5), from dyadic origins along axes: the interval is exactly the distance to a face (an exact hit),
// one ulp beyond or before it (an exact miss), 0 from an origin on a face (a hit), or empty space.
void make_empty_interval(CaseBuilder& b, const StressCaseSpec& s) {
  const PlacedMesh m = place_mesh(cube_grid_mesh(std::max(2, cube_grid_side(s.size))), 1.0, 0.0);
  b.add_mesh(m);
  for (uint32_t i = 0; i < b.ray_count(); ++i) {
    SplitMix64 rng = b.rng(i);
    Vec3 org;
    for (int a = 0; a < 3; ++a)
      org[a] = static_cast<float>(static_cast<int64_t>(rng.next() % 31) - 15) / 16.0f;
    Vec3 dir = axis_direction(rng);
    const int axis = dir.x != 0 ? 0 : (dir.y != 0 ? 1 : 2);
    if (i % 6 == 3) {  // oblique, dyadic: the distance to the face plane is still exact
      dir[(axis + 1) % 3] = rng.next() % 2 ? 0.5f : -0.25f;
      dir[(axis + 2) % 3] = rng.next() % 2 ? 0.25f : -0.125f;
    }
    const float d = 1.0f - org[axis] * dir[axis];  // exact: |dir[axis]| = 1, dyadic origin
    switch (i % 6) {
      case 0:
      case 3:
        b.ray(org, dir, false, d, d);
        break;
      case 1:
        b.ray(org, dir, false, std::nextafter(d, kInf), std::nextafter(d, kInf));
        break;
      case 2:
        b.ray(org, dir, false, std::nextafter(d, 0.0f), std::nextafter(d, 0.0f));
        break;
      case 4: {
        org[axis] = dir[axis] > 0 ? 1.0f : -1.0f;  // on the face it looks at
        b.ray(org, dir, false, 0.0f, 0.0f);
        break;
      }
      default:
        b.ray(org, dir, false, d * 0.5f, d * 0.5f);
        break;
    }
  }
}

struct KindEntry {
  StressKindInfo info;
  void (*make)(CaseBuilder&, const StressCaseSpec&);
};

const std::vector<KindEntry>& kinds() {
  static const std::vector<KindEntry> all = {
      {{"sphere",
        "closed icosphere (20 * 4^k >= size triangles, k <= 6) of radius `scale` centred at `offset`; "
        "rays from inside and outside through vertices and edge midpoints",
        true,
        {"scale", "offset"}},
       make_sphere},
      {{"cube_grid",
        "closed cube of half-size `scale` at `offset`, n x n quads per face (12 n^2 ~ size); "
        "rays through grid vertices and edges",
        true,
        {"scale", "offset"}},
       make_cube_grid},
      {{"axis_rays",
        "lattice of closed unit cubes (12 per cube ~ size); axis-parallel rays with +-0 components "
        "and rays in box face planes",
        true,
        {}},
       make_axis_rays},
      {{"axis_thin",
        "one triangle per ray reaching `scale` across an axis-parallel ray from `offset` on its "
        "axis, 1 to 1e6 units along it; every ray must hit",
        true,
        {"scale", "offset"}},
       make_axis_thin},
      {{"grazing",
        "a square at z = 0 and size/2 rotated squares; rays nearly parallel to them, in their "
        "plane, and just above it",
        false,
        {}},
       make_grazing},
      {{"huge_tiny",
        "triangles at 1e18 and 1e30 with triangles of edge 1e-20 near the origin; size/4 huge "
        "and size/2 tiny, plus 8 that collapse to zero area",
        false,
        {}},
       make_huge_tiny},
      {{"degenerate",
        "size random triangles mixed with size/4 invalid ones (zero area, NaN, +-inf) and size/8 "
        "slivers",
        false,
        {}},
       make_degenerate},
      {{"same_centroid", "size triangles of random shapes, all with the same centroid", false, {}},
       make_same_centroid},
      {{"coincident",
        "size bitwise-identical triangles; rays at their interior, edges, vertices and just "
        "beside",
        false,
        {}},
       make_coincident},
      {{"needles", "size needles of length/width `aspect` (the scenes' generator)", false, {"aspect"}},
       make_needles},
      {{"tiny_in_huge",
        "tiny spheres inside a closed cube of half-size `outer` (size triangles); every ray "
        "starts inside",
        true,
        {"outer"}},
       make_tiny_in_huge},
      {{"surface_origin",
        "rays starting on an icosphere's surface: outwards, inwards, along an edge",
        false,
        {"scale", "offset"}},
       make_surface_origin},
      {{"empty_interval",
        "rays with tmin = tmax inside a cube grid: at the exact distance of a face, one ulp "
        "off it, 0 on a face",
        false,
        {}},
       make_empty_interval},
  };
  return all;
}

}  // namespace

std::span<const StressKindInfo> stress_kinds() {
  static const std::vector<StressKindInfo> infos = [] {
    std::vector<StressKindInfo> out;
    for (const auto& k : kinds()) out.push_back(k.info);
    return out;
  }();
  return infos;
}

const StressKindInfo& find_stress_kind(std::string_view name) {
  for (const auto& k : stress_kinds())
    if (k.name == name) return k;
  std::string known;
  for (const auto& k : stress_kinds()) known += (known.empty() ? "" : ", ") + std::string(k.name);
  throw Error("unknown stress case kind '" + std::string(name) + "' (known: " + known + ")");
}

StressCase generate_stress_case(const StressCaseSpec& spec) {
  find_stress_kind(spec.kind);  // names the known kinds on an unknown one
  CaseBuilder builder(spec);
  for (const auto& k : kinds())
    if (k.info.name == spec.kind) k.make(builder, spec);
  return builder.take();
}

}  // namespace sahbench
