#include "builders/params.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include "builders/registry.h"
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

// What the CSV form records of a path: with an identity (a hash of the file's contents), the file's name
// beside it, so that builder_params and a run's fingerprint follow the file, not the folder the run or
// its checkout happens to be in; without one, the whole path.
std::string recorded_path(const ParamSet::Value& value) {
  if (!value.spec.path_identity || value.text.empty()) return value.text;
  return std::filesystem::path(value.text).filename().string();
}

// Sources nest only as deep as someone writes them; a default source that names its own pass would recurse
// forever, and this guards against such a registration.
constexpr int kMaxSourceDepth = 16;

double parse_value(std::string_view builder, const ParamSpec& spec, const std::string& text) {
  const std::string where = std::string(builder) + ": parameter '" + spec.name + "' = '" + text + "'";
  if (spec.type == ParamType::kSource) return 0.0;  // resolved by resolve_source
  if (spec.type == ParamType::kPath) {
    // The CSV form writes the path unquoted between ';' and parentheses, and the command line separates
    // parameters with ','; a path with any of these (or a control character) could not be read back.
    if (text.empty()) throw Error(where + " is empty");
    for (const char c : text)
      if (c == ';' || c == ',' || c == '(' || c == ')' || static_cast<unsigned char>(c) < 0x20)
        throw Error(where +
                    " has a character a path parameter may not hold (';', ',', '(', ')' or a control "
                    "character)");
    return 0.0;
  }
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

ParamSet resolve_params_at(std::string_view builder, const std::vector<ParamSpec>& specs,
                           const ParamOverrides& overrides, int depth);

// The source named `name` for parameter `spec` of `builder`, with the overrides nested under it.
SourceSpec resolve_source(std::string_view builder, const ParamSpec& spec, const std::string& name,
                          const ParamOverrides& nested, int depth) {
  const std::string where = std::string(builder) + "." + spec.name + "=" + name;
  if (depth >= kMaxSourceDepth)
    throw Error(where + ": sources nest deeper than " + std::to_string(kMaxSourceDepth) + " levels");
  SourceSpec source;
  try {
    source.info = &find_builder(name);
  } catch (const Error& e) {
    throw Error(std::string(builder) + ": parameter '" + spec.name + "': " + e.what());
  }
  const auto& shared = spec.shared_sources;
  if (nested.empty() && std::find(shared.begin(), shared.end(), name) != shared.end()) return source;
  auto params =
      std::make_shared<const ParamSet>(resolve_params_at(where, source.info->params, nested, depth + 1));
  if (source.info->check) source.info->check(*params);
  const uint32_t arity = source.info->arity ? source.info->arity(*params) : 2;
  if (arity != 2)
    throw Error(where + ": builds " + std::to_string(arity) + "-wide trees, and " + std::string(builder) +
                " takes a binary tree from '" + spec.name + "' (a builder or pass of arity 2)");
  source.params = std::move(params);
  return source;
}

ParamSet resolve_params_at(std::string_view builder, const std::vector<ParamSpec>& specs,
                           const ParamOverrides& overrides, int depth) {
  std::vector<ParamSet::Value> values;
  for (const auto& spec : specs) values.push_back({spec, spec.default_value});
  std::set<std::string> seen;
  std::map<std::string, std::string> source_names;  // kSource parameter -> the builder named
  std::map<std::string, ParamOverrides> nested;     // kSource parameter -> the overrides under it
  for (const auto& [key, text] : overrides) {
    // "P.rest": rest belongs to source parameter P.
    const auto dot = key.find('.');
    const std::string name = key.substr(0, dot);
    auto it = std::find_if(values.begin(), values.end(), [&](const auto& v) { return v.spec.name == name; });
    if (it == values.end())
      throw Error(std::string(builder) + ": unknown parameter '" + key + "' (known: " + known_names(specs) +
                  ")");
    if (dot != std::string::npos) {
      if (it->spec.type != ParamType::kSource)
        throw Error(std::string(builder) + ": parameter '" + name + "' is not a tree source, so '" + key +
                    "' names nothing");
      nested[name].emplace_back(key.substr(dot + 1), text);
      continue;
    }
    if (!seen.insert(key).second)
      throw Error(std::string(builder) + ": parameter '" + key + "' is given twice");
    it->given = true;
    if (it->spec.type == ParamType::kSource) source_names[name] = text;
    if (it->spec.type == ParamType::kPath) {
      // Held absolute, so that the file is found whatever the current folder later is; the characters
      // are checked on the text the CSV form records (recorded_path).
      it->text = text.empty() ? text : std::filesystem::absolute(text).lexically_normal().string();
      it->number = parse_value(builder, it->spec, recorded_path(*it));
      if (it->spec.path_identity) it->identity = it->spec.path_identity(it->text);
      continue;
    }
    it->number = parse_value(builder, it->spec, text);
  }
  for (auto& value : values) {
    if (value.spec.type != ParamType::kSource) continue;
    const auto named = source_names.find(value.spec.name);
    const std::string& source = named == source_names.end() ? value.spec.default_source : named->second;
    value.source = resolve_source(builder, value.spec, source, nested[value.spec.name], depth);
  }
  return ParamSet(std::string(builder), std::move(values));
}

}  // namespace

const std::string& SourceSpec::name() const {
  return info->name;
}

const ParamSet::Value& ParamSet::find(std::string_view name) const {
  for (const auto& value : values_)
    if (value.spec.name == name) return value;
  throw Error(builder_ + ": no parameter '" + std::string(name) + "' is declared");
}

double ParamSet::get(std::string_view name) const {
  const Value& value = find(name);
  if (value.spec.type == ParamType::kSource || value.spec.type == ParamType::kPath)
    throw Error(builder_ + ": parameter '" + std::string(name) + "' is a " +
                (value.spec.type == ParamType::kPath ? "path" : "tree source") + ", not a number");
  return value.number;
}

std::string ParamSet::to_string() const {
  // The source the pass builds itself (named alone and shared), if any: only_with_sources is read
  // against it.
  const Value* shared = nullptr;
  bool any_source = false;
  for (const auto& v : values_)
    if (v.spec.type == ParamType::kSource) {
      any_source = true;
      if (v.source.shared()) shared = &v;
    }
  auto applies = [&](const ParamSpec& spec) {
    if (spec.only_with_sources.empty() || !any_source) return true;
    return shared && std::find(spec.only_with_sources.begin(), spec.only_with_sources.end(),
                               shared->source.name()) != spec.only_with_sources.end();
  };
  std::string out;
  for (const auto& value : values_) {
    if (!applies(value.spec)) continue;
    out += (out.empty() ? "" : ";") + value.spec.name + "=";
    if (value.spec.type == ParamType::kPath) {
      out += recorded_path(value);
      if (!value.identity.empty()) out += ";" + value.spec.name + "_hash=" + value.identity;
      continue;
    }
    if (value.spec.type != ParamType::kSource) {
      out += format_value(value.number, value.spec);
      continue;
    }
    out += value.source.name();
    if (value.source.shared()) continue;
    out += '(';
    out += value.source.params->to_string();
    out += ')';
  }
  return out;
}

bool ParamSet::has(std::string_view name) const {
  for (const auto& value : values_)
    if (value.spec.name == name) return true;
  return false;
}

const std::string& ParamSet::get_choice(std::string_view name) const {
  for (const auto& value : values_)
    if (value.spec.name == name) {
      if (value.spec.type != ParamType::kChoice) break;
      return value.spec.choices.at(static_cast<std::size_t>(value.number));
    }
  throw Error(builder_ + ": no choice parameter '" + std::string(name) + "' is declared");
}

const SourceSpec& ParamSet::get_source(std::string_view name) const {
  const Value& value = find(name);
  if (value.spec.type != ParamType::kSource)
    throw Error(builder_ + ": parameter '" + std::string(name) + "' is not a tree source");
  return value.source;
}

const std::string& ParamSet::get_path(std::string_view name) const {
  const Value& value = find(name);
  if (value.spec.type != ParamType::kPath)
    throw Error(builder_ + ": parameter '" + std::string(name) + "' is not a path");
  return value.text;
}

const std::string& ParamSet::get_path_identity(std::string_view name) const {
  const Value& value = find(name);
  if (value.spec.type != ParamType::kPath)
    throw Error(builder_ + ": parameter '" + std::string(name) + "' is not a path");
  return value.identity;
}

bool ParamSet::reads_files() const {
  return std::any_of(values_.begin(), values_.end(), [](const Value& v) {
    if (v.spec.type == ParamType::kPath) return !v.text.empty();
    return v.spec.type == ParamType::kSource && !v.source.shared() && v.source.params->reads_files();
  });
}

std::vector<const SourceSpec*> ParamSet::own_sources() const {
  std::vector<const SourceSpec*> out;
  for (const Value& v : values_)
    if (v.spec.type == ParamType::kSource && !v.source.shared()) out.push_back(&v.source);
  return out;
}

ParamSpec path_param(std::string name, std::string help,
                     std::function<std::string(const std::string&)> identity) {
  ParamSpec spec{std::move(name), ParamType::kPath, 0.0, 0.0, 0.0, std::move(help)};
  spec.path_identity = std::move(identity);
  return spec;
}

ParamSpec choice_param(std::string name, std::vector<std::string> choices, uint32_t default_index,
                       std::string help) {
  const double last = static_cast<double>(choices.size()) - 1.0;
  return {std::move(name), ParamType::kChoice, double(default_index), 0.0, last,
          std::move(help), std::move(choices)};
}

ParamSpec source_param(std::string name, std::string default_source, std::string help,
                       std::vector<std::string> shared_sources) {
  ParamSpec spec{std::move(name), ParamType::kSource, 0.0, 0.0, 0.0, std::move(help)};
  spec.default_source = std::move(default_source);
  spec.shared_sources = std::move(shared_sources);
  return spec;
}

ParamSet resolve_params(std::string_view builder, const std::vector<ParamSpec>& specs,
                        const ParamOverrides& overrides) {
  return resolve_params_at(builder, specs, overrides, 0);
}

std::pair<std::string, std::string> parse_override(std::string_view text) {
  const auto eq = text.find('=');
  if (eq == std::string_view::npos || eq == 0)
    throw Error("parameter '" + std::string(text) + "' is not of the form key=value");
  return {std::string(text.substr(0, eq)), std::string(text.substr(eq + 1))};
}

}  // namespace sahbench
