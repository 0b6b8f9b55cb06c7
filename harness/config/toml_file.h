#pragma once
// Reading a TOML config file, experiment and stress configs alike: the file's text, its parse, and the
// one kit of typed readers every config is read with, so that one mistake gets one message in either,
// "<file>:<line>: <key> must be an integer, not a string". Internal to harness/config.

#include <toml++/toml.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/error.h"

namespace sahbench {

/// `text` parsed as TOML; a syntax error is an Error "<source_name>:<line>:<column>: TOML syntax error:
/// ..." (line 1 where toml++ gives none).
toml::table parse_toml(std::string_view text, const std::string& source_name);

// The file being read, for the "<file>:<line>:" prefix of every message.
struct Source {
  std::string file;

  [[noreturn]] void fail(uint32_t line, const std::string& what) const {
    throw Error(file + ":" + std::to_string(line) + ": " + what);
  }
  [[noreturn]] void fail(const toml::node& at, const std::string& what) const { fail(line_of(at), what); }
  // Line 1 where toml++ recorded no position (e.g. a table only implied by a dotted key).
  static uint32_t line_of(const toml::node& node) { return std::max<uint32_t>(node.source().begin.line, 1); }
};

/// "a table", "a list", "a string", "an integer", ...: what a node is, for messages.
std::string type_name(const toml::node& node);

/// `items` separated by `separator`.
std::string join(const std::vector<std::string>& items, std::string_view separator = ", ");

/// A table's entries in file order: toml++ keeps keys sorted by name, but sweeps vary the last key written
/// fastest and errors should name the first offending key in the file.
std::vector<std::pair<std::string, const toml::node*>> in_file_order(const toml::table& table);

/// Fails on the first key of `table` (in file order) that is not in `known`, naming `table_name`.
void check_keys(const Source& src, const toml::table& table, std::string_view table_name,
                const std::vector<std::string>& known);

/// `node` as a table; anything else fails, naming `what`.
const toml::table& as_table(const Source& src, const toml::node& node, const std::string& what);

/// An integer in [min, max].
int64_t read_int(const Source& src, const toml::node& node, const std::string& key, int64_t min, int64_t max);

/// A float or an integer, finite, in [min, max].
double read_real(const Source& src, const toml::node& node, const std::string& key, double min, double max);

/// A non-empty string.
std::string read_string(const Source& src, const toml::node& node, const std::string& key);

/// One of `choices`, spelled exactly.
std::string read_choice(const Source& src, const toml::node& node, const std::string& key,
                        const std::vector<std::string>& choices);

/// A name that ends up in file names and CSV cells: letters, digits, '-' and '_'.
std::string read_name(const Source& src, const toml::node& node, const std::string& key);

/// A list (of `of`, for the message), non-empty unless `allow_empty`.
const toml::array& read_list(const Source& src, const toml::node& node, const std::string& key,
                             const std::string& of, bool allow_empty = false);

/// A list of distinct non-empty strings, non-empty unless `allow_empty`.
std::vector<std::string> read_string_list(const Source& src, const toml::node& node, const std::string& key,
                                          bool allow_empty = false);

/// The tables of an array of tables ([[key]]); `key = {...}` or anything else is an error.
std::vector<const toml::table*> read_table_array(const Source& src, const toml::node& node,
                                                 const std::string& key);

/// A config's spelling of each value of an enum.
template <class Enum>
using Spellings = std::vector<std::pair<std::string, Enum>>;

template <class Enum>
Enum read_enum(const Source& src, const toml::node& node, const std::string& key,
               const Spellings<Enum>& spellings) {
  std::vector<std::string> choices;
  for (const auto& [text, value] : spellings) choices.push_back(text);
  const std::string text = read_choice(src, node, key, choices);
  for (const auto& [t, value] : spellings)
    if (t == text) return value;
  throw Error("unreachable: " + text);  // read_choice accepted only spellings
}

template <class Enum>
std::string spelling(const Spellings<Enum>& spellings, Enum value) {
  for (const auto& [text, v] : spellings)
    if (v == value) return text;
  throw Error("invalid enumerator " + std::to_string(static_cast<int>(value)));
}

}  // namespace sahbench
