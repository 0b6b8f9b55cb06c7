#include "scenes/camera.h"

#include <fmt/format.h>

#include <cmath>
#include <numbers>

#include "core/error.h"

namespace sahbench {

Camera automatic_camera(const Aabb& box) {
  constexpr float kAutoFovY = 45.0f * std::numbers::pi_v<float> / 180.0f;
  const Vec3 kAutoDirection = normalize(Vec3{1.0f, 0.6f, 1.4f});
  const float radius = 0.5f * length(box.extent());
  const float distance = radius / std::sin(0.5f * kAutoFovY);
  return Camera{box.center() + kAutoDirection * distance, -kAutoDirection, Vec3{0, 1, 0}, kAutoFovY};
}

Camera look_at_camera(const Vec3& eye, const Vec3& target, const Vec3& up, float fov_y_degrees) {
  auto text = [](const Vec3& v) { return fmt::format("({}, {}, {})", v.x, v.y, v.z); };
  auto finite = [](const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  if (!finite(eye)) throw Error("camera eye " + text(eye) + " is not finite");
  if (!finite(target)) throw Error("camera target " + text(target) + " is not finite");
  if (!finite(up)) throw Error("camera up " + text(up) + " is not finite");
  const Vec3 view = target - eye;
  // In double: a float's square overflows for distances above about 1.8e19.
  const auto distance = static_cast<float>(
      std::sqrt(double(view.x) * view.x + double(view.y) * view.y + double(view.z) * view.z));
  if (!(distance > 0.0f && std::isfinite(distance)))
    throw Error("camera target " + text(target) + " must differ from the eye " + text(eye) +
                " by a finite, non-zero distance");
  const Vec3 forward = view / distance;
  const float up_length = length(up);
  // Up must leave a usable right vector: |forward x up| / |up| is the sine of the angle between them.
  if (!(up_length > 0.0f) || !(length(cross(forward, up)) > 1e-3f * up_length))
    throw Error("camera up " + text(up) + " must be non-zero and not parallel to the view direction " +
                text(forward));
  if (!(fov_y_degrees > 0.0f && fov_y_degrees < 180.0f))
    throw Error(fmt::format("camera fov = {} degrees must be in (0, 180)", fov_y_degrees));
  return Camera{eye, forward, up / up_length, fov_y_degrees * std::numbers::pi_v<float> / 180.0f};
}

}  // namespace sahbench
