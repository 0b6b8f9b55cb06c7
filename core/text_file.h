#pragma once
// Reading and writing the files a user names (configs, ray files, result CSVs) with one kind of error:
// the path, what the file was to be, and why it cannot be, instead of a stream's silence (a directory
// opens as an empty stream) or its internal exception.

#include <filesystem>
#include <string>
#include <string_view>

namespace sahbench {

/// The whole of the file at `path`, read as the `what` ("config", "ray file", "result CSV"): a missing
/// file, a directory or a failed read is an Error naming the path and `what`.
std::string read_text_file(const std::filesystem::path& path, std::string_view what);

/// Refuses, with an Error naming it, a `path` to be written as the `what` that is a directory.
void require_file_path(const std::filesystem::path& path, std::string_view what);

}  // namespace sahbench
