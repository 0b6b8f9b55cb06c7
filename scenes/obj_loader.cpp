#include "scenes/obj_loader.h"

#include <tiny_obj_loader.h>

#include <charconv>
#include <cmath>
#include <limits>
#include <sstream>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "core/text_file.h"
#include "scenes/triangle_filter.h"

namespace sahbench {

namespace {

// What tinyobjloader cannot tell us. It reads a coordinate it cannot parse ("nan", "inf", "banana",
// "1e39") as 0 and a face index beyond int as a wrapped one, so that a broken vertex became a valid one at
// the origin. This pass reads the same `v` and `f` lines strictly: a coordinate that is not a finite
// float marks its vertex, and a face corner whose index is not an int marks that corner, so the filter
// counts them (non_finite, bad_index) instead of keeping a triangle nobody wrote.
struct StrictScan {
  std::vector<uint8_t> vertex_ok;               // per `v` line
  std::vector<std::vector<uint8_t>> corner_ok;  // per `f` line, per corner
};

// A coordinate as a float: any number up to FLT_MAX in magnitude (parsed in double, so that 1e-50 is
// the 0 a float holds, not out of range), and no NaN or infinity.
bool finite_float(std::string_view token) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc{} && end == token.data() + token.size() &&
         std::abs(value) <= std::numeric_limits<float>::max();
}

bool int_index(std::string_view corner) {
  std::string_view index = corner.substr(0, corner.find('/'));
  if (!index.empty() && index.front() == '+') index.remove_prefix(1);
  int value = 0;
  const auto [end, ec] = std::from_chars(index.data(), index.data() + index.size(), value);
  return ec == std::errc{} && end == index.data() + index.size();
}

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  while (true) {
    const auto start = line.find_first_not_of(" \t\r");
    if (start == std::string_view::npos) break;
    line.remove_prefix(start);
    const auto end = line.find_first_of(" \t\r");
    words.push_back(line.substr(0, end));
    if (end == std::string_view::npos) break;
    line.remove_prefix(end);
  }
  return words;
}

// The lines as tinyobjloader's LoadObjWithCallback reads them (tiny_obj_loader.h, safeGetline and its
// line loop), so that the n-th flag here is the n-th callback there: lines end at \n, \r\n or a lone
// \r and at a NUL; a line whose first non-blank is '#' is a comment, and only there; `v` and `f` are
// keywords only when a space or tab follows; a face line without corners makes no callback.
StrictScan strict_scan(std::string_view text) {
  StrictScan scan;
  auto blank = [](char c) { return c == ' ' || c == '\t'; };
  while (!text.empty()) {
    const auto end = text.find_first_of("\r\n");
    std::string_view line = text.substr(0, end);
    if (end == std::string_view::npos)
      text = {};
    else
      text.remove_prefix(end + (text[end] == '\r' && end + 1 < text.size() && text[end + 1] == '\n' ? 2 : 1));
    line = line.substr(0, line.find('\0'));
    while (!line.empty() && blank(line.front())) line.remove_prefix(1);
    if (line.size() < 2 || !blank(line[1])) continue;
    if (line.front() == 'v') {
      const std::vector<std::string_view> words = split_words(line.substr(2));
      bool ok = words.size() >= 3;
      for (std::size_t i = 0; ok && i < 3; ++i) ok = finite_float(words[i]);
      scan.vertex_ok.push_back(ok ? 1 : 0);
    } else if (line.front() == 'f') {
      const std::vector<std::string_view> words = split_words(line.substr(2));
      if (words.empty()) continue;
      std::vector<uint8_t>& corners = scan.corner_ok.emplace_back();
      for (const std::string_view word : words) corners.push_back(int_index(word) ? 1 : 0);
    }
  }
  return scan;
}

struct ObjState {
  const StrictScan* scan = nullptr;
  std::size_t faces_seen = 0;
  std::vector<Vec3> vertices;
  // Triangles as resolved vertex indices; resolved to positions at the end because an OBJ face may
  // name a vertex defined later in the file.
  std::vector<int64_t> corners;
  std::size_t degenerate_polygons = 0;
};

void on_vertex(void* user, tinyobj::real_t x, tinyobj::real_t y, tinyobj::real_t z, tinyobj::real_t /*w*/) {
  auto& state = *static_cast<ObjState*>(user);
  const std::size_t k = state.vertices.size();
  const bool ok = k < state.scan->vertex_ok.size() && state.scan->vertex_ok[k];
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  state.vertices.push_back(ok ? Vec3{to_float(x), to_float(y), to_float(z)} : Vec3{kNaN, kNaN, kNaN});
}

void on_face(void* user, tinyobj::index_t* indices, int count) {
  auto& state = *static_cast<ObjState*>(user);
  const std::size_t face = state.faces_seen++;
  const std::vector<uint8_t>* corner_ok =
      face < state.scan->corner_ok.size() &&
              state.scan->corner_ok[face].size() == static_cast<std::size_t>(count)
          ? &state.scan->corner_ok[face]
          : nullptr;
  // OBJ indices are 1-based; negative ones count back from the last vertex read so far; 0 is invalid
  // (tinyobjloader also passes 0 for an index it could not parse). -1 marks a bad index here.
  const auto defined = static_cast<int64_t>(state.vertices.size());
  auto resolve = [&](int corner) -> int64_t {
    // A corner this pass and tinyobjloader do not read alike is refused rather than guessed.
    if (!corner_ok || !(*corner_ok)[static_cast<std::size_t>(corner)]) return -1;
    const int raw = indices[corner].vertex_index;
    if (raw > 0) return raw - 1;
    if (raw < 0 && defined + raw >= 0) return defined + raw;
    return -1;
  };
  if (count < 3) {
    ++state.degenerate_polygons;
    return;
  }
  const int64_t first = resolve(0);
  for (int i = 1; i + 1 < count; ++i) {
    state.corners.push_back(first);
    state.corners.push_back(resolve(i));
    state.corners.push_back(resolve(i + 1));
  }
}

}  // namespace

Scene load_obj(const std::filesystem::path& path) {
  const std::string text = read_text_file(path, "OBJ scene");
  const StrictScan scan = strict_scan(text);
  std::istringstream stream(text);

  ObjState state;
  state.scan = &scan;
  tinyobj::callback_t callbacks;
  callbacks.vertex_cb = on_vertex;
  callbacks.index_cb = on_face;
  std::string warn, err;
  // No MaterialReader: tinyobjloader then skips `mtllib` lines entirely.
  if (!tinyobj::LoadObjWithCallback(stream, callbacks, &state, nullptr, &warn, &err))
    throw Error(path.string() + ": " + (err.empty() ? "cannot parse OBJ" : err));

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
