// Keyframe interpolation (scenes/keyframes.h) on hand-made cases with known answers: STEP, LINEAR,
// slerp (constant angular speed, shorter arc), CUBICSPLINE (Hermite with the tangents glTF stores),
// clamping outside the keyframes, and the errors for malformed keyframes.

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>

#include "core/error.h"
#include "scenes/keyframes.h"
#include "tests/scenes/temp_dir.h"

namespace sahbench {
namespace {

using test::error_message;

std::vector<double> at(const Keyframes& k, double t) {
  std::vector<double> out(static_cast<std::size_t>(k.width()));
  k.evaluate(t, out);
  return out;
}

// The unit quaternion of a rotation by `degrees` about z.
std::array<double, 4> about_z(double degrees) {
  const double half = degrees * std::numbers::pi / 360.0;
  return {0.0, 0.0, std::sin(half), std::cos(half)};
}

void expect_quat_near(const std::vector<double>& q, const std::array<double, 4>& expected,
                      double tol = 1e-6) {
  ASSERT_EQ(q.size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(q[i], expected[i], tol) << "component " << i;
}

TEST(Keyframes, StepHoldsEachValueUntilTheNextKeyframe) {
  const Keyframes k({0.0f, 1.0f, 2.0f}, {10, 20, 30}, 1, Interpolation::kStep, false);
  EXPECT_EQ(at(k, -1.0), std::vector<double>{10});  // before the first: clamped
  EXPECT_EQ(at(k, 0.0), std::vector<double>{10});
  EXPECT_EQ(at(k, 0.999), std::vector<double>{10});
  EXPECT_EQ(at(k, 1.0), std::vector<double>{20});
  EXPECT_EQ(at(k, 1.5), std::vector<double>{20});
  EXPECT_EQ(at(k, 2.0), std::vector<double>{30});
  EXPECT_EQ(at(k, 7.0), std::vector<double>{30});  // after the last: clamped
}

TEST(Keyframes, LinearInterpolatesEachComponent) {
  const Keyframes k({1.0f, 3.0f, 4.0f}, {0, 10, -2, /**/ 4, 20, 2, /**/ 4, 20, 6}, 3, Interpolation::kLinear,
                    false);
  const auto a = at(k, 1.5);  // a quarter of the way from keyframe 0 to 1
  EXPECT_DOUBLE_EQ(a[0], 1.0);
  EXPECT_DOUBLE_EQ(a[1], 12.5);
  EXPECT_DOUBLE_EQ(a[2], -1.0);
  const auto b = at(k, 3.5);
  EXPECT_DOUBLE_EQ(b[2], 4.0);
  EXPECT_EQ(at(k, 0.0), (std::vector<double>{0, 10, -2}));
  EXPECT_EQ(at(k, 4.0), (std::vector<double>{4, 20, 6}));
}

TEST(Keyframes, SingleKeyframeIsConstant) {
  const Keyframes k({0.5f}, {7, 8, 9}, 3, Interpolation::kLinear, false);
  EXPECT_EQ(at(k, -3.0), (std::vector<double>{7, 8, 9}));
  EXPECT_EQ(at(k, 0.5), (std::vector<double>{7, 8, 9}));
  EXPECT_EQ(at(k, 3.0), (std::vector<double>{7, 8, 9}));
}

TEST(Keyframes, SlerpTurnsAtConstantAngularSpeed) {
  // From no rotation to 90 degrees about z over one second.
  const auto q0 = about_z(0), q1 = about_z(90);
  const Keyframes k({0.0f, 1.0f},
                    {float(q0[0]), float(q0[1]), float(q0[2]), float(q0[3]), float(q1[0]), float(q1[1]),
                     float(q1[2]), float(q1[3])},
                    4, Interpolation::kLinear, true);
  expect_quat_near(at(k, 0.5), about_z(45));
  expect_quat_near(at(k, 1.0 / 3.0), about_z(30));  // a normalised lerp would give 29.3 degrees here
  expect_quat_near(at(k, 0.9), about_z(81));
}

TEST(Keyframes, SlerpTakesTheShorterArc) {
  // 170 degrees, then -q of 10 degrees beyond (the same rotation as 190 degrees written with the
  // opposite sign): the shorter way from 170 to 190 passes 180, not back through 0.
  const auto q0 = about_z(170);
  const auto q1 = about_z(190);
  const std::array<double, 4> q1_negated{-q1[0], -q1[1], -q1[2], -q1[3]};
  double out[4];
  slerp(q0, q1_negated, 0.5, out);
  const std::vector<double> mid(out, out + 4);
  // 180 degrees about z is (0, 0, 1, 0) up to sign.
  const double sign = mid[2] < 0 ? -1.0 : 1.0;
  expect_quat_near({sign * mid[0], sign * mid[1], sign * mid[2], sign * mid[3]}, about_z(180));
}

TEST(Keyframes, SlerpOfNearlyEqualQuaternionsStaysUnit) {
  const auto q0 = about_z(10), q1 = about_z(10.001);
  double out[4];
  slerp(q0, q1, 0.5, out);
  EXPECT_NEAR(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3], 1.0, 1e-12);
  expect_quat_near({out[0], out[1], out[2], out[3]}, about_z(10.0005), 1e-9);
}

TEST(Keyframes, CubicSplineUsesTheStoredTangents) {
  // Two keyframes 2 s apart: value 0 with out-tangent 3, then value 1 with in-tangent -1. Each keyframe
  // stores (in-tangent, value, out-tangent); the first in-tangent and last out-tangent are unused.
  const Keyframes k({0.0f, 2.0f}, {99, 0, 3, /**/ -1, 1, 99}, 1, Interpolation::kCubicSpline, false);
  // Hermite basis at s = 0.5: h00 = 0.5, h10 = 0.125, h01 = 0.5, h11 = -0.125, tangents scaled by 2 s.
  EXPECT_DOUBLE_EQ(at(k, 1.0)[0], 0.5 * 0 + 2 * 0.125 * 3 + 0.5 * 1 + 2 * -0.125 * -1);  // 1.5
  // s = 0.25: h00 = 0.84375, h10 = 0.140625, h01 = 0.15625, h11 = -0.046875.
  EXPECT_DOUBLE_EQ(at(k, 0.5)[0], 1.09375);
  // At and beyond the keyframes: the values, not the tangents.
  EXPECT_DOUBLE_EQ(at(k, 0.0)[0], 0.0);
  EXPECT_DOUBLE_EQ(at(k, 2.0)[0], 1.0);
  EXPECT_DOUBLE_EQ(at(k, -1.0)[0], 0.0);
  EXPECT_DOUBLE_EQ(at(k, 5.0)[0], 1.0);
}

TEST(Keyframes, CubicSplineRotationIsNormalised) {
  const auto q0 = about_z(0), q1 = about_z(90);
  std::vector<float> values;
  for (const auto& q : {q0, q1})
    for (int g = 0; g < 3; ++g)
      for (double c : q) values.push_back(g == 1 ? float(c) : 0.0f);  // zero tangents
  const Keyframes k({0.0f, 1.0f}, values, 4, Interpolation::kCubicSpline, true);
  const auto q = at(k, 0.5);
  EXPECT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12);
  // Zero tangents and s = 0.5 weigh both keyframes equally: the normalised midpoint, 45 degrees.
  expect_quat_near(q, about_z(45));
}

TEST(Keyframes, MalformedKeyframesAreErrors) {
  EXPECT_NE(error_message([] {
              Keyframes({0, 1}, {1, 2, 3}, 1, Interpolation::kLinear, false);
            }).find("need 2 output"),
            std::string::npos);
  EXPECT_NE(error_message([] {
              Keyframes({0, 1}, {1, 2, 3, 4}, 1, Interpolation::kCubicSpline, false);
            }).find("need 6 output"),
            std::string::npos);
  EXPECT_NE(error_message([] {
              Keyframes({1, 0}, {1, 2}, 1, Interpolation::kLinear, false);
            }).find("decrease"),
            std::string::npos);
  EXPECT_NE(error_message([] {
              Keyframes({0, NAN}, {1, 2}, 1, Interpolation::kLinear, false);
            }).find("not finite"),
            std::string::npos);
  EXPECT_NE(error_message([] {
              Keyframes({0, 1}, {1, INFINITY}, 1, Interpolation::kStep, false);
            }).find("not finite"),
            std::string::npos);
  EXPECT_NE(error_message([] { Keyframes({}, {}, 1, Interpolation::kStep, false); }).find("no keyframes"),
            std::string::npos);
  EXPECT_NE(error_message([] {
              Keyframes({0}, {1, 2, 3}, 3, Interpolation::kStep, true);
            }).find("rotation"),
            std::string::npos);
  EXPECT_NE(error_message([] { parse_interpolation("SMOOTH"); }).find("SMOOTH"), std::string::npos);
  EXPECT_EQ(parse_interpolation("CUBICSPLINE"), Interpolation::kCubicSpline);
}

}  // namespace
}  // namespace sahbench
