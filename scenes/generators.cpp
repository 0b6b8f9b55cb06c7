#include "scenes/generators.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "scenes/noise.h"
#include "scenes/parallel_index.h"
#include "scenes/rng.h"
#include "scenes/surface_grid.h"
#include "scenes/triangle_filter.h"

namespace sahbench {

namespace {

using Mat3 = std::array<double, 9>;  // row-major

/// Uniformly distributed rotation: a uniform unit quaternion, drawn by rejection from the 4D ball
/// (no trigonometry, so identical on every platform).
Mat3 random_rotation(SplitMix64& rng) {
  double w, x, y, z, len2;
  do {
    w = rng.uniform(-1.0, 1.0), x = rng.uniform(-1.0, 1.0), y = rng.uniform(-1.0, 1.0),
    z = rng.uniform(-1.0, 1.0);
    len2 = w * w + x * x + y * y + z * z;
  } while (len2 > 1.0 || len2 < 1e-6);
  const double inv = 1.0 / std::sqrt(len2);
  w *= inv, x *= inv, y *= inv, z *= inv;
  return {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
          2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
          2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
}

/// Vertices and triangles of a UV sphere with n_lat bands and n_lon segments. Vertex 0 is the north
/// pole, then rings 1..n_lat-1 of n_lon vertices, then the south pole. Triangles are numbered band by
/// band: the top cap has n_lon, each middle band 2 n_lon, the bottom cap n_lon.
class UvSphere {
 public:
  UvSphere(std::size_t n_lat, std::size_t n_lon) : n_lat_(n_lat), n_lon_(n_lon) {
    // Unit-sphere positions in double; callers transform them and round once to float.
    unit_.reserve(vertex_count());
    unit_.push_back({0.0, 0.0, 1.0});
    for (std::size_t r = 1; r < n_lat; ++r) {
      const double theta = std::numbers::pi * static_cast<double>(r) / static_cast<double>(n_lat);
      for (std::size_t j = 0; j < n_lon; ++j) {
        const double phi = 2.0 * std::numbers::pi * static_cast<double>(j) / static_cast<double>(n_lon);
        unit_.push_back({std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)});
      }
    }
    unit_.push_back({0.0, 0.0, -1.0});
  }

  std::size_t vertex_count() const { return 2 + (n_lat_ - 1) * n_lon_; }
  std::size_t triangle_count() const { return 2 * n_lon_ * (n_lat_ - 1); }
  std::size_t bands() const { return n_lat_; }
  const std::array<double, 3>& unit(std::size_t v) const { return unit_[v]; }

  /// Writes the triangles of band b (0 = top cap) to out[first_triangle(b) ...], using `vertices`
  /// (already transformed, indexed as unit()).
  void write_band(std::size_t b, const std::vector<Vec3>& vertices, Triangle* out) const {
    const std::size_t south = vertex_count() - 1;
    auto ring = [&](std::size_t r, std::size_t j) { return vertices[1 + (r - 1) * n_lon_ + j % n_lon_]; };
    Triangle* t = out + first_triangle(b);
    for (std::size_t j = 0; j < n_lon_; ++j) {
      if (b == 0) {
        *t++ = {vertices[0], ring(1, j), ring(1, j + 1)};
      } else if (b == n_lat_ - 1) {
        *t++ = {ring(b, j), vertices[south], ring(b, j + 1)};
      } else {
        *t++ = {ring(b, j), ring(b + 1, j), ring(b + 1, j + 1)};
        *t++ = {ring(b, j), ring(b + 1, j + 1), ring(b, j + 1)};
      }
    }
  }

 private:
  std::size_t first_triangle(std::size_t b) const { return b == 0 ? 0 : n_lon_ + (b - 1) * 2 * n_lon_; }

  std::size_t n_lat_, n_lon_;
  std::vector<std::array<double, 3>> unit_;
};

Vec3 transform(const Mat3& m, const std::array<double, 3>& p, double scale,
               const std::array<double, 3>& offset) {
  return {to_float(scale * (m[0] * p[0] + m[1] * p[1] + m[2] * p[2]) + offset[0]),
          to_float(scale * (m[3] * p[0] + m[4] * p[1] + m[5] * p[2]) + offset[1]),
          to_float(scale * (m[6] * p[0] + m[7] * p[1] + m[8] * p[2]) + offset[2])};
}

std::size_t round_to_size(double v) {
  return static_cast<std::size_t>(std::llround(v));
}

// Item number of a generator's one-off draws (e.g. the sphere's rotation), far from the item numbers
// 0, 1, 2, ... of its triangles or objects.
constexpr uint64_t kSetupItem = ~uint64_t{0};

}  // namespace

std::vector<Triangle> generate_sphere(uint64_t tris, uint64_t seed) {
  // Square cells at the equator need n_lon = 2 n_lat, so tris = 2 n_lon (n_lat - 1) ~ 4 n_lat^2.
  const std::size_t n_lat =
      std::max<std::size_t>(2, round_to_size(std::sqrt(static_cast<double>(tris) / 4.0)));
  const std::size_t n_lon = std::max<std::size_t>(
      3, round_to_size(static_cast<double>(tris) / (2.0 * static_cast<double>(n_lat - 1))));
  const UvSphere sphere(n_lat, n_lon);
  SplitMix64 setup = SplitMix64::for_item(seed, kSetupItem);
  const Mat3 rotation = random_rotation(setup);

  std::vector<Vec3> vertices(sphere.vertex_count());
  parallel_for_each_index(vertices.size(), [&](std::size_t v) {
    vertices[v] = transform(rotation, sphere.unit(v), 1.0, {0, 0, 0});
  });
  std::vector<Triangle> out(sphere.triangle_count());
  tbb::parallel_for(std::size_t{0}, sphere.bands(),
                    [&](std::size_t b) { sphere.write_band(b, vertices, out.data()); });
  return out;
}

std::vector<Triangle> generate_terrain(uint64_t tris, uint64_t seed, int octaves) {
  const SurfaceGrid grid = surface_grid(tris);
  // Features at 2 per unit for the first octave; heights up to about a quarter of the extent.
  constexpr double kBaseFrequency = 2.0;
  constexpr double kAmplitude = 0.25;

  std::vector<Vec3> vertices(grid.vertex_count());
  parallel_for_each_index(vertices.size(), [&](std::size_t v) {
    const double x = grid.x(v), z = grid.z(v);
    const double h = kAmplitude * fractal_noise(kBaseFrequency * x, kBaseFrequency * z, seed, octaves);
    vertices[v] = {to_float(x), to_float(h), to_float(z)};
  });
  return triangulate(grid, vertices);
}

std::vector<Triangle> generate_soup(uint64_t tris, uint64_t seed) {
  constexpr double kMinSize = 0.002, kMaxSize = 0.2;
  std::vector<Triangle> out(tris);
  parallel_for_each_index(out.size(), [&](std::size_t i) {
    SplitMix64 rng = SplitMix64::for_item(seed, i);
    const Vec3 v0{static_cast<float>(rng.uniform(-1.0, 1.0)), static_cast<float>(rng.uniform(-1.0, 1.0)),
                  static_cast<float>(rng.uniform(-1.0, 1.0))};
    const double u = rng.uniform();
    const auto size = static_cast<float>(kMinSize + (kMaxSize - kMinSize) * u * u * u);
    const Vec3 v1 = v0 + rng.unit_vector() * size;
    const Vec3 v2 = v0 + rng.unit_vector() * size;
    out[i] = {v0, v1, v2};
  });
  return out;
}

std::vector<Triangle> generate_needles(uint64_t tris, uint64_t seed, double aspect) {
  constexpr double kMinLength = 0.05, kMaxLength = 0.5;
  std::vector<Triangle> out(tris);
  parallel_for_each_index(out.size(), [&](std::size_t i) {
    SplitMix64 rng = SplitMix64::for_item(seed, i);
    const std::array<double, 3> c{rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)};
    const Vec3 af = rng.unit_vector();
    const std::array<double, 3> a{af.x, af.y, af.z};
    // A perpendicular direction: a random direction minus its component along a, if that leaves enough.
    std::array<double, 3> p{};
    for (;;) {
      const Vec3 r = rng.unit_vector();
      const double along = r.x * a[0] + r.y * a[1] + r.z * a[2];
      p = {r.x - along * a[0], r.y - along * a[1], r.z - along * a[2]};
      const double len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
      if (len > 0.1) {
        for (double& x : p) x /= len;
        break;
      }
    }
    const double length = rng.uniform(kMinLength, kMaxLength);
    const double width = length / aspect;
    auto point = [&](double s, double w) {
      return Vec3{to_float(c[0] + s * a[0] + w * p[0]), to_float(c[1] + s * a[1] + w * p[1]),
                  to_float(c[2] + s * a[2] + w * p[2])};
    };
    out[i] = {point(-0.5 * length, 0.0), point(0.5 * length, 0.0), point(0.0, width)};
  });
  return out;
}

std::vector<Triangle> generate_multiscale(uint64_t tris, uint64_t seed, double outer) {
  constexpr double kRadius = 0.002;
  // 5 bands x 10 segments: 80 triangles with edges of about 2 pi r / 10 = 1.3e-3.
  const UvSphere sphere(5, 10);
  constexpr std::size_t kBoxTriangles = 12;
  const std::size_t per_sphere = sphere.triangle_count();
  const std::size_t spheres = std::max<std::size_t>(
      1, round_to_size((static_cast<double>(tris) - kBoxTriangles) / static_cast<double>(per_sphere)));

  std::vector<Triangle> out(kBoxTriangles + spheres * per_sphere);
  // The enclosing cube, two triangles per face, wound to face inwards.
  const auto h = to_float(outer);
  auto corner = [h](int i) { return Vec3{i & 1 ? h : -h, i & 2 ? h : -h, i & 4 ? h : -h}; };
  constexpr std::array<std::array<int, 4>, 6> kFaces{
      {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}}};
  for (std::size_t f = 0; f < kFaces.size(); ++f) {
    const auto& q = kFaces[f];
    out[2 * f] = {corner(q[0]), corner(q[1]), corner(q[2])};
    out[2 * f + 1] = {corner(q[0]), corner(q[2]), corner(q[3])};
  }

  tbb::parallel_for(std::size_t{0}, spheres, [&](std::size_t s) {
    SplitMix64 rng = SplitMix64::for_item(seed, s);
    const std::array<double, 3> centre{rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0),
                                       rng.uniform(-1.0, 1.0)};
    const Mat3 rotation = random_rotation(rng);
    std::vector<Vec3> vertices(sphere.vertex_count());
    for (std::size_t v = 0; v < vertices.size(); ++v)
      vertices[v] = transform(rotation, sphere.unit(v), kRadius, centre);
    Triangle* dst = out.data() + kBoxTriangles + s * per_sphere;
    for (std::size_t b = 0; b < sphere.bands(); ++b) sphere.write_band(b, vertices, dst);
  });
  return out;
}

}  // namespace sahbench
