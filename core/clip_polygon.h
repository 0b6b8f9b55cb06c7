#pragma once
// A triangle clipped by axis-aligned planes, in double precision: Sutherland and Hodgman 1974,
// "Reentrant Polygon Clipping", one plane at a time. The SBVH builder bounds the part of a triangle
// inside a box and a slab with it (Stich, Friedrich and Dietrich 2009, section 4.2), and the validator
// checks with it that the leaves holding a clipped triangle cover all of it.
//
// Vertices are doubles so that points where edges cross a plane carry only double rounding (about
// 2^-52 of the triangle's coordinates), far below the float resolution of any bound made from them;
// callers that need float bounds round them outward.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "core/error.h"
#include "core/triangle.h"

namespace sahbench {

struct ClipPolygon {
  using Point = std::array<double, 3>;
  /// A triangle clipped by k planes has at most 3 + k vertices; the validator's coverage check clips
  /// pieces by many planes, and near-degenerate pieces may gain a vertex per plane from rounding.
  static constexpr int kMaxVertices = 32;

  std::array<Point, kMaxVertices> v;
  int count = 0;
  /// Bit i set: v[i] is a vertex of the input triangle, exact in float. Other vertices are crossing
  /// points, whose coordinates off the crossing plane's axis carry rounding.
  uint32_t original = 0;

  static ClipPolygon of(const Triangle& t) {
    ClipPolygon p;
    p.reset(t);
    return p;
  }
  /// Becomes the triangle t, in place (the vertex array is large to copy).
  void reset(const Triangle& t) {
    v[0] = {t.v0.x, t.v0.y, t.v0.z};
    v[1] = {t.v1.x, t.v1.y, t.v1.z};
    v[2] = {t.v2.x, t.v2.y, t.v2.z};
    count = 3;
    original = 0b111;
  }

  bool empty() const { return count == 0; }

  /// Keeps the closed part with coordinate `axis` <= value (keep_below) or >= value. A crossing point is
  /// added only where an edge's ends lie strictly on opposite sides, so vertices on the plane are not
  /// repeated; the crossing's coordinate on `axis` is `value` exactly.
  void clip(int axis, double value, bool keep_below) {
    if (count == 0) return;
    std::array<Point, kMaxVertices> out;
    uint32_t out_original = 0;
    int n = 0;
    auto side = [&](const Point& p) {  // -1 kept side strictly, 0 on the plane, 1 cut off
      const double d = keep_below ? p[axis] - value : value - p[axis];
      return d < 0 ? -1 : (d > 0 ? 1 : 0);
    };
    auto push = [&](const Point& p, bool is_original) {
      if (n == kMaxVertices)
        throw Error("ClipPolygon: more than " + std::to_string(kMaxVertices) + " vertices");
      out_original |= uint32_t{is_original} << n;
      out[n++] = p;
    };
    for (int i = 0; i < count; ++i) {
      const Point& a = v[i];
      const Point& b = v[i + 1 == count ? 0 : i + 1];
      const int sa = side(a), sb = side(b);
      if (sa <= 0) push(a, (original >> i) & 1);
      if (sa * sb < 0) push(crossing(a, b, axis, value), false);
    }
    std::copy_n(out.begin(), n, v.begin());
    count = n;
    original = out_original;
  }

  /// True when some vertex lies strictly below (below) or above `value` on `axis`: the polygon then has
  /// points off the plane on that side, not just a boundary on it.
  bool reaches(int axis, double value, bool below) const {
    for (int i = 0; i < count; ++i)
      if (below ? v[i][axis] < value : v[i][axis] > value) return true;
    return false;
  }

  /// The point of segment ab with coordinate `axis` = value; a and b lie strictly on opposite sides.
  static Point crossing(const Point& a, const Point& b, int axis, double value) {
    const double s = (value - a[axis]) / (b[axis] - a[axis]);
    Point p;
    for (int k = 0; k < 3; ++k) p[k] = a[k] + s * (b[k] - a[k]);
    p[axis] = value;
    return p;
  }
};

/// Largest absolute coordinate of a triangle: the scale of the rounding in points computed from it.
inline double coordinate_scale(const Triangle& t) {
  double m = 0.0;
  for (const Vec3& p : {t.v0, t.v1, t.v2})
    for (std::size_t k = 0; k < 3; ++k) m = std::max(m, std::fabs(double(p[k])));
  return m;
}

}  // namespace sahbench
