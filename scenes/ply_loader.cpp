#include "scenes/ply_loader.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "scenes/file_reader.h"
#include "scenes/triangle_filter.h"

namespace sahbench {

namespace {

enum class Format { kAscii, kBinaryLittleEndian, kBinaryBigEndian };
enum class Type { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };

struct Property {
  std::string name;
  Type type = Type::kFloat32;  // the value type (the item type for a list)
  bool is_list = false;
  Type count_type = Type::kUInt8;  // lists only
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
};

// Header lines are short; a longer one means this is not a PLY header (or a binary file).
constexpr std::size_t kMaxHeaderLine = 4096;
constexpr std::size_t kMaxHeaderLines = 10000;
// Indices are stored as 32-bit; this marks one that was negative or too large, so it counts as bad.
constexpr uint32_t kBadIndex = std::numeric_limits<uint32_t>::max();

std::optional<Type> parse_type(std::string_view s) {
  static constexpr std::array<std::pair<std::string_view, Type>, 16> kNames{{
      {"char", Type::kInt8},
      {"int8", Type::kInt8},
      {"uchar", Type::kUInt8},
      {"uint8", Type::kUInt8},
      {"short", Type::kInt16},
      {"int16", Type::kInt16},
      {"ushort", Type::kUInt16},
      {"uint16", Type::kUInt16},
      {"int", Type::kInt32},
      {"int32", Type::kInt32},
      {"uint", Type::kUInt32},
      {"uint32", Type::kUInt32},
      {"float", Type::kFloat32},
      {"float32", Type::kFloat32},
      {"double", Type::kFloat64},
      {"float64", Type::kFloat64},
  }};
  for (const auto& [name, type] : kNames)
    if (name == s) return type;
  return std::nullopt;
}

std::size_t type_size(Type t) {
  switch (t) {
    case Type::kInt8:
    case Type::kUInt8:
      return 1;
    case Type::kInt16:
    case Type::kUInt16:
      return 2;
    case Type::kInt32:
    case Type::kUInt32:
    case Type::kFloat32:
      return 4;
    case Type::kFloat64:
      return 8;
  }
  return 0;
}

bool is_integer(Type t) {
  return t != Type::kFloat32 && t != Type::kFloat64;
}

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    std::size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
    if (j > i) words.push_back(line.substr(i, j - i));
    i = j;
  }
  return words;
}

// "vertices", "faces", or "NAME elements", for messages.
std::string plural(const Element& e) {
  if (e.name == "vertex") return "vertices";
  if (e.name == "face") return "faces";
  return "'" + e.name + "' elements";
}

Header parse_header(FileReader& in) {
  const std::string& file = in.name();
  auto fail = [&](const std::string& what) -> Error {
    return Error(file + ": header line " + std::to_string(in.line_number()) + ": " + what);
  };

  std::string line;
  if (!in.read_line(line, kMaxHeaderLine) || line != "ply")
    throw Error(file + ": not a PLY file (the first line is not 'ply')");

  Header header;
  bool have_format = false;
  for (std::size_t n = 0; n < kMaxHeaderLines; ++n) {
    if (!in.read_line(line, kMaxHeaderLine)) throw Error(file + ": truncated header: no 'end_header' line");
    const auto words = split_words(line);
    if (words.empty()) continue;
    const std::string_view key = words[0];
    if (key == "comment" || key == "obj_info") continue;
    if (key == "end_header") {
      if (!have_format) throw fail("'end_header' before any 'format' line");
      return header;
    }
    if (key == "format") {
      if (words.size() != 3) throw fail("expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
      if (words[1] == "ascii")
        header.format = Format::kAscii;
      else if (words[1] == "binary_little_endian")
        header.format = Format::kBinaryLittleEndian;
      else if (words[1] == "binary_big_endian")
        header.format = Format::kBinaryBigEndian;
      else
        throw fail("unknown format '" + std::string(words[1]) + "'");
      have_format = true;
    } else if (key == "element") {
      if (words.size() != 3) throw fail("expected 'element NAME COUNT'");
      Element e;
      e.name = words[1];
      const auto [end, ec] = std::from_chars(words[2].data(), words[2].data() + words[2].size(), e.count);
      if (ec != std::errc() || end != words[2].data() + words[2].size())
        throw fail("bad element count '" + std::string(words[2]) + "'");
      header.elements.push_back(std::move(e));
    } else if (key == "property") {
      if (header.elements.empty()) throw fail("'property' before any 'element'");
      Property p;
      if (words.size() == 5 && words[1] == "list") {
        const auto count_type = parse_type(words[2]);
        const auto item_type = parse_type(words[3]);
        if (!count_type) throw fail("unknown type '" + std::string(words[2]) + "'");
        if (!item_type) throw fail("unknown type '" + std::string(words[3]) + "'");
        if (!is_integer(*count_type)) throw fail("list count type must be an integer type");
        p.is_list = true;
        p.count_type = *count_type;
        p.type = *item_type;
        p.name = words[4];
      } else if (words.size() == 3 && words[1] != "list") {
        const auto type = parse_type(words[1]);
        if (!type) throw fail("unknown type '" + std::string(words[1]) + "'");
        p.type = *type;
        p.name = words[2];
      } else {
        throw fail("expected 'property TYPE NAME' or 'property list COUNT_TYPE ITEM_TYPE NAME'");
      }
      header.elements.back().properties.push_back(std::move(p));
    } else {
      throw fail("unknown keyword '" + std::string(key) + "'");
    }
  }
  throw Error(file + ": no 'end_header' within the first " + std::to_string(kMaxHeaderLines) + " lines");
}

/// Reads property values in the file's encoding. Returns nullopt at end of file; the caller reports
/// which element ran short.
class ValueReader {
 public:
  ValueReader(FileReader& in, Format format) : in_(in), format_(format) {}

  std::optional<double> real(Type t) {
    if (format_ == Format::kAscii) {
      const std::string_view token = in_.next_token();
      if (token.empty()) return std::nullopt;
      if (is_integer(t)) return static_cast<double>(parse_ascii_integer(token));
      double v = 0.0;
      const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
      // from_chars reports a value beyond the double range (or below it) without giving the rounded
      // result; strtod gives +-inf (counted as non-finite by the filter) or the underflowed value.
      if (ec == std::errc::result_out_of_range && end == token.data() + token.size())
        return std::strtod(std::string(token).c_str(), nullptr);
      if (ec != std::errc() || end != token.data() + token.size()) throw bad_number(token);
      return v;
    }
    return binary_as<double>(t);
  }

  /// An integer-typed value (list counts, indices).
  std::optional<int64_t> integer(Type t) {
    if (format_ == Format::kAscii) {
      const std::string_view token = in_.next_token();
      if (token.empty()) return std::nullopt;
      return parse_ascii_integer(token);
    }
    if (!is_integer(t)) return std::nullopt;  // not reached: the header check allows only integer types here
    return binary_as<int64_t>(t);
  }

  /// Skips one value; false at end of file.
  bool skip(Type t) {
    if (format_ == Format::kAscii) return !in_.next_token().empty();
    return in_.skip(type_size(t));
  }

  /// Skips `count` values of one type; false at end of file.
  bool skip(Type t, uint64_t count) {
    if (format_ != Format::kAscii) {
      // Guard the multiplication: a count this large cannot be in any file anyway.
      if (count > std::numeric_limits<std::size_t>::max() / 8) return false;
      return in_.skip(static_cast<std::size_t>(count) * type_size(t));
    }
    for (uint64_t i = 0; i < count; ++i)
      if (in_.next_token().empty()) return false;
    return true;
  }

 private:
  /// The next binary value, of type `t`, converted to `Out`; nullopt at end of file.
  template <typename Out>
  std::optional<Out> binary_as(Type t) {
    switch (t) {
      case Type::kInt8:
        return binary<int8_t>();
      case Type::kUInt8:
        return binary<uint8_t>();
      case Type::kInt16:
        return binary<int16_t>();
      case Type::kUInt16:
        return binary<uint16_t>();
      case Type::kInt32:
        return binary<int32_t>();
      case Type::kUInt32:
        return binary<uint32_t>();
      case Type::kFloat32:
        return binary<float>();
      case Type::kFloat64:
        return binary<double>();
    }
    return std::nullopt;
  }

  template <typename T>
  std::optional<T> binary() {
    std::array<unsigned char, sizeof(T)> bytes;
    if (!in_.read(bytes.data(), bytes.size())) return std::nullopt;
    const bool file_little = format_ == Format::kBinaryLittleEndian;
    if (file_little != (std::endian::native == std::endian::little)) std::reverse(bytes.begin(), bytes.end());
    return std::bit_cast<T>(bytes);
  }

  int64_t parse_ascii_integer(std::string_view token) const {
    int64_t v = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
    if (ec != std::errc() || end != token.data() + token.size()) throw bad_number(token);
    return v;
  }

  Error bad_number(std::string_view token) const {
    return Error(in_.name() + ": line " + std::to_string(in_.line_number()) + ": '" + std::string(token) +
                 "' is not a number of the declared type");
  }

  FileReader& in_;
  Format format_;
};

// Where the vertex and face data live in the header.
struct Layout {
  std::size_t vertex_element = 0, face_element = 0;
  std::size_t x = 0, y = 0, z = 0;  // property indices in the vertex element
  std::size_t indices = 0;          // list property index in the face element
};

Layout check_header(const Header& header, const std::string& file) {
  Layout layout;
  auto find_element = [&](std::string_view name) -> std::optional<std::size_t> {
    for (std::size_t i = 0; i < header.elements.size(); ++i)
      if (header.elements[i].name == name) return i;
    return std::nullopt;
  };
  const auto vertex = find_element("vertex");
  const auto face = find_element("face");
  if (!vertex) throw Error(file + ": no 'vertex' element in the header");
  if (!face) throw Error(file + ": no 'face' element in the header (point clouds are not supported)");
  layout.vertex_element = *vertex;
  layout.face_element = *face;

  const Element& v = header.elements[*vertex];
  for (auto [axis, slot] :
       {std::pair{"x", &layout.x}, std::pair{"y", &layout.y}, std::pair{"z", &layout.z}}) {
    bool found = false;
    for (std::size_t i = 0; i < v.properties.size(); ++i)
      if (v.properties[i].name == axis) {
        if (v.properties[i].is_list) throw Error(file + ": vertex property '" + axis + "' is a list");
        *slot = i;
        found = true;
      }
    if (!found) throw Error(file + ": the 'vertex' element has no '" + axis + "' property");
  }
  // Indices are stored as 32-bit; kBadIndex is reserved.
  if (v.count >= kBadIndex) throw Error(file + ": too many vertices (" + std::to_string(v.count) + ")");

  const Element& f = header.elements[*face];
  bool found = false;
  for (std::size_t i = 0; i < f.properties.size() && !found; ++i) {
    const Property& p = f.properties[i];
    if (p.name != "vertex_indices" && p.name != "vertex_index") continue;
    if (!p.is_list) throw Error(file + ": face property '" + p.name + "' is not a list");
    if (!is_integer(p.type)) throw Error(file + ": face property '" + p.name + "' has a non-integer type");
    layout.indices = i;
    found = true;
  }
  if (!found) throw Error(file + ": the 'face' element has no 'vertex_indices' (or 'vertex_index') list");
  return layout;
}

[[noreturn]] void truncated(const std::string& file, const Element& e, uint64_t done) {
  throw Error(file + ": truncated: expected " + std::to_string(e.count) + " " + plural(e) +
              ", file ends after " + std::to_string(done));
}

}  // namespace

Scene load_ply(const std::filesystem::path& path) {
  FileReader in(path);
  const std::string& file = in.name();
  const Header header = parse_header(in);
  const Layout layout = check_header(header, file);
  ValueReader values(in, header.format);

  std::vector<Vec3> vertices;
  // Triangles as vertex index triples, resolved once all elements are read (a file may list faces first).
  std::vector<uint32_t> corners;
  std::size_t degenerate_polygons = 0;
  auto to_index = [](int64_t i) {
    return i < 0 || i >= static_cast<int64_t>(kBadIndex) ? kBadIndex : static_cast<uint32_t>(i);
  };
  // Counts come from the file; cap what is reserved up front so a lying header cannot exhaust memory.
  constexpr uint64_t kMaxReserve = uint64_t{1} << 22;

  for (std::size_t ei = 0; ei < header.elements.size(); ++ei) {
    const Element& e = header.elements[ei];
    // An element without properties holds no bytes, whatever its count: nothing to read or skip (and a
    // count near 2^64 would otherwise spin here forever).
    if (e.properties.empty()) continue;
    const bool is_vertex = ei == layout.vertex_element;
    const bool is_face = ei == layout.face_element;
    if (is_vertex) vertices.reserve(static_cast<std::size_t>(std::min(e.count, kMaxReserve)));
    if (is_face) corners.reserve(static_cast<std::size_t>(std::min(e.count, kMaxReserve) * 3));

    for (uint64_t item = 0; item < e.count; ++item) {
      std::array<double, 3> xyz{};
      for (std::size_t pi = 0; pi < e.properties.size(); ++pi) {
        const Property& p = e.properties[pi];
        if (p.is_list) {
          const auto count = values.integer(p.count_type);
          if (!count) truncated(file, e, item);
          if (*count < 0)
            throw Error(file + ": " + plural(e) + " #" + std::to_string(item) + ": negative list length");
          if (!(is_face && pi == layout.indices)) {
            if (!values.skip(p.type, static_cast<uint64_t>(*count))) truncated(file, e, item);
            continue;
          }
          // Fan-triangulate the polygon (first, i, i+1) as its indices stream in.
          if (*count < 3) {
            ++degenerate_polygons;
            if (!values.skip(p.type, static_cast<uint64_t>(*count))) truncated(file, e, item);
            continue;
          }
          std::array<uint32_t, 3> fan{};
          for (int64_t k = 0; k < *count; ++k) {
            const auto index = values.integer(p.type);
            if (!index) truncated(file, e, item);
            const uint32_t i = to_index(*index);
            if (k < 2) {
              fan[static_cast<std::size_t>(k)] = i;
              continue;
            }
            fan[2] = i;
            corners.insert(corners.end(), fan.begin(), fan.end());
            fan[1] = i;
          }
        } else if (is_vertex && (pi == layout.x || pi == layout.y || pi == layout.z)) {
          const auto v = values.real(p.type);
          if (!v) truncated(file, e, item);
          xyz[pi == layout.x ? 0 : (pi == layout.y ? 1 : 2)] = *v;
        } else if (!values.skip(p.type)) {
          truncated(file, e, item);
        }
      }
      if (is_vertex) vertices.push_back({to_float(xyz[0]), to_float(xyz[1]), to_float(xyz[2])});
    }
  }

  Scene scene;
  scene.source = path.string();
  TriangleFilter filter(scene);
  filter.reserve(corners.size() / 3);
  filter.add_degenerate(degenerate_polygons);
  for (std::size_t i = 0; i + 2 < corners.size(); i += 3) {
    // kBadIndex is >= vertices.size() (checked in check_header), so the filter counts it as bad.
    filter.add_indexed(vertices, corners[i], corners[i + 1], corners[i + 2]);
  }
  return scene;
}

}  // namespace sahbench
