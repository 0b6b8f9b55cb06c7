#include "harness/config/toml_file.h"

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace sahbench {

std::string read_config_text(const std::filesystem::path& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot open the " + what);
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(path.string() + ": cannot read the " + what);
  return text.str();
}

toml::table parse_toml(std::string_view text, const std::string& source_name) {
  try {
    return toml::parse(text, std::string_view(source_name));
  } catch (const toml::parse_error& e) {
    const auto& at = e.source().begin;
    throw Error(source_name + ":" + std::to_string(std::max<uint32_t>(at.line, 1)) + ":" +
                std::to_string(at.column) + ": TOML syntax error: " + std::string(e.description()));
  }
}

}  // namespace sahbench
