#pragma once
// Double-precision affine transforms as glTF writes them: column-major 4x4 matrices and
// translation/rotation/scale (TRS) with a unit quaternion (x, y, z, w). The static loader and the
// animation evaluator compose node transforms with these same functions, so the animated pose at rest
// and the static load agree to the bit.

#include <array>
#include <cmath>

#include "core/vec3.h"
#include "scenes/triangle_filter.h"

namespace sahbench {

/// Column-major 4x4 matrix: element (row, col) is m[col * 4 + row].
using Mat4 = std::array<double, 16>;

inline constexpr Mat4 kIdentity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

/// a * b.
inline Mat4 multiply(const Mat4& a, const Mat4& b) {
  Mat4 c{};
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 4; ++row) {
      double s = 0.0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + row] * b[col * 4 + k];
      c[col * 4 + row] = s;
    }
  return c;
}

/// A node's local TRS. The rotation need not be normalised; trs_matrix normalises it.
struct Trs {
  std::array<double, 3> translation{0, 0, 0};
  std::array<double, 4> rotation{0, 0, 0, 1};  ///< quaternion x, y, z, w
  std::array<double, 3> scale{1, 1, 1};

  friend bool operator==(const Trs&, const Trs&) = default;
};

/// T * R * S (glTF 2.0, section 3.5.3). The quaternion is normalised first, as exporters write rounded
/// values; a zero quaternion is left as it is (and gives a degenerate matrix).
inline Mat4 trs_matrix(const Trs& trs) {
  double qx = trs.rotation[0], qy = trs.rotation[1], qz = trs.rotation[2], qw = trs.rotation[3];
  const double len = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
  if (len > 0.0) qx /= len, qy /= len, qz /= len, qw /= len;
  const double sx = trs.scale[0], sy = trs.scale[1], sz = trs.scale[2];
  const double xx = qx * qx, yy = qy * qy, zz = qz * qz;
  const double xy = qx * qy, xz = qx * qz, yz = qy * qz, wx = qw * qx, wy = qw * qy, wz = qw * qz;
  // clang-format off
  return Mat4{(1 - 2 * (yy + zz)) * sx, 2 * (xy + wz) * sx,       2 * (xz - wy) * sx,       0,
              2 * (xy - wz) * sy,       (1 - 2 * (xx + zz)) * sy, 2 * (yz + wx) * sy,       0,
              2 * (xz + wy) * sz,       2 * (yz - wx) * sz,       (1 - 2 * (xx + yy)) * sz, 0,
              trs.translation[0],       trs.translation[1],       trs.translation[2],       1};
  // clang-format on
}

/// m applied to the point (x, y, z), rounded once to float (out-of-range values become infinities).
inline Vec3 transform_point(const Mat4& m, double x, double y, double z) {
  return {to_float(m[0] * x + m[4] * y + m[8] * z + m[12]), to_float(m[1] * x + m[5] * y + m[9] * z + m[13]),
          to_float(m[2] * x + m[6] * y + m[10] * z + m[14])};
}

inline Vec3 transform_point(const Mat4& m, const Vec3& p) {
  return transform_point(m, p.x, p.y, p.z);
}

/// m applied to the direction (x, y, z) (no translation), rounded to float.
inline Vec3 transform_direction(const Mat4& m, double x, double y, double z) {
  return {to_float(m[0] * x + m[4] * y + m[8] * z), to_float(m[1] * x + m[5] * y + m[9] * z),
          to_float(m[2] * x + m[6] * y + m[10] * z)};
}

}  // namespace sahbench
