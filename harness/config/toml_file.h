#pragma once
// Reading a TOML config file (experiment and stress configs alike), with errors that name the file and
// the line. Internal to the harness.

#include <toml++/toml.h>

#include <filesystem>
#include <string>
#include <string_view>

namespace sahbench {

/// The whole text of the file at `path`; `what` names it in the Error when it cannot be opened or read
/// ("<path>: cannot open the experiment config").
std::string read_config_text(const std::filesystem::path& path, const std::string& what);

/// `text` parsed as TOML; a syntax error is an Error "<source_name>:<line>:<column>: TOML syntax error:
/// ..." (line 1 where toml++ gives none).
toml::table parse_toml(std::string_view text, const std::string& source_name);

}  // namespace sahbench
