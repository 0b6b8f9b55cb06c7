#include "scenes/obj_loader.h"

#include <tiny_obj_loader.h>

#include <fstream>
#include <vector>

#include "core/error.h"
#include "scenes/triangle_filter.h"

namespace sahbench {

namespace {

struct ObjState {
  std::vector<Vec3> vertices;
  // Triangles as resolved vertex indices; resolved to positions at the end because an OBJ face may
  // name a vertex defined later in the file.
  std::vector<int64_t> corners;
  std::size_t degenerate_polygons = 0;
};

void on_vertex(void* user, tinyobj::real_t x, tinyobj::real_t y, tinyobj::real_t z, tinyobj::real_t /*w*/) {
  auto& state = *static_cast<ObjState*>(user);
  state.vertices.push_back({to_float(x), to_float(y), to_float(z)});
}

void on_face(void* user, tinyobj::index_t* indices, int count) {
  auto& state = *static_cast<ObjState*>(user);
  // OBJ indices are 1-based; negative ones count back from the last vertex read so far; 0 is invalid
  // (tinyobjloader also passes 0 for an index it could not parse). -1 marks a bad index here.
  const auto defined = static_cast<int64_t>(state.vertices.size());
  auto resolve = [&](int raw) -> int64_t {
    if (raw > 0) return raw - 1;
    if (raw < 0 && defined + raw >= 0) return defined + raw;
    return -1;
  };
  if (count < 3) {
    ++state.degenerate_polygons;
    return;
  }
  const int64_t first = resolve(indices[0].vertex_index);
  for (int i = 1; i + 1 < count; ++i) {
    state.corners.push_back(first);
    state.corners.push_back(resolve(indices[i].vertex_index));
    state.corners.push_back(resolve(indices[i + 1].vertex_index));
  }
}

}  // namespace

Scene load_obj(const std::filesystem::path& path) {
  std::ifstream stream(path, std::ios::binary);
  if (!stream) throw Error(path.string() + ": cannot open file");

  ObjState state;
  tinyobj::callback_t callbacks;
  callbacks.vertex_cb = on_vertex;
  callbacks.index_cb = on_face;
  std::string warn, err;
  // No MaterialReader: tinyobjloader then skips `mtllib` lines entirely.
  if (!tinyobj::LoadObjWithCallback(stream, callbacks, &state, nullptr, &warn, &err))
    throw Error(path.string() + ": " + (err.empty() ? "cannot parse OBJ" : err));
  if (stream.bad()) throw Error(path.string() + ": read error");

  Scene scene;
  scene.source = path.string();
  TriangleFilter filter(scene);
  filter.reserve(state.corners.size() / 3);
  filter.add_degenerate(state.degenerate_polygons);
  for (std::size_t i = 0; i + 2 < state.corners.size(); i += 3)
    filter.add_indexed(state.vertices, state.corners[i], state.corners[i + 1], state.corners[i + 2]);
  return scene;
}

}  // namespace sahbench
