#pragma once
// Cameras for primary rays: one aimed at a point, as a config's [[camera]] or `sahbench image --eye`
// gives it, and the automatic framing of a scene without a camera of its own.

#include "core/aabb.h"
#include "core/vec3.h"
#include "scenes/scene.h"

namespace sahbench {

/// A pinhole camera at `eye` looking at `target` (the centre of the image), `up` the image's up direction
/// (orthogonalised against the view direction when the rays are made), `fov_y_degrees` its vertical field of
/// view. A non-finite coordinate, `target` equal to `eye`, an `up` of zero length or parallel to the view
/// direction, and a field of view outside (0, 180) degrees are each an Error naming the value.
Camera look_at_camera(const Vec3& eye, const Vec3& target, const Vec3& up, float fov_y_degrees);

/// The automatic framing of `box`: a 45-degree vertical field of view, from the direction
/// (1, 0.6, 1.4), y up, the box's bounding sphere filling the view; primary rays use it for a scene
/// without a camera. Its `up` is (0, 1, 0), not yet orthogonalised against the view direction.
Camera automatic_camera(const Aabb& box);

}  // namespace sahbench
