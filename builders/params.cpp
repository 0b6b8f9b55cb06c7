#include "builders/params.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>

#include "core/error.h"

namespace sahbench {
namespace {

std::string format_value(double value, const ParamSpec& spec) {
  const ParamType type = spec.type;
  if (type == ParamType::kChoice) {
    const auto index = static_cast<std::size_t>(value);
    return index < spec.choices.size() ? spec.choices[index] : "?";
  }
  if (type == ParamType::kInt) return std::to_string(static_cast<long long>(value));
  char buf[32];
  // Shortest representation that reads back to the same double.
  const auto result = std::to_chars(buf, buf + sizeof buf, value);
  return std::string(buf, result.ptr);
}

std::string known_names(const std::vector<ParamSpec>& specs) {
  std::string out;
  for (const auto& s : specs) out += (out.empty() ? "" : ", ") + s.name;
  return out.empty() ? "none" : out;
}

double parse_value(std::string_view builder, const ParamSpec& spec, const std::string& text) {
  const std::string where = std::string(builder) + ": parameter '" + spec.name + "' = '" + text + "'";
  if (spec.type == ParamType::kChoice) {
    for (std::size_t i = 0; i < spec.choices.size(); ++i)
      if (spec.choices[i] == text) return static_cast<double>(i);
    std::string known;
    for (const auto& c : spec.choices) known += (known.empty() ? "" : ", ") + c;
    throw Error(where + " is not one of " + known);
  }
  double value = 0.0;
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, value);
  if (text.empty() || result.ec != std::errc{} || result.ptr != end || !std::isfinite(value))
    throw Error(where + " is not a number");
  if (spec.type == ParamType::kInt && value != std::floor(value)) throw Error(where + " is not an integer");
  if (value < spec.min_value || value > spec.max_value)
    throw Error(where + " is outside [" + format_value(spec.min_value, spec) + ", " +
                format_value(spec.max_value, spec) + "]");
  return value;
}

}  // namespace

double ParamSet::get(std::string_view name) const {
  for (const auto& [spec, value] : values_)
    if (spec.name == name) return value;
  throw Error(builder_ + ": no parameter '" + std::string(name) + "' is declared");
}

std::string ParamSet::to_string() const {
  std::string out;
  for (const auto& [spec, value] : values_)
    out += (out.empty() ? "" : ";") + spec.name + "=" + format_value(value, spec);
  return out;
}

bool ParamSet::has(std::string_view name) const {
  for (const auto& [spec, value] : values_)
    if (spec.name == name) return true;
  return false;
}

const std::string& ParamSet::get_choice(std::string_view name) const {
  for (const auto& [spec, value] : values_)
    if (spec.name == name) {
      if (spec.type != ParamType::kChoice) break;
      return spec.choices.at(static_cast<std::size_t>(value));
    }
  throw Error(builder_ + ": no choice parameter '" + std::string(name) + "' is declared");
}

ParamSpec choice_param(std::string name, std::vector<std::string> choices, uint32_t default_index,
                       std::string help) {
  const double last = static_cast<double>(choices.size()) - 1.0;
  return {std::move(name), ParamType::kChoice, double(default_index), 0.0, last,
          std::move(help), std::move(choices)};
}

ParamSet resolve_params(std::string_view builder, const std::vector<ParamSpec>& specs,
                        const ParamOverrides& overrides) {
  std::vector<std::pair<ParamSpec, double>> values;
  for (const auto& spec : specs) values.emplace_back(spec, spec.default_value);
  std::set<std::string> seen;
  for (const auto& [key, text] : overrides) {
    // Named by value for the lambda: clang before 16 cannot capture a structured binding.
    const std::string& name = key;
    auto it = std::find_if(values.begin(), values.end(), [&](const auto& v) { return v.first.name == name; });
    if (it == values.end())
      throw Error(std::string(builder) + ": unknown parameter '" + key + "' (known: " + known_names(specs) +
                  ")");
    if (!seen.insert(key).second)
      throw Error(std::string(builder) + ": parameter '" + key + "' is given twice");
    it->second = parse_value(builder, it->first, text);
  }
  return ParamSet(std::string(builder), std::move(values));
}

std::pair<std::string, std::string> parse_override(std::string_view text) {
  const auto eq = text.find('=');
  if (eq == std::string_view::npos || eq == 0)
    throw Error("parameter '" + std::string(text) + "' is not of the form key=value");
  return {std::string(text.substr(0, eq)), std::string(text.substr(eq + 1))};
}

}  // namespace sahbench
