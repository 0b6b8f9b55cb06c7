#include "scenes/gltf_loader.h"

#include <string>
#include <vector>

#include "scenes/gltf_reader.h"
#include "scenes/transform.h"
#include "scenes/triangle_filter.h"

namespace sahbench {

namespace {

// The first perspective camera found in the hierarchy becomes the scene camera; glTF cameras look
// down their local -z with +y up. Point and spot lights (KHR_lights_punctual) contribute positions.
void place_camera_and_light(const tinygltf::Model& model, const tinygltf::Node& node, const Mat4& m,
                            Scene& scene) {
  if (!scene.camera && node.camera >= 0 && static_cast<std::size_t>(node.camera) < model.cameras.size()) {
    const tinygltf::Camera& cam = model.cameras[static_cast<std::size_t>(node.camera)];
    const Vec3 forward = transform_direction(m, 0, 0, -1), up = transform_direction(m, 0, 1, 0);
    if (cam.type == "perspective" && cam.perspective.yfov > 0 && length(forward) > 0 &&
        length(cross(forward, up)) > 0) {
      const Vec3 f = normalize(forward);
      const Vec3 u = normalize(cross(normalize(cross(f, up)), f));
      scene.camera = Camera{transform_point(m, 0, 0, 0), f, u, static_cast<float>(cam.perspective.yfov)};
    }
  }
  const auto ext = node.extensions.find("KHR_lights_punctual");
  if (ext != node.extensions.end() && ext->second.Has("light")) {
    const int light = ext->second.Get("light").GetNumberAsInt();
    if (light >= 0 && static_cast<std::size_t>(light) < model.lights.size() &&
        model.lights[static_cast<std::size_t>(light)].type != "directional")
      scene.lights.push_back(transform_point(m, 0, 0, 0));
  }
}

// Each use of a mesh places its triangles once, transformed by the node's world matrix in double.
void place_mesh(GltfReader& reader, int mesh_index, const Mat4& m, TriangleFilter& filter) {
  for (const DecodedPrimitive& prim : reader.decode_mesh(mesh_index)) {
    std::vector<Vec3> world(prim.positions.size());
    for (std::size_t i = 0; i < world.size(); ++i) world[i] = transform_point(m, prim.positions[i]);
    filter.reserve(prim.corners.size() / 3);
    for (std::size_t i = 0; i + 2 < prim.corners.size(); i += 3)
      filter.add_indexed(world, prim.corners[i], prim.corners[i + 1], prim.corners[i + 2]);
  }
}

}  // namespace

Scene load_gltf(const std::filesystem::path& path, bool binary) {
  const tinygltf::Model model = load_gltf_model(path, binary);
  Scene scene;
  scene.source = path.string();
  GltfReader reader(model, scene.source);
  reader.check_required_extensions();
  TriangleFilter filter(scene);
  // World matrices in the order scene_nodes() gives, where a parent precedes its children.
  std::vector<Mat4> world(model.nodes.size(), kIdentity);
  for (const VisitedNode& v : reader.scene_nodes()) {
    const Mat4& parent = v.parent < 0 ? kIdentity : world[static_cast<std::size_t>(v.parent)];
    world[static_cast<std::size_t>(v.node)] = multiply(parent, reader.local_transform(v.node));
    const tinygltf::Node& node = model.nodes[static_cast<std::size_t>(v.node)];
    if (node.mesh >= 0) {
      if (static_cast<std::size_t>(node.mesh) >= model.meshes.size())
        reader.fail("node " + std::to_string(v.node) + ": mesh index " + std::to_string(node.mesh) +
                    " out of range");
      place_mesh(reader, node.mesh, world[static_cast<std::size_t>(v.node)], filter);
    }
    place_camera_and_light(model, node, world[static_cast<std::size_t>(v.node)], scene);
  }
  scene.animated = !model.animations.empty();
  return scene;
}

}  // namespace sahbench
