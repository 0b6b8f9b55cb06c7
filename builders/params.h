#pragma once
// Builder parameters: each builder declares its parameters (name, type, default, range, help); a user's
// `key=value` overrides are checked against that declaration, and the resolved set (every parameter with
// its value) is what the builder reads and what the CSV's builder_params column records.

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace sahbench {

/// kChoice: one of a list of names, held as its index (min 0, max choices - 1) and written by name.
enum class ParamType { kInt, kFloat, kChoice };

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::kInt;
  double default_value = 0.0;
  double min_value = 0.0;
  double max_value = 0.0;
  std::string help;
  std::vector<std::string> choices = {};  ///< kChoice only
};

/// A kChoice parameter whose default is choices[default_index].
ParamSpec choice_param(std::string name, std::vector<std::string> choices, uint32_t default_index,
                       std::string help);

using ParamOverrides = std::vector<std::pair<std::string, std::string>>;

class ParamSet {
 public:
  ParamSet() = default;
  ParamSet(std::string builder, std::vector<std::pair<ParamSpec, double>> values)
      : builder_(std::move(builder)), values_(std::move(values)) {}

  /// The value of a declared parameter; asking for an undeclared one is a programming error (throws).
  double get(std::string_view name) const;
  uint32_t get_uint(std::string_view name) const { return static_cast<uint32_t>(get(name)); }
  float get_float(std::string_view name) const { return static_cast<float>(get(name)); }
  /// Whether a parameter of that name is declared.
  bool has(std::string_view name) const;
  /// The name chosen for a kChoice parameter.
  const std::string& get_choice(std::string_view name) const;

  /// "key=value;key=value" in declaration order, integers without a fraction: the CSV form.
  std::string to_string() const;

 private:
  std::string builder_;
  std::vector<std::pair<ParamSpec, double>> values_;
};

/// Resolves `overrides` against `specs`: unknown names, values that do not parse as the declared type,
/// values out of range and repeated names are errors naming the builder, the key and the value.
ParamSet resolve_params(std::string_view builder, const std::vector<ParamSpec>& specs,
                        const ParamOverrides& overrides);

/// Parses "key=value" into its two parts; an argument without '=' is an error naming it.
std::pair<std::string, std::string> parse_override(std::string_view text);

}  // namespace sahbench
