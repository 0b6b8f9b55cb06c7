#pragma once
// Keyframe interpolation as glTF 2.0 animation samplers define it (specification section 3.11 and
// Appendix C, "Animation Sampler Interpolation Modes"): STEP, LINEAR (spherical linear interpolation for
// rotations) and CUBICSPLINE (cubic Hermite with per-keyframe tangents). Evaluated in double.

#include <span>
#include <string_view>
#include <vector>

namespace sahbench {

enum class Interpolation { kStep, kLinear, kCubicSpline };

/// "STEP", "LINEAR" or "CUBICSPLINE"; anything else is an Error naming the value.
Interpolation parse_interpolation(std::string_view text);

/// One sampler's keyframes. `values` holds `width` numbers per keyframe (3 for translation and scale,
/// 4 for a rotation quaternion x, y, z, w, the number of morph targets for weights); CUBICSPLINE
/// stores three such groups per keyframe: in-tangent, value, out-tangent.
class Keyframes {
 public:
  /// Checks the sizes, that every time and value is finite, and that the times never decrease.
  /// `rotation`: the values are quaternions (LINEAR slerps, CUBICSPLINE normalises the result).
  /// Throws Error describing the problem (callers prefix where it is).
  Keyframes(std::vector<float> times, std::vector<float> values, int width, Interpolation interpolation,
            bool rotation);

  int width() const { return width_; }
  float first_time() const { return times_.front(); }
  float last_time() const { return times_.back(); }

  /// The value at time `t`, `width` numbers into `out`. Before the first keyframe the first value,
  /// after the last the last value (glTF clamps; looping is the caller's choice of t).
  void evaluate(double t, std::span<double> out) const;

 private:
  // Group `g` of keyframe `key` (`width` numbers): for CUBICSPLINE, group 0 is the in-tangent, 1 the
  // value, 2 the out-tangent; otherwise only group 0 exists and is the value.
  const float* group(std::size_t key, int g) const;

  std::vector<float> times_;
  std::vector<float> values_;
  int width_;
  Interpolation interpolation_;
  bool rotation_;
};

/// Spherical linear interpolation of unit quaternions a and b (x, y, z, w) at s in [0, 1], along the
/// shorter arc (b is negated when a . b < 0), as in glTF 2.0 Appendix C; falls back to normalised
/// linear interpolation when the quaternions are nearly parallel. The result is normalised.
void slerp(std::span<const double, 4> a, std::span<const double, 4> b, double s, std::span<double, 4> out);

}  // namespace sahbench
