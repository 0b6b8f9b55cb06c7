#pragma once
// Parsing and normalising procedural scene specs: "proc:KIND[:key=value,key=value...]".

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace sahbench {

enum class ProcParamType {
  kCount,    ///< positive whole number, with optional k (1e3) or M (1e6) suffix: 1000, 100k, 1.5M
  kInteger,  ///< non-negative whole number (seeds)
  kReal,     ///< finite real number
};

/// One parameter of a procedural generator: its name, type, default and allowed range (inclusive).
struct ProcParamInfo {
  std::string_view name;
  ProcParamType type = ProcParamType::kReal;
  double default_value = 0.0;
  double min = 0.0;
  double max = 0.0;
  std::string_view help;
};

/// A generator kind and its parameters, in the order the normalised spec lists them.
struct ProcKindInfo {
  std::string_view name;
  std::string_view help;
  std::vector<ProcParamInfo> params;
};

/// A parsed spec with a value for every parameter of its kind (defaults filled in).
class ProcSpec {
 public:
  ProcSpec(const ProcKindInfo& kind, std::vector<uint64_t> integers, std::vector<double> reals)
      : kind_(&kind), integers_(std::move(integers)), reals_(std::move(reals)) {}

  std::string_view kind() const { return kind_->name; }
  /// Value of a kCount or kInteger parameter; `name` must be one of the kind's parameters.
  uint64_t integer(std::string_view name) const { return integers_[index(name)]; }
  /// Value of a kReal parameter.
  double real(std::string_view name) const { return reals_[index(name)]; }

  /// "proc:KIND:key=value,..." with every parameter in declaration order; counts written in full
  /// (tris=1000000) and reals in their shortest round-trip form, so equal scenes have equal specs.
  std::string normalised() const;

 private:
  std::size_t index(std::string_view name) const;

  const ProcKindInfo* kind_;
  std::vector<uint64_t> integers_;  // per parameter; used by kCount and kInteger
  std::vector<double> reals_;       // per parameter; used by kReal
};

/// Parses `spec` against the known kinds. Throws Error naming the spec and the offending kind, key or
/// value (and listing what is accepted).
ProcSpec parse_proc_spec(std::string_view spec, std::span<const ProcKindInfo> kinds);

/// "1000", "100k", "1.5M" as a count; nullopt unless it is a whole number >= 1 (at most 2^53).
std::optional<uint64_t> parse_count(std::string_view text);

}  // namespace sahbench
