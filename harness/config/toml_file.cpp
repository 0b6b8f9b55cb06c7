#include "harness/config/toml_file.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/error.h"

namespace sahbench {

toml::table parse_toml(std::string_view text, const std::string& source_name) {
  try {
    return toml::parse(text, std::string_view(source_name));
  } catch (const toml::parse_error& e) {
    const auto& at = e.source().begin;
    throw Error(source_name + ":" + std::to_string(std::max<uint32_t>(at.line, 1)) + ":" +
                std::to_string(at.column) + ": TOML syntax error: " + std::string(e.description()));
  }
}

std::string type_name(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::table:
      return "a table";
    case toml::node_type::array:
      return "a list";
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a float";
    case toml::node_type::boolean:
      return "a boolean";
    case toml::node_type::date:
      return "a date";
    case toml::node_type::time:
      return "a time";
    case toml::node_type::date_time:
      return "a date-time";
    default:
      return "nothing";
  }
}

std::string join(const std::vector<std::string>& items, std::string_view separator) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : std::string(separator)) + item;
  return out;
}

// A table's entries in file order: toml++ keeps keys sorted by name, but sweeps vary the last key written
// fastest and errors should name the first offending key in the file.
std::vector<std::pair<std::string, const toml::node*>> in_file_order(const toml::table& table) {
  std::vector<std::pair<const toml::key*, const toml::node*>> entries;
  for (const auto& [key, node] : table) entries.emplace_back(&key, &node);
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) {
    const auto& pa = a.first->source().begin;
    const auto& pb = b.first->source().begin;
    return pa.line != pb.line ? pa.line < pb.line : pa.column < pb.column;
  });
  std::vector<std::pair<std::string, const toml::node*>> out;
  for (const auto& [key, node] : entries) out.emplace_back(std::string(key->str()), node);
  return out;
}

// Fails on the first key of `table` (in file order) that is not in `known`.
void check_keys(const Source& src, const toml::table& table, std::string_view table_name,
                const std::vector<std::string>& known) {
  for (const auto& [key, node] : in_file_order(table)) {
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    const auto* list = node->as_array();
    const std::string what = node->is_table()                     ? "table [" + key + "]"
                             : list && list->is_array_of_tables() ? "table [[" + key + "]]"
                                                                  : "key '" + key + "'";
    src.fail(*node, "unknown " + what + " in " + std::string(table_name) + " (known: " + join(known) + ")");
  }
}

const toml::table& as_table(const Source& src, const toml::node& node, const std::string& what) {
  if (const auto* table = node.as_table()) return *table;
  src.fail(node, what + " must be a table, not " + type_name(node));
}

int64_t read_int(const Source& src, const toml::node& node, const std::string& key, int64_t min,
                 int64_t max) {
  const auto* value = node.as_integer();
  if (!value) src.fail(node, key + " must be an integer, not " + type_name(node));
  const int64_t v = value->get();
  // Limits at the type's range are no real limit: say only the bound that matters then.
  const bool unbounded = max >= std::numeric_limits<int>::max();
  if (v < min && unbounded)
    src.fail(node, key + " = " + std::to_string(v) + " must be at least " + std::to_string(min));
  if (v < min || v > max)
    src.fail(node, key + " = " + std::to_string(v) + " is outside [" + std::to_string(min) + ", " +
                       std::to_string(max) + "]");
  return v;
}

std::string read_string(const Source& src, const toml::node& node, const std::string& key) {
  const auto* value = node.as_string();
  if (!value) src.fail(node, key + " must be a string, not " + type_name(node));
  if (value->get().empty()) src.fail(node, key + " must not be empty");
  return value->get();
}

// One of `choices`, spelled exactly.
std::string read_choice(const Source& src, const toml::node& node, const std::string& key,
                        const std::vector<std::string>& choices) {
  std::string value = read_string(src, node, key);
  if (std::find(choices.begin(), choices.end(), value) == choices.end())
    src.fail(node, key + " = \"" + value + "\" is not one of " + join(choices, " | "));
  return value;
}

double read_real(const Source& src, const toml::node& node, const std::string& key, double min, double max) {
  double value = 0.0;
  if (const auto* f = node.as_floating_point()) {
    value = f->get();
  } else if (const auto* i = node.as_integer()) {
    value = static_cast<double>(i->get());
  } else {
    src.fail(node, key + " must be a number, not " + type_name(node));
  }
  if (!std::isfinite(value) || value < min || value > max)
    src.fail(node, fmt::format("{} = {} is outside [{}, {}]", key, value, min, max));
  return value;
}

// Names that end up in file names and CSV cells: letters, digits, '-' and '_'.
std::string read_name(const Source& src, const toml::node& node, const std::string& key) {
  std::string value = read_string(src, node, key);
  for (char c : value)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_'))
      src.fail(node, key + " = \"" + value + "\" may contain only letters, digits, '-' and '_'");
  return value;
}

const toml::array& read_list(const Source& src, const toml::node& node, const std::string& key,
                             const std::string& of, bool allow_empty) {
  const auto* list = node.as_array();
  if (!list) src.fail(node, key + " must be a list of " + of + ", not " + type_name(node));
  if (list->empty() && !allow_empty) src.fail(node, key + " must not be an empty list");
  return *list;
}

std::vector<std::string> read_string_list(const Source& src, const toml::node& node, const std::string& key,
                                          bool allow_empty) {
  std::vector<std::string> out;
  for (const auto& item : read_list(src, node, key, "strings", allow_empty)) {
    if (!item.is_string()) src.fail(item, key + " must be a list of strings, not contain " + type_name(item));
    std::string value = read_string(src, item, key + " item");
    if (std::find(out.begin(), out.end(), value) != out.end())
      src.fail(item, key + " lists \"" + value + "\" twice");
    out.push_back(std::move(value));
  }
  return out;
}

// The tables of an array of tables ([[key]]); `key = {...}` or anything else is an error.
std::vector<const toml::table*> read_table_array(const Source& src, const toml::node& node,
                                                 const std::string& key) {
  const auto* list = node.as_array();
  if (!list || !list->is_array_of_tables())
    src.fail(node, key + " must be written as [[" + key + "]] tables, not " + type_name(node));
  std::vector<const toml::table*> out;
  for (const auto& item : *list) out.push_back(item.as_table());
  return out;
}

}  // namespace sahbench
