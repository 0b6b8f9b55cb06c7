#pragma once
// A minimal experiment config and the check of a config's errors, shared by the config and animation-run
// suites.

#include <gtest/gtest.h>

#include <initializer_list>
#include <string>
#include <string_view>

#include "core/error.h"
#include "harness/config/config.h"

namespace sahbench::test {

/// A valid static experiment config of 9 lines named `name`, over the one scene `scene`, with one
/// binned_sah builder and one primary ray set; tests append tables from line 10 on.
inline std::string minimal_config(std::string_view name, std::string_view scene) {
  return "[experiment]\nname = \"" + std::string(name) + "\"\nscenes = [\"" + std::string(scene) +
         "\"]\n\n[[builder]]\nname = \"binned_sah\"\n\n[[ray_set]]\nkind = \"primary\"\n";
}

/// Parses `text` as the file `source_name` and checks that the Error it throws starts with
/// "<source_name>:<line>:" and contains every one of `parts`.
inline void expect_config_error(std::string_view text, const std::string& source_name, int line,
                                std::initializer_list<std::string_view> parts) {
  std::string message;
  try {
    parse_experiment_config(text, source_name);
  } catch (const Error& e) {
    message = e.what();
  }
  ASSERT_FALSE(message.empty()) << "no error for:\n" << text;
  const std::string prefix = source_name + ":" + std::to_string(line) + ":";
  EXPECT_EQ(message.substr(0, prefix.size()), prefix) << message;
  for (auto part : parts)
    EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
}

}  // namespace sahbench::test
