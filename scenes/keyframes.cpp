#include "scenes/keyframes.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"

namespace sahbench {

namespace {

// Above this cosine the two quaternions are so close that sin(theta) loses its precision and normalised
// linear interpolation is indistinguishable from slerp (the usual cut-off, e.g. J. Blow 2004,
// "Understanding Slerp, Then Not Using It").
constexpr double kSlerpLinearThreshold = 0.9995;

void normalise4(std::span<double, 4> q) {
  const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (len > 0.0)
    for (double& c : q) c /= len;
}

}  // namespace

Interpolation parse_interpolation(std::string_view text) {
  if (text == "STEP") return Interpolation::kStep;
  if (text == "LINEAR") return Interpolation::kLinear;
  if (text == "CUBICSPLINE") return Interpolation::kCubicSpline;
  throw Error("interpolation '" + std::string(text) + "' is not one of STEP, LINEAR, CUBICSPLINE");
}

void slerp(std::span<const double, 4> a, std::span<const double, 4> b, double s, std::span<double, 4> out) {
  double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  // q and -q are the same rotation; interpolate towards the closer one (the shorter arc).
  const double sign = dot < 0.0 ? -1.0 : 1.0;
  dot *= sign;
  double wa = 1.0 - s, wb = s;
  if (dot < kSlerpLinearThreshold) {
    const double theta = std::acos(dot);
    const double sin_theta = std::sin(theta);
    wa = std::sin((1.0 - s) * theta) / sin_theta;
    wb = std::sin(s * theta) / sin_theta;
  }
  for (int i = 0; i < 4; ++i) out[i] = wa * a[i] + sign * wb * b[i];
  normalise4(out);
}

Keyframes::Keyframes(std::vector<float> times, std::vector<float> values, int width,
                     Interpolation interpolation, bool rotation)
    : times_(std::move(times)),
      values_(std::move(values)),
      width_(width),
      interpolation_(interpolation),
      rotation_(rotation) {
  if (width_ < 1) throw Error("keyframe width " + std::to_string(width_) + " must be at least 1");
  if (rotation_ && width_ != 4)
    throw Error("rotation keyframes need 4 values, not " + std::to_string(width_));
  if (times_.empty()) throw Error("no keyframes");
  const std::size_t groups = interpolation_ == Interpolation::kCubicSpline ? 3 : 1;
  const std::size_t expected = times_.size() * groups * static_cast<std::size_t>(width_);
  if (values_.size() != expected)
    throw Error(std::to_string(times_.size()) + " keyframes need " + std::to_string(expected) +
                " output values, not " + std::to_string(values_.size()));
  for (std::size_t i = 0; i < times_.size(); ++i) {
    if (!std::isfinite(times_[i])) throw Error("keyframe time " + std::to_string(i) + " is not finite");
    if (i > 0 && times_[i] < times_[i - 1])
      throw Error("keyframe times decrease at keyframe " + std::to_string(i) + " (" +
                  std::to_string(times_[i - 1]) + " then " + std::to_string(times_[i]) + ")");
  }
  for (std::size_t i = 0; i < values_.size(); ++i)
    if (!std::isfinite(values_[i]))
      throw Error("keyframe output value " + std::to_string(i) + " is not finite");
}

const float* Keyframes::group(std::size_t key, int g) const {
  const std::size_t groups = interpolation_ == Interpolation::kCubicSpline ? 3 : 1;
  return values_.data() + (key * groups + static_cast<std::size_t>(g)) * static_cast<std::size_t>(width_);
}

void Keyframes::evaluate(double t, std::span<double> out) const {
  const int value_group = interpolation_ == Interpolation::kCubicSpline ? 1 : 0;
  const std::size_t n = times_.size();
  auto copy_value = [&](std::size_t key) {
    const float* v = group(key, value_group);
    for (int i = 0; i < width_; ++i) out[i] = v[i];
  };
  // Clamp outside the keyframes (and a single keyframe is constant).
  if (n == 1 || t <= times_.front()) return copy_value(0);
  if (t >= times_.back()) return copy_value(n - 1);
  // The segment [k, k + 1] with times_[k] <= t < times_[k + 1]; repeated times leave no zero-length
  // segment here, as upper_bound skips past them.
  const std::size_t k1 =
      static_cast<std::size_t>(std::upper_bound(times_.begin(), times_.end(), t) - times_.begin());
  const std::size_t k = k1 - 1;
  if (interpolation_ == Interpolation::kStep) return copy_value(k);

  const double t0 = times_[k], t1 = times_[k1];
  const double td = t1 - t0;
  const double s = (t - t0) / td;
  if (interpolation_ == Interpolation::kLinear) {
    const float* a = group(k, 0);
    const float* b = group(k1, 0);
    if (rotation_) {
      const double qa[4] = {a[0], a[1], a[2], a[3]}, qb[4] = {b[0], b[1], b[2], b[3]};
      slerp(std::span<const double, 4>(qa), std::span<const double, 4>(qb), s,
            std::span<double, 4>(out.data(), 4));
      return;
    }
    for (int i = 0; i < width_; ++i) out[i] = (1.0 - s) * a[i] + s * b[i];
    return;
  }

  // Cubic Hermite spline (glTF 2.0, Appendix C): p(s) = (2s^3 - 3s^2 + 1) v_k + td (s^3 - 2s^2 + s) b_k
  //   + (-2s^3 + 3s^2) v_k+1 + td (s^3 - s^2) a_k+1, with b_k the out-tangent of keyframe k and a_k+1 the
  // in-tangent of keyframe k + 1.
  const double s2 = s * s, s3 = s2 * s;
  const double h00 = 2 * s3 - 3 * s2 + 1, h10 = td * (s3 - 2 * s2 + s), h01 = -2 * s3 + 3 * s2,
               h11 = td * (s3 - s2);
  const float* v0 = group(k, 1);
  const float* b0 = group(k, 2);
  const float* v1 = group(k1, 1);
  const float* a1 = group(k1, 0);
  for (int i = 0; i < width_; ++i) out[i] = h00 * v0[i] + h10 * b0[i] + h01 * v1[i] + h11 * a1[i];
  if (rotation_) normalise4(std::span<double, 4>(out.data(), 4));
}

}  // namespace sahbench
