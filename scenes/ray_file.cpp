#include "scenes/ray_file.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <limits>
#include <sstream>
#include <string>
#include <string_view>

#include "core/error.h"
#include "core/text_file.h"

namespace sahbench {
namespace {

// A token as an error message can show it: bytes outside printable ASCII (a NUL would cut the message)
// as \xNN.
std::string printable(std::string_view token) {
  std::string out;
  for (const char c : token) {
    const auto u = static_cast<unsigned char>(c);
    out += u >= 0x20 && u < 0x7f ? std::string(1, c) : fmt::format("\\x{:02x}", u);
  }
  return out;
}

float parse_float(std::string_view token, const std::string& where) {
  // from_chars takes no leading '+'; a number written with one is still a number.
  const bool plus =
      token.size() > 1 && token.front() == '+' &&
      (std::isdigit(static_cast<unsigned char>(token[1])) || token[1] == '.' || token[1] == 'i');
  const std::string_view digits = plus ? token.substr(1) : token;
  if (digits == "inf") return std::numeric_limits<float>::infinity();
  if (token == "-inf") return -std::numeric_limits<float>::infinity();
  float value = 0.0f;
  const auto result = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (result.ptr != digits.data() + digits.size() || result.ec == std::errc::invalid_argument)
    throw Error(where + ": '" + printable(token) + "' is not a number");
  if (result.ec == std::errc::result_out_of_range)
    throw Error(where + ": '" + printable(token) +
                "' is outside the range of a float (magnitudes 1.4e-45 to 3.4e38, or 0, inf)");
  if (value != value) throw Error(where + ": '" + printable(token) + "' is not a number (NaN)");
  return value;
}

// The fields of a line: separated by spaces and tabs, or by one comma with any spaces around it. Two
// commas with nothing between them, or a comma at either end, leave a field empty: an Error, since the
// numbers after it would silently shift to other columns.
std::vector<std::string_view> fields(std::string_view rest, const std::string& where) {
  constexpr std::string_view kBlank = " \t\r";
  std::vector<std::string_view> out;
  bool after_comma = false;
  auto empty_field = [&] { return Error(where + ": field " + std::to_string(out.size() + 1) + " is empty"); };
  for (;;) {
    const auto start = rest.find_first_not_of(kBlank);
    if (start == std::string_view::npos) {
      if (after_comma) throw empty_field();
      return out;
    }
    rest = rest.substr(start);
    if (rest.front() == ',') {
      if (after_comma || out.empty()) throw empty_field();
      after_comma = true;
      rest = rest.substr(1);
      continue;
    }
    const auto end = rest.find_first_of(" \t,\r");
    out.push_back(rest.substr(0, end));
    after_comma = false;
    rest = end == std::string_view::npos ? std::string_view{} : rest.substr(end);
  }
}

// Whether `token` reads as a word rather than a number: a header line's column name.
bool is_word(std::string_view token) {
  if (token.empty() || !std::isalpha(static_cast<unsigned char>(token.front()))) return false;
  std::string lower(token);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower != "inf" && lower != "infinity" && lower != "nan";
}

}  // namespace

std::vector<Ray> read_rays(const std::filesystem::path& path, std::vector<std::size_t>* lines) {
  std::istringstream in(read_text_file(path, "ray file"));
  std::vector<Ray> rays;
  std::string line;
  bool first = true;  // the first non-empty line, which may be a header
  for (std::size_t number = 1; std::getline(in, line); ++number) {
    const std::string where = path.string() + ":" + std::to_string(number);
    // A comment runs to the end of the line.
    const std::vector<std::string_view> tokens =
        fields(std::string_view(line).substr(0, line.find('#')), where);
    if (tokens.empty()) continue;
    // A first line of column names ("ox oy oz dx dy dz") is a header, not data.
    const bool header = first && std::all_of(tokens.begin(), tokens.end(), is_word);
    first = false;
    if (header) continue;
    if (tokens.size() != 6 && tokens.size() != 8)
      throw Error(where + ": expected 6 or 8 numbers (ox oy oz dx dy dz [tmin tmax]), found " +
                  std::to_string(tokens.size()));
    float v[8] = {0, 0, 0, 0, 0, 0, 0, std::numeric_limits<float>::infinity()};
    for (std::size_t i = 0; i < tokens.size(); ++i) v[i] = parse_float(tokens[i], where);
    Ray ray;
    ray.org = {v[0], v[1], v[2]};
    ray.dir = {v[3], v[4], v[5]};
    ray.tmin = v[6];
    ray.tmax = v[7];
    if (!traceable(ray))  // NaN is refused above: an infinite component
      throw Error(where + ": the origin and the direction must be finite");
    if (!(ray.tmin >= 0.0f && ray.tmin < std::numeric_limits<float>::infinity()))
      throw Error(where + fmt::format(": tmin = {} must be finite and at least 0 (the kernels answer for "
                                      "[tmin, tmax] with tmin >= 0)",
                                      ray.tmin));
    // An empty interval would answer every query with a miss, as swapped columns would.
    if (ray.tmax < ray.tmin)
      throw Error(where + fmt::format(": tmax = {} is below tmin = {}: the interval [tmin, tmax] is empty "
                                      "(the columns are ox oy oz dx dy dz tmin tmax)",
                                      ray.tmax, ray.tmin));
    if (ray.dir == Vec3{0, 0, 0}) throw Error(where + ": the direction is zero");
    rays.push_back(ray);
    if (lines) lines->push_back(number);
  }
  if (rays.empty()) throw Error(path.string() + ": no rays in the ray file");
  return rays;
}

}  // namespace sahbench
