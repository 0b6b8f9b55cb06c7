#pragma once
// "Did you mean ...?" for a mistyped name on the command line.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace sahbench {

/// The name of `names` closest to `typed` by edit distance (insertions, deletions, substitutions and
/// swaps of neighbours, as Damerau-Levenshtein), if one is within a third of the longer length, at least 1
/// edit, and closer than any other; nullopt otherwise.
std::optional<std::string> closest_name(std::string_view typed, const std::vector<std::string>& names);

}  // namespace sahbench
