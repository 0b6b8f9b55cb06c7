#pragma once
// Builder parameters: each builder declares its parameters (name, type, default, range, help); a user's
// `key=value` overrides are checked against that declaration, and the resolved set (every parameter with
// its value) is what the builder reads and what the CSV's builder_params column records.
//
// Passes take a tree from a source (a kSource parameter, usually `source`): any registered builder or
// pass of arity 2, named with its own parameters, so that passes compose. The overrides spell the chain
// with dotted keys, `source=reinsert`, `source.iterations=2`, `source.source=binned_sah`,
// `source.source.max_leaf=4` (a config's nested tables are read into the same keys), and the CSV form
// writes a named source's resolved parameters in parentheses after its name:
// `source=reinsert(iterations=2;...;source=binned_sah(bins=32;...))`.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace sahbench {

/// kChoice: one of a list of names, held as its index (min 0, max choices - 1) and written by name.
/// kSource: a binary tree source, a registered builder or pass with its own parameters (SourceSpec).
/// kPath: a file path, held as text and never opened here (builders do no file I/O); a config makes a
/// relative one relative to the config's folder, the command line relative to the current one, and the
/// resolved set holds it absolute. Where the parameter has an identity (ParamSpec::path_identity), the
/// CSV form records the file's name and that identity rather than the folder it lies in.
enum class ParamType { kInt, kFloat, kChoice, kSource, kPath };

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::kInt;
  double default_value = 0.0;
  double min_value = 0.0;
  double max_value = 0.0;
  std::string help;
  std::vector<std::string> choices = {};  ///< kChoice only
  /// kSource: the builder used when none is named.
  std::string default_source = {};
  /// kSource: builders that, named alone (no nested parameters), the pass builds with its own parameters
  /// (wide_collapse's bins and leaf sizes); their CSV form is the bare name. Any other source, or one of
  /// these given a nested parameter, is built with its own parameters over its own defaults.
  std::vector<std::string> shared_sources = {};
  /// Non-empty: applies only while the set's kSource parameter is a shared source named one of these (the
  /// pass's own binary build of it); otherwise it is not recorded (and the builder's check refuses it set
  /// away from its default).
  std::vector<std::string> only_with_sources = {};
  /// kPath: the file's identity (a hash of its contents) as text, given by whoever registers the
  /// parameter, since builders do no file I/O. When set, the CSV form records the file's name and then
  /// the identity as NAME_hash, so that a run over a changed file is another run and a run over the same
  /// file in another folder the same run.
  std::function<std::string(const std::string& path)> path_identity = {};
};

/// A kChoice parameter whose default is choices[default_index].
ParamSpec choice_param(std::string name, std::vector<std::string> choices, uint32_t default_index,
                       std::string help);

/// A kPath parameter, empty unless given; `identity` (if any) as ParamSpec::path_identity.
ParamSpec path_param(std::string name, std::string help,
                     std::function<std::string(const std::string&)> identity = {});

/// A kSource parameter: the pass takes a binary tree from `default_source` unless another is named.
ParamSpec source_param(std::string name, std::string default_source, std::string help,
                       std::vector<std::string> shared_sources = {});

using ParamOverrides = std::vector<std::pair<std::string, std::string>>;

struct BuilderInfo;
class ParamSet;

/// The value of a kSource parameter: which builder makes the pass's input tree, and with what.
struct SourceSpec {
  const BuilderInfo* info = nullptr;
  /// The source's resolved parameters; null for a shared source (ParamSpec::shared_sources), which the
  /// pass builds with its own.
  std::shared_ptr<const ParamSet> params;

  bool shared() const { return params == nullptr; }
  const std::string& name() const;
};

class ParamSet {
 public:
  /// One declared parameter and its value: a number (kChoice: the index), for kSource its source, for
  /// kPath its text and the file's identity (ParamSpec::path_identity, empty without one).
  struct Value {
    ParamSpec spec;
    double number = 0.0;
    SourceSpec source = {};
    std::string text = {};
    std::string identity = {};
    bool given = false;  ///< set by an override rather than left at its default
  };

  ParamSet() = default;
  ParamSet(std::string builder, std::vector<Value> values)
      : builder_(std::move(builder)), values_(std::move(values)) {}

  /// The value of a declared parameter; asking for an undeclared one is a programming error (throws).
  double get(std::string_view name) const;
  uint32_t get_uint(std::string_view name) const { return static_cast<uint32_t>(get(name)); }
  float get_float(std::string_view name) const { return static_cast<float>(get(name)); }
  /// Whether a parameter of that name is declared.
  bool has(std::string_view name) const;
  /// Whether a declared parameter was given (by an override, even one equal to its default).
  bool given(std::string_view name) const { return find(name).given; }
  /// The name chosen for a kChoice parameter.
  const std::string& get_choice(std::string_view name) const;
  /// The source of a kSource parameter.
  const SourceSpec& get_source(std::string_view name) const;
  /// The text of a kPath parameter (empty when not given).
  const std::string& get_path(std::string_view name) const;
  /// The identity a kPath parameter's file had when the set was resolved (empty without one).
  const std::string& get_path_identity(std::string_view name) const;
  /// Whether any kPath parameter, here or in a source's parameters, names a file.
  bool reads_files() const;
  /// The sources of this set's kSource parameters that have parameters of their own (not shared).
  std::vector<const SourceSpec*> own_sources() const;

  /// "key=value;key=value" in declaration order, integers without a fraction, a source as
  /// "NAME(its to_string())" unless shared, a path followed by NAME_hash=IDENTITY where it has one, and
  /// without the parameters whose only_with_sources the source is not among: the CSV form.
  std::string to_string() const;

 private:
  const Value& find(std::string_view name) const;

  std::string builder_;
  std::vector<Value> values_;
};

/// Resolves `overrides` against `specs`: unknown names, values that do not parse as the declared type,
/// values out of range, paths with characters the CSV form cannot hold and repeated names are errors naming
/// the builder, the key and the value. A kSource parameter's value names a registered builder, and keys
/// "P.KEY" are that source's own overrides, resolved against it (recursively) and checked by its
/// BuilderInfo::check; an unknown source, a key nested under a parameter that is not a source, and a source
/// that builds wider than binary trees are errors naming them.
ParamSet resolve_params(std::string_view builder, const std::vector<ParamSpec>& specs,
                        const ParamOverrides& overrides);

/// Parses "key=value" into its two parts; an argument without '=' is an error naming it.
std::pair<std::string, std::string> parse_override(std::string_view text);

}  // namespace sahbench
